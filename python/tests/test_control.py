"""Tracking policies from Python: gains against scipy's DARE, commands
against the policy law evaluated in numpy, closed-loop rollouts from a
solved trajectory."""

import numpy as np
import pytest
import scipy.linalg
import tandem


def double_integrator(n, dt, position, velocity, control):
    """The joint-space double integrator sampled every dt, with the policy's cost."""
    i, z = np.eye(n), np.zeros((n, n))
    a = np.block([[i, dt * i], [z, i]])
    b = np.vstack([0.5 * dt * dt * i, dt * i])
    q = np.diag([position] * n + [velocity] * n)
    return a, b, q, control * i


def dare_gain(n, dt, weights):
    a, b, q, r = double_integrator(n, dt, *weights)
    p = scipy.linalg.solve_discrete_are(a, b, q, r)
    return np.linalg.solve(r + b.T @ p @ b, b.T @ p @ a)


def reference(n=3, steps=60, dt=0.05):
    s = np.linspace(0.0, 1.0, steps)[:, None]
    blend = s**3 * (10 - 15 * s + 6 * s * s)
    return np.linspace(0.2, -0.4, n) + blend * np.linspace(0.5, 1.0, n), dt


def test_constant_gain_equals_scipy_dare():
    ref, dt = reference()
    for weights in [(100.0, 1.0, 0.1), (10.0, 0.5, 2.0)]:
        policy = tandem.TrackingPolicy(
            ref, dt, position_weight=weights[0], velocity_weight=weights[1], control_weight=weights[2]
        )
        k = policy.gain()
        expected = dare_gain(3, dt, weights)
        assert k.shape == (3, 6)
        assert np.abs(k - expected).max() < 1e-12 * np.abs(expected).max()  # seen 4.0e-15


def test_time_varying_gains_stay_at_the_dare_gain():
    """The finite-horizon recursion starts from the DARE cost-to-go, its
    fixed point: every waypoint's gain is the DARE gain."""
    ref, dt = reference()
    policy = tandem.TrackingPolicy(ref, dt, schedule="time_varying")
    expected = dare_gain(3, dt, (100.0, 1.0, 0.1))
    for i in [0, len(ref) // 2, len(ref) - 1]:
        assert np.abs(policy.gain(i) - expected).max() < 3e-12 * np.abs(expected).max()  # seen 3.1e-14


def test_query_follows_the_policy_law():
    """command = v + (−K e)·dt, e = [q − q_d, v − v_d] at the waypoint after
    the closest one (velocity feedforward only, the default)."""
    ref, dt = reference()
    policy = tandem.TrackingPolicy(ref, dt, joints=["a", "b", "c"])
    assert policy.joint_names == ["a", "b", "c"] and policy.dof == 3 and policy.dt == dt
    np.testing.assert_array_equal(policy.reference, ref)
    k = policy.gain()
    rng = np.random.default_rng(5)
    for _ in range(50):
        i = int(rng.integers(0, len(ref) - 2))
        q = ref[i] + 0.01 * rng.standard_normal(3)
        v = 0.1 * rng.standard_normal(3)
        policy.reset()
        command, index, distance, target = policy.query_with_info(q, v)
        closest = int(np.argmin(np.linalg.norm(ref - q, axis=1)))
        assert index == closest and target == min(closest + 1, len(ref) - 1)
        assert distance == pytest.approx(np.linalg.norm(ref[closest] - q), rel=1e-12)
        vd = (ref[target] - ref[target - 1]) / dt if 0 < target < len(ref) - 1 else np.zeros(3)
        error = np.concatenate([q - ref[target], v - vd])
        np.testing.assert_allclose(command, v - (k @ error) * dt, rtol=0, atol=1e-13)  # seen: equal
        out = np.empty(3)
        policy.reset()
        assert policy.query(q, v, out=out) is out
        np.testing.assert_array_equal(out, command)


def test_policy_from_a_solved_trajectory_tracks_it_to_the_goal():
    problem = tandem.Problem.builtin("panda_reach")
    solution = tandem.solve(problem, seed=1)
    assert solution.converged
    trajectory = solution.trajectory
    # The reference starts at the start configuration (once).
    if not np.array_equal(trajectory[0], problem.start):
        trajectory = np.vstack([problem.start, trajectory])
    policy = tandem.TrackingPolicy(trajectory, solution.time_step, joints=solution.joint_names)
    rng = np.random.default_rng(6)
    for _ in range(5):
        start = problem.start + 0.05 * rng.standard_normal(7)
        path = policy.rollout(start, 3 * len(trajectory))
        assert path.shape == (3 * len(trajectory) + 1, 7)
        np.testing.assert_array_equal(path[0], start)
        assert np.linalg.norm(path[-1] - trajectory[-1]) < 1e-3
    # Queries of one rollout step by step give the same path.
    policy.reset()
    q, v = problem.start.copy(), np.zeros(7)
    stepped = [q.copy()]
    for _ in range(20):
        v = policy.query(q, v)
        q = q + v * solution.time_step
        stepped.append(q.copy())
    np.testing.assert_allclose(np.array(stepped), policy.rollout(problem.start, 20), rtol=0, atol=1e-14)
