"""Train an arbitration policy on tandem's Gymnasium environment with
Stable-Baselines3's DDPG (the algorithm of the dissertation's chapter 6)
or SAC.

Not run in CI: Stable-Baselines3 pulls in PyTorch (a ~700 MB wheel).

    pip install . stable-baselines3          # from the repository root
    python examples/python/train_sb3.py --algo ddpg --steps 100000

The same task, trained by tandem's own DDPG (candle, deterministic per
seed) and evaluated in Table 6.1: `tandem experiment learned`.
"""

import argparse

import gymnasium as gym
import numpy as np

import tandem.gym  # noqa: F401  (registers the environments)


def evaluate(env, act, episodes=50):
    """Success rate and mean return of ``act(obs)`` over fresh episodes."""
    successes, returns = 0, []
    for seed in range(10_000, 10_000 + episodes):
        obs, _ = env.reset(seed=seed)
        total, info = 0.0, {}
        while True:
            obs, reward, terminated, truncated, info = env.step(act(obs))
            total += reward
            if terminated or truncated:
                break
        successes += info.get("outcome") == "success"
        returns.append(total)
    return successes / episodes, float(np.mean(returns))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--env", default="tandem/PlanarArbitration-v0")
    parser.add_argument("--algo", choices=["ddpg", "sac"], default="ddpg")
    parser.add_argument("--steps", type=int, default=100_000)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()

    from stable_baselines3 import DDPG, SAC
    from stable_baselines3.common.noise import NormalActionNoise

    env = gym.make(args.env)
    n = env.action_space.shape[0]
    if args.algo == "ddpg":
        noise = NormalActionNoise(mean=np.zeros(n), sigma=0.15 * np.ones(n))
        model = DDPG("MlpPolicy", env, action_noise=noise, seed=args.seed, verbose=1)
    else:
        model = SAC("MlpPolicy", env, seed=args.seed, verbose=1)
    model.learn(total_timesteps=args.steps)
    learned = evaluate(env, lambda obs: model.predict(obs, deterministic=True)[0])
    direct = evaluate(env, env.unwrapped.follow_user)
    print(f"learned: success {learned[0]:.0%}, mean return {learned[1]:.1f}")
    print(f"direct control: success {direct[0]:.0%}, mean return {direct[1]:.1f}")
    model.save(f"arbitration_{args.algo}")


if __name__ == "__main__":
    main()
