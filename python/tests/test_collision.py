"""Collision checks and signed distances from Python: consistency of the
boolean, minimum and all-pairs queries, witness points, gradients against
finite differences, and the batch queries."""

import numpy as np
import tandem

CONFIGURATIONS = 200


def configurations(robot, rng, count):
    lower, upper = robot.lower_limits, robot.upper_limits
    return lower + (upper - lower) * rng.random((count, robot.nq))


def test_boolean_minimum_and_all_pairs_agree():
    problem = tandem.Problem.builtin("panda_grasp_box")
    model = problem.collision_model()
    assert len(model.pairs) > 100 and ("panda_hand", "box") not in model.pairs
    qs = configurations(problem.robot, np.random.default_rng(7), CONFIGURATIONS)
    free = model.collision_free_many(qs)
    minima = model.min_distances(qs)
    assert 0 < free.sum() < len(qs)  # both kinds occur
    for q, is_free, minimum in zip(qs, free, minima):
        closest = model.min_distance(q)
        assert closest.distance == minimum
        assert model.collision_free(q) == is_free == (minimum > 0)
        every = model.distances(q)
        assert len(every) == len(model.pairs)
        assert min(d.distance for d in every) == minimum
        assert [d.pair for d in every] == list(range(len(model.pairs)))
        assert model.pairs[closest.pair] == closest.bodies
        near = model.distances(q, 0.05)
        assert [d.pair for d in near] == [d.pair for d in every if d.distance < 0.05]


def test_witness_points_and_normals():
    problem = tandem.Problem.builtin("panda_reach_obstacle")
    model = problem.collision_model()
    for d in model.distances(problem.start, 0.3):
        assert abs(np.linalg.norm(d.normal) - 1.0) < 1e-12
        np.testing.assert_allclose(d.point_b - d.point_a, d.distance * d.normal, atol=1e-14)  # seen 1.1e-16


def test_gradients_match_finite_differences():
    problem = tandem.Problem.builtin("panda_reach_obstacle")
    model = problem.collision_model()
    rng = np.random.default_rng(8)
    h, worst, checked = 1e-6, 0.0, 0
    for q in [problem.start, problem.goal["q"]] + list(configurations(problem.robot, rng, 20)):
        near = [d for d in model.distances(q, 0.2, gradients=True) if abs(d.distance) > 1e-4]
        if not near:
            continue  # (pairs in contact are not differentiable there)
        numeric = np.zeros((len(model.pairs), 7))
        for k in range(7):
            step = np.zeros(7)
            step[k] = h
            plus = [d.distance for d in model.distances(q + step)]
            minus = [d.distance for d in model.distances(q - step)]
            numeric[:, k] = (np.array(plus) - np.array(minus)) / (2 * h)
        for d in near:
            worst = max(worst, np.abs(d.gradient - numeric[d.pair]).max())
            checked += 1
    assert checked > 20
    assert worst < 2e-8, worst  # central differences, h = 1e-6: largest seen 1.9e-10
    closest = model.min_distance(problem.start, gradient=True)
    assert closest.gradient.shape == (7,)
    assert model.min_distance(problem.start).gradient is None


def test_self_collision_model_and_motions():
    robot = tandem.RobotModel.panda()
    model = tandem.CollisionModel(robot)
    assert model.robot.joint_names == robot.joint_names and model.padding == 0.0
    assert all(not a.startswith("table") for a, _ in model.pairs)
    ready = np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785])
    assert model.collision_free(ready)
    folded = ready.copy()
    folded[3] = -0.1  # elbow folded onto the base
    folded[1] = 1.7
    assert not model.collision_free(folded) or model.min_distance(folded).distance > 0
    padded = tandem.CollisionModel(robot, padding=0.01)
    assert padded.min_distance(ready).distance < model.min_distance(ready).distance
    problem = tandem.Problem.builtin("panda_reach_obstacle")
    scene = problem.collision_model()
    start, goal = problem.start, problem.goal["q"]
    # Straight through the wall: blocked; each end on its own is free.
    assert scene.collision_free(start) and scene.collision_free(goal)
    assert not scene.motion_free(start, goal)
    assert not scene.motion_free_certified(start, goal, 0.002)
    assert scene.path_free(tandem.plan(problem, seed=0).path)
    assert scene.path_free(np.array([start]))
