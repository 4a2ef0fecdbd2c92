"""Problems, IK, planning and trajectory optimization from Python: results
judged with Pinocchio's forward kinematics (independent of tandem's) and
compared with the command line on the same problem and seed."""

import json
import subprocess

import numpy as np
import pinocchio as pin
import pytest
import tandem
from conftest import GRASP_FAMILY, PANDA_URDF

# Acceptance of a reached goal (the generator's: 1 mm, 10 mrad).
GOAL_DISTANCE = 1e-3
GOAL_ANGLE = 1e-2


class PinPanda:
    """tandem's Panda in Pinocchio, arm joints from tandem, fingers open."""

    def __init__(self):
        self.model = pin.buildModelFromUrdf(str(PANDA_URDF))
        self.data = self.model.createData()
        self.tcp = self.model.getFrameId("panda_hand_tcp")

    def tcp_pose(self, q):
        full = pin.neutral(self.model)
        full[:7] = q
        full[7:9] = 0.04
        pin.framesForwardKinematics(self.model, self.data, full)
        return self.data.oMf[self.tcp].homogeneous


@pytest.fixture(scope="module")
def pin_panda():
    return PinPanda()


def angle_between(a, b):
    return np.arccos(np.clip(np.dot(a, b) / np.linalg.norm(a) / np.linalg.norm(b), -1.0, 1.0))


def rotation_angle(r):
    return np.arccos(np.clip((np.trace(r) - 1.0) / 2.0, -1.0, 1.0))


def test_problems_load():
    assert set(tandem.Problem.builtin_names()) >= {"panda_reach", "panda_reach_obstacle", "panda_grasp_box"}
    grasp = tandem.Problem.builtin("panda_grasp_box")
    assert grasp.gripper == "panda_hand_tcp" and grasp.joint_names == tandem.RobotModel.panda().joint_names
    goal = grasp.goal
    assert goal["kind"] == "grasp" and goal["object"] == "box" and goal["pose"].shape == (4, 4)
    [box] = grasp.objects
    np.testing.assert_allclose(goal["pose"], box["pose"] @ box["grasps"][goal["grasp"]], atol=1e-15)
    assert {o["name"] for o in grasp.obstacles} >= {"table"}
    from_file = tandem.Problem.from_file(GRASP_FAMILY.parent / "panda_grasp_box.toml")
    np.testing.assert_array_equal(from_file.start, grasp.start)
    assert from_file.origin.endswith("panda_grasp_box.toml")


def test_family_members_are_reproducible():
    family = tandem.ProblemFamily.from_file(GRASP_FAMILY)
    assert family.name == "panda_grasp_family" and family.base.name == "panda_grasp_box"
    a, b, other = family.sample(5, seed=3), family.sample(5, seed=3), family.sample(6, seed=3)
    assert a.name == "panda_grasp_family#5"
    np.testing.assert_array_equal(a.start, b.start)
    np.testing.assert_array_equal(a.objects[0]["pose"], b.objects[0]["pose"])
    assert not np.array_equal(a.start, other.start)
    assert a.collision_model().collision_free(a.start)


def test_plan_reaches_the_goal_without_collision():
    problem = tandem.Problem.builtin("panda_reach_obstacle")
    result = tandem.plan(problem, seed=1)
    assert result.solved and result.status == "solved" and result.certified
    path, goals = result.path, result.goals
    np.testing.assert_array_equal(path[0], problem.start)
    np.testing.assert_array_equal(path[-1], problem.goal["q"])
    np.testing.assert_array_equal(goals, [problem.goal["q"]])
    model = problem.collision_model()
    assert model.path_free(path, resolution=0.002)
    assert model.collision_free_many(path).all()
    assert result.planning_time > 0 and result.iterations > 0 and result.nodes >= 2
    # The same seed, the same path.
    np.testing.assert_array_equal(tandem.plan(problem, seed=1).path, path)


def test_solve_reaches_a_pose_goal(pin_panda):
    problem = tandem.Problem.builtin("panda_reach")
    solution = tandem.solve(problem, seed=1)
    assert solution.converged and solution.status == "converged", solution.report()
    trajectory = solution.trajectory
    assert trajectory.shape == (problem.horizon + 1, 7)
    np.testing.assert_array_equal(trajectory[0], problem.start)
    assert solution.time_step == pytest.approx(problem.duration / problem.horizon)
    model = problem.collision_model()
    assert model.path_free(trajectory, resolution=0.002)
    robot = problem.robot
    assert all(robot.within_limits(q) for q in trajectory)
    final = pin_panda.tcp_pose(trajectory[-1])
    goal = problem.goal
    assert np.linalg.norm(final[:3, 3] - goal["position"]) < GOAL_DISTANCE
    assert angle_between(final[:3, goal["axis"]], goal["direction"]) < GOAL_ANGLE
    np.testing.assert_allclose(robot.frame_pose(trajectory[-1], "panda_hand_tcp"), final, atol=1e-9)


def test_solve_matches_the_command_line(tandem_cli):
    """The same problem and seed through the CLI and the package: the same trajectory."""
    problem = tandem.Problem.builtin("panda_reach_obstacle")
    solution = tandem.solve(problem, seed=2)
    out = subprocess.run(
        [tandem_cli, "solve", "builtin:panda_reach_obstacle", "--seed", "2", "--json"],
        capture_output=True,
        text=True,
        check=True,
    )
    cli = json.loads(out.stdout)
    assert cli["status"] == solution.status
    assert cli["joints"] == solution.joint_names
    np.testing.assert_array_equal(np.array(cli["trajectory"]), solution.trajectory)
    assert cli["cost"] == solution.cost


def test_grasp_goal_configurations_and_solve(pin_panda):
    problem = tandem.Problem.builtin("panda_grasp_box")
    target = problem.goal["pose"]
    goals = tandem.goal_configurations(problem, seed=0)
    assert 1 <= len(goals) <= 4
    model = problem.collision_model()
    for q in goals:
        pose = pin_panda.tcp_pose(q)
        assert np.linalg.norm(pose[:3, 3] - target[:3, 3]) < 1e-4
        assert rotation_angle(pose[:3, :3].T @ target[:3, :3]) < 1e-3
        assert model.collision_free(q)
    solution = tandem.solve(problem, seed=0)
    assert solution.converged, solution.report()
    final = pin_panda.tcp_pose(solution.trajectory[-1])
    assert np.linalg.norm(final[:3, 3] - target[:3, 3]) < GOAL_DISTANCE
    assert rotation_angle(final[:3, :3].T @ target[:3, :3]) < GOAL_ANGLE
    assert solution.plan.solved and solution.min_distance is not None


def test_solve_ik_reaches_targets(pin_panda):
    robot = tandem.RobotModel.panda()
    model = tandem.CollisionModel(robot)
    rng = np.random.default_rng(4)
    lower, upper = robot.lower_limits, robot.upper_limits
    reached = 0
    for _ in range(5):
        q = lower + (upper - lower) * (0.2 + 0.6 * rng.random(7))
        if not model.collision_free(q):
            continue
        target = pin_panda.tcp_pose(q)
        found = tandem.solve_ik(
            model, "panda_hand_tcp", target[:3, 3], orientation=target[:3, :3], seed=1, count=2
        )
        assert found.shape[1] == 7 and 1 <= len(found) <= 2
        for solution in found:
            pose = pin_panda.tcp_pose(solution)
            assert np.linalg.norm(pose[:3, 3] - target[:3, 3]) < 1e-5
            assert rotation_angle(pose[:3, :3].T @ target[:3, :3]) < 1e-4
            assert model.collision_free(solution) and robot.within_limits(solution)
        reached += 1
    assert reached >= 3
    # An axis goal only: z of the hand pointing down.
    [q] = tandem.solve_ik(model, "panda_hand_tcp", [0.5, 0.0, 0.4], axis=2, direction=[0, 0, -1])
    pose = pin_panda.tcp_pose(q)
    assert np.linalg.norm(pose[:3, 3] - [0.5, 0.0, 0.4]) < 1e-5
    assert angle_between(pose[:3, 2], [0, 0, -1]) < 1e-4


SRDF = """<?xml version="1.0"?>
<robot name="panda">
  <group name="panda_arm">
    <chain base_link="panda_link0" tip_link="panda_link8"/>
  </group>
  <disable_collisions link1="panda_link0" link2="panda_link2" reason="Never"/>
</robot>
"""

SCENE = """world:
  collision_objects:
    - id: shelf
      primitives:
        - type: box
          dimensions: [0.3, 0.6, 0.04]
      primitive_poses:
        - position: [0.55, 0.0, 0.45]
          orientation: [0, 0, 0, 1]
allowed_collision_matrix:
  entry_names: [panda_link0, shelf]
  entry_values:
    - [false, false]
    - [false, false]
"""

REQUEST = """group_name: panda_arm
start_state:
  joint_state:
    name: [panda_joint1, panda_joint2, panda_joint3, panda_joint4, panda_joint5, panda_joint6, panda_joint7, panda_finger_joint1]
    position: [-1.2, -0.3, 0.0, -2.2, 0.0, 1.9, 0.785, 0.03]
goal_constraints:
  - joint_constraints:
{goal}
"""


def test_moveit_inputs(tmp_path, pin_panda):
    """A MoveIt planning scene and motion plan request become a problem:
    the box primitive as an obstacle, start and joint goal as given, the
    finger held where the request starts it; the planned path is collision-free."""
    goal = [1.2, -0.3, 0.0, -2.2, 0.0, 1.9, 0.785]
    files = {"panda.srdf": SRDF, "scene.yaml": SCENE}
    files["request.yaml"] = REQUEST.format(
        goal="\n".join(f"      - joint_name: panda_joint{i + 1}\n        position: {v}" for i, v in enumerate(goal))
    )
    for name, text in files.items():
        (tmp_path / name).write_text(text)
    srdf, scene, request = (tmp_path / n for n in ["panda.srdf", "scene.yaml", "request.yaml"])
    problem = tandem.Problem.from_moveit(PANDA_URDF, srdf, scene, request)
    assert problem.name == "request" and problem.joint_names == [f"panda_joint{i}" for i in range(1, 8)]
    np.testing.assert_array_equal(problem.start, [-1.2, -0.3, 0.0, -2.2, 0.0, 1.9, 0.785])
    np.testing.assert_array_equal(problem.goal["q"], goal)
    [shelf] = problem.obstacles
    assert shelf["name"] == "shelf" and shelf["shape"] == "box"
    np.testing.assert_allclose(shelf["size"], [0.3, 0.6, 0.04])
    np.testing.assert_allclose(shelf["pose"][:3, 3], [0.55, 0.0, 0.45])
    # The finger is held at the request's 0.03 m: Pinocchio places the left finger there.
    pin_q = pin.neutral(pin_panda.model)
    pin_q[:7], pin_q[7:9] = problem.start, 0.03
    pin.framesForwardKinematics(pin_panda.model, pin_panda.data, pin_q)
    finger = pin_panda.data.oMf[pin_panda.model.getFrameId("panda_leftfinger")].homogeneous
    np.testing.assert_allclose(problem.robot.frame_pose(problem.start, "panda_leftfinger"), finger, atol=1e-12)
    model = problem.collision_model()
    assert ("panda_link0", "panda_link2") not in model.pairs
    result = tandem.plan(problem, seed=0)
    assert result.solved
    np.testing.assert_array_equal(result.path[-1], goal)
    assert model.path_free(result.path, resolution=0.002)
    # A request without a goal is an error naming the file.
    (tmp_path / "bad.yaml").write_text(files["request.yaml"].split("goal_constraints")[0])
    with pytest.raises(tandem.ProblemError, match="bad.yaml"):
        tandem.Problem.from_moveit(PANDA_URDF, srdf, scene, tmp_path / "bad.yaml")


def test_point_clouds_from_numpy_are_obstacles():
    """An N x 3 array as a problem's obstacle: a wall far from the arm
    plans and keeps clear; points through the hand at the start make it
    start_invalid; a sensor pose places the points; NaN rows are dropped;
    thinning only brings obstacles closer; bad arrays are refused."""
    base = tandem.Problem.builtin("panda_reach")
    grid = np.array([[-0.6, -0.5 + 0.02 * i, 0.1 + 0.02 * j] for i in range(51) for j in range(40)])
    walled = base.with_point_cloud(grid, 0.01, name="wall")
    assert any(o["name"] == "wall" and o["shape"] == "points" for o in walled.obstacles)
    result = tandem.plan(walled, seed=1)
    assert result.solved and result.certified
    assert walled.collision_model().path_free(result.path, resolution=0.002)
    # The same wall in a camera's frame: 1 m along x, turned 90 degrees about z.
    pose = np.array([[0.0, -1.0, 0.0, 1.0], [1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]])
    local = (grid - pose[:3, 3]) @ pose[:3, :3]  # world = R local + t
    seen = base.with_point_cloud(np.vstack([local, [[np.nan, 0.0, 0.0]]]), 0.01, name="wall", pose=pose)

    def to_wall(problem):
        pairs = problem.collision_model().distances(base.start)
        return min(d.distance for d in pairs if "wall" in d.bodies)

    d_world, d_seen = to_wall(walled), to_wall(seen)
    assert 0.3 < d_world and abs(d_world - d_seen) < 1e-9, (d_world, d_seen)
    # Thinned at 5 cm the balls grow by 5 cm: closer than the full cloud, by at most the spacing.
    d_thin = to_wall(base.with_point_cloud(grid, 0.01, name="wall", spacing=0.05))
    assert d_world - 0.05 - 1e-9 <= d_thin <= d_world, (d_world, d_thin)
    hand = np.array([[0.2 + 0.005 * k, 0.0, 0.59] for k in range(50)])
    blocked = tandem.plan(base.with_point_cloud(hand, 0.01, name="hand"), seed=1)
    assert blocked.status == "start_invalid"
    for bad, kwargs in [(grid[:, :2], {}), (grid, {"pose": np.eye(3)}), (grid, {"pose": 2 * np.eye(4)})]:
        with pytest.raises(ValueError):
            base.with_point_cloud(bad, 0.01, **kwargs)
    with pytest.raises(ValueError):
        base.with_point_cloud(grid, -1.0)
    with pytest.raises(tandem.ProblemError):
        walled.with_point_cloud(grid, 0.01, name="wall")
