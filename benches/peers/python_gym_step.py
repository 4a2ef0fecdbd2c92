"""Per-step cost of tandem's Gymnasium environments from Python
(``tandem.gym``): ``env.step`` with the action that follows the user, over
whole episodes (reset excluded), for the planar and the Panda task. Each
step is one simulated-user action, one arbiter observation (beliefs,
sub-policy actions, the 17-value state), one constrained tick, a
collision check and Algorithm 5's reward. Target: under 100 µs.

    python python_gym_step.py [--episodes E] [--json out.json]
"""

import argparse
import json
import statistics
import time
from pathlib import Path

import gymnasium as gym

import tandem.gym  # noqa: F401  (registers the environments)


def measure(env_id, episodes):
    env = gym.make(env_id).unwrapped
    times = []
    for seed in range(episodes):
        obs, _ = env.reset(seed=seed)
        while True:
            action = env.follow_user(obs)
            began = time.perf_counter_ns()
            obs, _, terminated, truncated, _ = env.step(action)
            times.append((time.perf_counter_ns() - began) / 1e3)
            if terminated or truncated:
                break
    times.sort()
    return {"steps": len(times), "median_us": statistics.median(times), "p99_us": times[int(0.99 * (len(times) - 1))]}


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--episodes", type=int, default=10)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    results = {}
    print(f"{'environment':<32} {'steps':>7} {'median µs':>10} {'p99 µs':>10}")
    for env_id in ("tandem/PlanarArbitration-v0", "tandem/PandaArbitration-v0"):
        r = measure(env_id, args.episodes)
        results[env_id] = r
        print(f"{env_id:<32} {r['steps']:>7} {r['median_us']:>10.1f} {r['p99_us']:>10.1f}")
    if args.json:
        args.json.write_text(json.dumps(results, indent=2) + "\n")


if __name__ == "__main__":
    main()
