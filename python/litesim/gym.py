"""A gymnasium environment around a litesim test: the agent drives sut.car.

    from litesim.gym import ScenarioEnv
    env = ScenarioEnv("examples/scenarios/cut_in.osc")
    obs, info = env.reset(seed=3)
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())

Observation (float32, shape (1 + max_objects, 6)):
    row 0, the ego: speed, requested speed, distance to goal (capped at
    1000 m), lateral offset in its lane (0 off-road), length, width;
    rows 1.., the nearest other actors in the ego's frame: present (1/0),
    dx, dy, relative heading, speed, length (zeros where absent).
Action: throttle 0..1, brake 0..1, steering −1..1.
Reward: metres advanced at the requested speed's pace (speed·dt, less
the overshoot above the requested speed), −100 when the run ends failed.
"""
from __future__ import annotations

from typing import Any, Dict, Optional, Tuple

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from . import _native

BIG = 1e6


class ScenarioEnv(gym.Env):
    """One litesim test as an episode; each step is one simulation step."""

    metadata = {"render_modes": []}

    def __init__(self, test: str, max_objects: int = 8, mode: Optional[str] = None):
        super().__init__()
        if not isinstance(max_objects, int) or max_objects < 0:
            raise ValueError(f"max_objects: expected an int ≥ 0, got {max_objects!r}")
        self.test = str(test)
        self.max_objects = max_objects
        self.mode = mode
        self.observation_space = spaces.Box(-BIG, BIG, shape=(1 + max_objects, 6), dtype=np.float32)
        self.action_space = spaces.Box(
            np.array([0.0, 0.0, -1.0], dtype=np.float32),
            np.array([1.0, 1.0, 1.0], dtype=np.float32),
            dtype=np.float32,
        )
        # The test is prepared once (parsed, its map loaded); each episode
        # is a run stepped on this thread, its observations encoded natively.
        self._episodes = _native.Episodes(self.test, mode, max_objects)
        self._running = False

    def reset(self, *, seed: Optional[int] = None, options: Optional[Dict[str, Any]] = None):
        super().reset(seed=seed)
        # The litesim seed: the one given, else one drawn from the env's RNG.
        # A drawn seed whose scenario cannot be set up (an actor that
        # cannot be placed: an invalid run) is drawn again; a given one is
        # an error that says why.
        for _ in range(100):
            run_seed = seed if seed is not None else int(self.np_random.integers(1, 2**31 - 1))
            try:
                obs, t = self._episodes.reset(run_seed)
                break
            except _native.LitesimError as e:
                if seed is not None or not str(e).startswith("the run ended before its first step: invalid"):
                    raise
                why = str(e)
        else:
            raise _native.LitesimError(f"{self.test}: 100 drawn seeds in a row could not be set up (the last: {why})")
        self._running = True
        return obs, {"time": t, "seed": run_seed}

    def step(self, action) -> Tuple[np.ndarray, float, bool, bool, Dict[str, Any]]:
        if not self._running:
            raise RuntimeError("call reset() before step()")
        a = np.asarray(action, dtype=np.float64).reshape(-1)
        if a.shape != (3,):
            raise ValueError(f"action: expected 3 numbers (throttle, brake, steering), got shape {np.shape(action)}")
        # Clipped to the action space (plain floats: np.clip costs more
        # than the simulation step).
        throttle = min(max(float(a[0]), 0.0), 1.0)
        brake = min(max(float(a[1]), 0.0), 1.0)
        steering = min(max(float(a[2]), -1.0), 1.0)
        obs, reward, terminated, info = self._episodes.step(throttle, brake, steering)
        if terminated:
            self._running = False
        return obs, reward, terminated, False, info

    def close(self):
        self._episodes.close()
        self._running = False
