"""The Gymnasium environments of tandem.gym: the checker, determinism per
seed, the observation layout, the hard constraints and the reward."""

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import tandem
import tandem.gym  # noqa: F401  (registers the environments)

IDS = ["tandem/PlanarArbitration-v0", "tandem/PandaArbitration-v0", "tandem/PandaArbitrationPhysics-v0"]


@pytest.mark.parametrize("env_id", IDS)
def test_environments_pass_the_checker(env_id):
    env = gym.make(env_id)
    check_env(env.unwrapped, skip_render_check=True)
    assert env.observation_space.shape == (17,)
    assert env.action_space.shape == ((2,) if "Planar" in env_id else (3,))


@pytest.mark.parametrize("env_id", IDS)
def test_episodes_are_deterministic_per_seed(env_id):
    def rollout(seed):
        env = gym.make(env_id)
        obs, _ = env.reset(seed=seed)
        seen = [obs]
        for _ in range(40):
            obs, reward, terminated, truncated, _ = env.step(env.unwrapped.follow_user(obs))
            seen.append(np.append(obs, reward))
            if terminated or truncated:
                break
        return seen

    a, b, c = rollout(5), rollout(5), rollout(6)
    assert len(a) == len(b) and all(np.array_equal(x, y) for x, y in zip(a, b))
    assert not np.array_equal(a[0], c[0])


def test_following_the_user_reaches_the_goal_without_collisions():
    env = gym.make("tandem/PlanarArbitration-v0")
    outcomes = []
    for seed in range(4):
        obs, _ = env.reset(seed=seed)
        info = {}
        for _ in range(2000):
            obs, reward, terminated, truncated, info = env.step(env.unwrapped.follow_user(obs))
            assert np.isfinite(reward)
            if terminated or truncated:
                break
        outcomes.append(info["outcome"])
    # Under the hard constraints nothing is ever touched.
    assert "collision" not in outcomes
    assert all(o in ("success", "failed", "timeout") for o in outcomes)


def test_the_reward_prefers_agreement_and_the_environment_reward_is_separate():
    combined = gym.make("tandem/PlanarArbitration-v0")
    environment = gym.make("tandem/PlanarArbitration-v0", reward="environment")
    obs, _ = combined.reset(seed=2)
    environment.reset(seed=2)
    human = combined.unwrapped.follow_user(obs)
    _, r_follow, *_ = combined.step(human)
    _, r_env, *_ = environment.step(human)
    combined.reset(seed=2)
    _, r_oppose, *_ = combined.step(-human)
    assert r_follow > r_oppose
    assert r_env in (0.0, -2.0, 10.0)


def test_bad_actions_and_tasks_raise_tandem_errors():
    env = tandem.ArbitrationEnv("planar")
    with pytest.raises(tandem.ArbitrationError, match="before reset"):
        env.step(np.zeros(2))
    env.reset(1)
    with pytest.raises(tandem.ArbitrationError, match="2 finite values"):
        env.step(np.array([np.nan, 0.0]))
    with pytest.raises(tandem.ArbitrationError, match="'planar' or 'panda'"):
        tandem.ArbitrationEnv("mars")


def test_the_learned_mode_needs_an_actor_file(tmp_path):
    problem = tandem.Problem.builtin("planar_pick")
    with pytest.raises(tandem.ArbitrationError, match="needs a trained arbitration actor"):
        tandem.Arbiter(problem, mode="learned")
    bad = tmp_path / "actor.safetensors"
    bad.write_bytes(b"not a tensor file")
    with pytest.raises(tandem.ArbitrationError, match="not a safetensors file"):
        tandem.Arbiter(problem, mode="learned", actor=str(bad))


def test_the_simulator_experiments_run_from_python():
    planar = tandem.run_planar_experiment(tasks=1, seed=0)
    users = {e["user"] for e in planar}
    methods = {e["method"] for e in planar}
    assert users == {"straight", "noisy-0.5", "noisy-1", "biased"}
    assert "direct" in methods and len(planar) == len(users) * len(methods)
    # Every assisted method keeps the hard constraints.
    assert all(e["hard_violations"] == 0 for e in planar if e["method"] != "direct")
    assert planar == tandem.run_planar_experiment(tasks=1, seed=0)
    grasp = tandem.run_reach_grasp_experiment(tasks=1, seed=0, arm="right")
    assert len(grasp) == 7 * 6
    assert {e["outcome"] for e in grasp} <= {"success", "collision", "failed", "timeout"}
    with pytest.raises(tandem.ArbitrationError, match="'right', 'left' or 'both'"):
        tandem.run_reach_grasp_experiment(arm="middle")


def test_the_physics_variant_ends_as_the_kinematic_one_when_the_user_is_followed():
    """MuJoCo moves the arm. Following the user (direct control, which never
    turns the gripper) touches nothing and ends as the kinematic variant
    does on these seeds: the grasp judge refuses the tilted gripper, so the
    fingers never close. (A lifted box: tests/physics_mujoco.rs.)"""

    def outcomes(env_id):
        env = gym.make(env_id)
        seen = []
        for seed in range(4):
            obs, _ = env.reset(seed=seed)
            info = {}
            for _ in range(1000):
                obs, reward, terminated, truncated, info = env.step(env.unwrapped.follow_user(obs))
                assert np.all(np.isfinite(obs)) and np.isfinite(reward)
                if terminated or truncated:
                    break
            seen.append(info["outcome"])
        return seen

    physics = outcomes("tandem/PandaArbitrationPhysics-v0")
    assert "collision" not in physics, physics
    assert all(o in ("success", "failed", "timeout") for o in physics)
    assert physics == outcomes("tandem/PandaArbitration-v0")


def test_physics_is_refused_on_the_planar_task():
    with pytest.raises(tandem.TandemError, match="Panda task only"):
        tandem.gym.ArbitrationEnv("planar", physics=True)
