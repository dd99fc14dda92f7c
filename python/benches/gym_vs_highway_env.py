"""ScenarioEnv against highway-env, side by side on this machine (issue
"a run costs what its physics costs"): a 500-step episode of two cars at
50 Hz in each, step and reset medians.

    pip install highway-env ./python
    python3 python/benches/gym_vs_highway_env.py

highway-env: `highway-v0`, 2 lanes, 1 other vehicle (IDM), 50 Hz
simulation and policy, 10 s (500 steps), continuous action 0, no
rendering. litesim: examples/scenarios/cut_in.osc (two cars, 10 s at
20 ms: 500 steps), pedals (0.3, 0, 0).
"""
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
EPISODES = int(sys.argv[1]) if len(sys.argv) > 1 else 20


def episodes(reset, step, n):
    resets, steps, whole = [], [], []
    for k in range(n):
        t0 = time.perf_counter()
        reset(k)
        t1 = time.perf_counter()
        resets.append(t1 - t0)
        count = 0
        while True:
            t = time.perf_counter()
            done = step()
            steps.append(time.perf_counter() - t)
            count += 1
            if done:
                break
        whole.append(time.perf_counter() - t0)
    return statistics.median(resets), statistics.median(steps), statistics.median(whole), count


def highway():
    import gymnasium as gym
    import highway_env  # noqa: F401  (registers the envs)

    env = gym.make(
        "highway-v0",
        config={
            "lanes_count": 2,
            "vehicles_count": 1,
            "controlled_vehicles": 1,
            "simulation_frequency": 50,
            "policy_frequency": 50,
            "duration": 10,
            "action": {"type": "ContinuousAction"},
            "offscreen_rendering": True,
        },
    )
    act = np.zeros(2, dtype=np.float32)
    env.reset(seed=0)

    def step():
        _, _, term, trunc, _ = env.step(act)
        return term or trunc

    return episodes(lambda k: env.reset(seed=k), step, EPISODES)


def litesim_env():
    from litesim.gym import ScenarioEnv

    env = ScenarioEnv(str(ROOT / "examples/scenarios/cut_in.osc"))
    act = np.array([0.3, 0.0, 0.0], dtype=np.float32)
    env.reset(seed=1)

    def step():
        _, _, term, trunc, _ = env.step(act)
        return term or trunc

    return episodes(lambda k: env.reset(), step, EPISODES)


if __name__ == "__main__":
    rows = [("highway-env", highway()), ("litesim ScenarioEnv", litesim_env())]
    for name, (r, s, e, n) in rows:
        print(f"{name:20s} reset {r * 1e6:8.0f} µs  step {s * 1e6:7.1f} µs  episode ({n} steps) {e * 1e3:8.2f} ms")
    print(f"episode ratio: litesim {rows[0][1][2] / rows[1][1][2]:.0f}× faster")
