"""Gymnasium environments for learning arbitration (chapter 6 of the
dissertation).

A simulated user drives a robot toward one of several goals; the agent
arbitrates. Each step it observes the arbitration state — gripper
position, each goal relative to it, the distance and direction to the
nearest obstacle, every goal-conditioned sub-policy's action (as a gripper
velocity) and belief, and the user's command: 17 values, positions over
0.1 m and velocities over the user speed — and returns the arbitrated
gripper velocity (scaled to [−1, 1]: ±1 is twice the user speed), which tandem's
arbiter executes under its hard constraints (joint limits and velocities,
collision distances). The reward is the dissertation's Algorithm 5: agree
with the user at decision points (where the sub-policies' von Mises mixture is
multimodal), with the user's goal's sub-policy elsewhere, at the user's
speed; plus −10 for touching an obstacle (the episode ends), −2 per step at
the workspace border and +10 for reaching the user's goal.

Registered ids:

- ``tandem/PlanarArbitration-v0``: the planar gripper of §6.5 behind a pole,
  two cylinders near the far edge, users straight, noisy-0.5, noisy-1 and
  biased at 5 cm/s, 30 Hz, 20 s; actions are x–y velocities.
- ``tandem/PandaArbitration-v0``: the Panda reach-and-grasp task of Table 5.1
  (a box on the table, the seven operators of Table 5.1 at 10 cm/s);
  actions are 3-D gripper velocities.
- ``tandem/PandaArbitrationPhysics-v0``: the same task with MuJoCo moving the
  arm (a build with the ``mujoco`` feature, ``pip install mujoco==3.17.0``):
  the goal counts once the fingers close on the box, lift it 10 cm and hold
  it 1 s; touching the table or the other arm, or pushing the box 2 cm, is a
  collision.

Episodes are deterministic per ``reset(seed=...)``. ``reward="environment"``
gives the environment reward alone.

>>> import gymnasium as gym
>>> import tandem.gym  # registers the environments
>>> env = gym.make("tandem/PlanarArbitration-v0")
>>> obs, info = env.reset(seed=3)
>>> action = env.unwrapped.follow_user(obs)   # the user's command as an action
>>> obs, reward, terminated, truncated, info = env.step(action)
"""

from __future__ import annotations

from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces

from ._native import ArbitrationEnv as _NativeEnv

__all__ = ["ArbitrationEnv", "PlanarArbitrationEnv", "PandaArbitrationEnv", "PandaArbitrationPhysicsEnv"]


class ArbitrationEnv(gymnasium.Env):
    """The arbitration-learning environment on ``task`` (``"planar"`` or ``"panda"``)."""

    metadata = {"render_modes": []}

    def __init__(
        self, task: str = "planar", reward: str = "combined", max_time: float | None = None, physics: bool = False
    ):
        self._env = _NativeEnv(task, reward=reward, max_time=max_time, physics=physics)
        width, dims = self._env.state_width, self._env.action_width
        # Normalised actions (as Stable-Baselines3 advises): ±1 is the
        # environment's largest command, twice the user speed.
        self._scale = self._env.max_action
        self.observation_space = spaces.Box(-np.inf, np.inf, shape=(width,), dtype=np.float64)
        self.action_space = spaces.Box(-1.0, 1.0, shape=(dims,), dtype=np.float64)
        self.task = task

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        episode = int(self.np_random.integers(0, 2**63 - 1))
        obs = self._env.reset(episode)
        return obs, {"episode_seed": episode}

    def step(self, action):
        action = np.asarray(action, dtype=np.float64).reshape(-1)
        action = np.clip(action, self.action_space.low, self.action_space.high)
        return self._env.step(action * self._scale)

    def human_command(self, obs: np.ndarray) -> np.ndarray:
        """The user's command in an observation (units of the user speed)."""
        return np.asarray(obs[self._env.human_offset :], dtype=np.float64)

    def follow_user(self, obs: np.ndarray) -> np.ndarray:
        """The action that executes the user's command as given (direct control)."""
        return np.clip(self.human_command(obs) / self._scale, -1.0, 1.0)


class PlanarArbitrationEnv(ArbitrationEnv):
    """``tandem/PlanarArbitration-v0``: the planar task of §6.5 of the dissertation."""

    def __init__(self, reward: str = "combined", max_time: float | None = None):
        super().__init__("planar", reward=reward, max_time=max_time)


class PandaArbitrationEnv(ArbitrationEnv):
    """``tandem/PandaArbitration-v0``: the Panda reach-and-grasp task of Table 5.1."""

    def __init__(self, reward: str = "combined", max_time: float | None = None):
        super().__init__("panda", reward=reward, max_time=max_time)


class PandaArbitrationPhysicsEnv(ArbitrationEnv):
    """``tandem/PandaArbitrationPhysics-v0``: the Panda task with MuJoCo under the arm."""

    def __init__(self, reward: str = "combined", max_time: float | None = None):
        super().__init__("panda", reward=reward, max_time=max_time, physics=True)


def _register() -> None:
    for name, entry in (
        ("tandem/PlanarArbitration-v0", "tandem.gym:PlanarArbitrationEnv"),
        ("tandem/PandaArbitration-v0", "tandem.gym:PandaArbitrationEnv"),
        ("tandem/PandaArbitrationPhysics-v0", "tandem.gym:PandaArbitrationPhysicsEnv"),
    ):
        if name not in gymnasium.registry:
            gymnasium.register(id=name, entry_point=entry)


_register()
