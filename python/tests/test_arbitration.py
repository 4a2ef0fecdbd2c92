"""The per-tick arbiter from Python: the same commands as the Rust tick,
hard limits on every command, the safe fallback on NaN, errors as
exceptions, and a shared-control episode to a grasp."""

import numpy as np
import pytest

import tandem


@pytest.fixture(scope="module")
def grasp():
    problem = tandem.Problem.builtin("panda_grasp_box")
    return problem, tandem.Arbiter(problem, mode="sos", seed=0)


def test_a_nan_command_holds_and_the_next_tick_works(grasp):
    problem, arbiter = grasp
    arbiter.reset()
    qdot, status, info = arbiter.tick(problem.start, [np.nan, 0.0, 0.0])
    assert status == "invalid_command" and not qdot.any()
    qdot, status, info = arbiter.tick(problem.start, [0.0, 0.0, -0.05])
    assert status in ("nominal", "constrained", "step_shortened"), status
    assert np.abs(qdot).max() > 1e-4
    assert info["mode"] == "sos" and len(info["beliefs"]) == len(arbiter.goals) == 1
    # Wrong lengths and an unknown kind.
    assert arbiter.tick(problem.start, [0.1, 0.0])[1] == "invalid_command"
    assert arbiter.tick(problem.start[:3], [0.1, 0.0, 0.0])[1] == "invalid_state"
    with pytest.raises(tandem.ArbitrationError, match="kind must be"):
        arbiter.tick(problem.start, [0.1, 0.0, 0.0], kind="wrench")


def test_bad_settings_are_errors():
    problem = tandem.Problem.builtin("panda_grasp_box")
    with pytest.raises(tandem.ArbitrationError, match="mode"):
        tandem.Arbiter(problem, mode="telepathy")
    with pytest.raises(tandem.ArbitrationError, match="margin"):
        tandem.Arbiter(problem, margin=-1.0)
    with pytest.raises(tandem.ArbitrationError, match="sum_of_squares_center"):
        tandem.Arbiter(problem, sos_center=float("nan"))


def test_a_centred_arbiter_adds_the_robot_action_where_the_operator_is_silent():
    """With the operator still, sum of squares keeps the gripper still
    (κ = 0, eq. 5.4) or, centred (κ = 0.5), moves the arm where the
    operator's command leaves it free: within ε of no gripper motion, the
    joints move toward the robot's action."""
    problem = tandem.Problem.builtin("panda_grasp_box")
    still = tandem.Arbiter(problem, mode="sos", seed=0)
    centred = tandem.Arbiter(problem, mode="sos", seed=0, sos_center=0.5)
    # Off the reference (where the robot's action is feedback, not zero).
    q = problem.start.copy()
    q[0] += 0.1
    q[3] += 0.1
    zero = [0.0, 0.0, 0.0]
    a, status_a, _ = still.tick(q, zero)
    b, status_b, _ = centred.tick(q, zero)
    assert status_a == "nominal" and status_b == "nominal", (status_a, status_b)
    assert np.abs(a).max() < 1e-12, a
    # Measured: 0.058 rad/s at most, the gripper at 1.8 mm/s (2 % of the joints' speed).
    assert np.abs(b).max() > 0.01, b
    jac = problem.robot.frame_jacobian(q, "panda_hand_tcp")[:3]
    assert np.linalg.norm(jac @ b) < 0.2 * np.linalg.norm(b), (jac @ b, b)


def test_an_episode_reaches_the_grasp_within_limits(grasp):
    """An operator pushing the gripper toward the grasp point at 10 cm/s,
    stepped kinematically: every command within the velocity limits, every
    configuration within the position limits and collision-free (checked by
    the collision model, sampled between ticks), the gripper ends at the
    grasp point pointing down."""
    problem, arbiter = grasp
    robot, model = problem.robot, problem.collision_model()
    target = np.array(arbiter.goal_positions[0])
    arbiter.reset()
    q, velocity = problem.start.copy(), np.zeros(robot.nq)
    out = np.zeros(robot.nq)
    for _ in range(300):
        tcp = robot.frame_pose(q, "panda_hand_tcp")
        error = target - tcp[:3, 3]
        if np.linalg.norm(error) < 0.005:
            break
        command = 0.1 * error / max(np.linalg.norm(error), 0.1)
        qdot, status, _ = arbiter.tick(q, command, velocity=velocity, out=out)
        assert qdot is out
        assert np.all(np.abs(qdot) <= robot.velocity_limits + 1e-9), status
        step = q + arbiter.period * qdot
        assert model.path_free(np.vstack([q, step]), resolution=0.002)
        q, velocity = step, qdot.copy()
        assert robot.within_limits(q)
    tcp = robot.frame_pose(q, "panda_hand_tcp")
    assert np.linalg.norm(target - tcp[:3, 3]) < 0.005
    assert tcp[2, 2] < -np.cos(0.2)  # the approach axis points down within 0.2 rad
