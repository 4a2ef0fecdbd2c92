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


def closest_point(ref, q):
    """The closest point of the polyline through ``ref`` (earliest of ties),
    as a waypoint coordinate s, and its distance."""
    best = (0.0, np.inf)
    for i in range(len(ref) - 1):
        a, b = ref[i], ref[i + 1]
        t = float(np.clip((q - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0))
        d = float(np.linalg.norm(q - a - t * (b - a)))
        if d < best[1] * (1 - 1e-9):
            best = (i + t, d)
    return best


def at(table, s):
    i = min(int(np.floor(s)), len(table) - 1)
    return table[i] if i == len(table) - 1 else table[i] + (s - i) * (table[i + 1] - table[i])


def test_query_follows_the_policy_law():
    """command = v + (−K e)·dt, e = [q − q_d, v − v_d] at the point one
    waypoint past the closest point of the reference polyline, interpolated
    (velocity feedforward only, the default)."""
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
        command, progress, distance, target = policy.query_with_info(q, v)
        s, d = closest_point(ref, q)
        assert progress == pytest.approx(s, abs=1e-12) and target == pytest.approx(min(s + 1, len(ref) - 1), abs=1e-12)
        assert distance == pytest.approx(d, rel=1e-12)
        velocities = np.vstack([np.zeros(3), np.diff(ref, axis=0) / dt])
        vd = at(velocities, target) if target < len(ref) - 1 else np.zeros(3)
        error = np.concatenate([q - at(ref, target), v - vd])
        np.testing.assert_allclose(command, v - (k @ error) * dt, rtol=0, atol=1e-12)
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
