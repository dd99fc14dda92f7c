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

import math
from typing import Any, Dict, Optional, Tuple

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from . import _native
from ._native import Command

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
        self._run: Optional[_native.SteppedRun] = None
        self._last: Optional[_native.Observation] = None
        self._dt = 0.02

    def _encode(self, o: "_native.Observation") -> np.ndarray:
        out = np.zeros((1 + self.max_objects, 6), dtype=np.float32)
        e = o.ego
        road = o.road
        out[0] = [
            e.speed,
            o.requested_speed,
            min(o.distance_to_goal, 1000.0) if math.isfinite(o.distance_to_goal) else 1000.0,
            road["offset"] if road else 0.0,
            e.length,
            e.width,
        ]
        c, s = math.cos(e.yaw), math.sin(e.yaw)
        near = sorted(o.objects, key=lambda a: (a.x - e.x) ** 2 + (a.y - e.y) ** 2)
        for i, a in enumerate(near[: self.max_objects]):
            dx, dy = a.x - e.x, a.y - e.y
            dyaw = math.atan2(math.sin(a.yaw - e.yaw), math.cos(a.yaw - e.yaw))
            out[1 + i] = [1.0, dx * c + dy * s, -dx * s + dy * c, dyaw, a.speed, a.length]
        return np.clip(out, -BIG, BIG)

    def reset(self, *, seed: Optional[int] = None, options: Optional[Dict[str, Any]] = None):
        super().reset(seed=seed)
        if self._run is not None:
            self._run.close()
        # The litesim seed: the one given, else one drawn from the env's RNG.
        run_seed = seed if seed is not None else int(self.np_random.integers(1, 2**31 - 1))
        self._run = _native.SteppedRun(self.test, run_seed, self.mode)
        ev = self._run.next()
        if ev[0] != "obs":
            raise _native.LitesimError(f"the run ended before its first step: {ev[2]}")
        self._last = ev[1]
        return self._encode(self._last), {"time": self._last.time, "seed": run_seed}

    def step(self, action) -> Tuple[np.ndarray, float, bool, bool, Dict[str, Any]]:
        if self._run is None or self._last is None:
            raise RuntimeError("call reset() before step()")
        a = np.clip(np.asarray(action, dtype=np.float64).reshape(-1), self.action_space.low, self.action_space.high)
        if a.shape != (3,):
            raise ValueError(f"action: expected 3 numbers (throttle, brake, steering), got shape {np.shape(action)}")
        prev = self._last
        self._run.send(Command.pedals(float(a[0]), float(a[1]), float(a[2])))
        ev = self._run.next()
        if ev[0] == "obs":
            o = ev[1]
            dt = max(o.time - prev.time, 0.0)
            over = max(0.0, o.ego.speed - max(o.requested_speed, 0.0))
            reward = (o.ego.speed - 2.0 * over) * dt
            self._last = o
            return self._encode(o), float(reward), False, False, {"time": o.time}
        _, passed, failures, _summary = ev
        obs = self._encode(prev)
        self._last = None
        self._run = None
        return obs, 0.0 if passed else -100.0, True, False, {"passed": passed, "failures": failures}

    def close(self):
        if self._run is not None:
            self._run.close()
            self._run = None
