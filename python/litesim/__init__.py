"""litesim from Python: deterministic scenario runs with your own system
under test, in-process.

    import litesim
    r = litesim.run("examples/scenarios/cut_in.osc", seed=3, sut="acc")
    r.passed, r.failures, r.kpis["pairs"], r.log   # log: a pandas DataFrame

A SUT is any object with ``step(observation) -> Command`` (and optionally
``reset(info)``); it is called in lock step with the simulation, in this
process, with no gRPC in between. Its ``step`` is looked up once a run,
before ``reset``.
"""
from __future__ import annotations

import json
import os
from typing import Any, Dict, List, Optional, Sequence, Union

from . import _native
from ._native import Command, LitesimError, Observation, ObjectState, Simulator, __version__

__all__ = [
    "Command",
    "LitesimError",
    "Observation",
    "ObjectState",
    "Prepared",
    "Result",
    "Simulator",
    "prepare",
    "run",
    "__version__",
]

PathLike = Union[str, "os.PathLike[str]"]


class Result:
    """The outcome of one run.

    Attributes:
        passed: every check held.
        verdict: ``"pass"``, ``"fail"`` (a check on the SUT failed),
            ``"invalid"`` (the scenario was not realised: a non-SUT actor
            missed its goal; the reasons are in ``invalid``) or ``"error"``
            (the run could not be carried out: the SUT raised or answered
            something invalid, its traceback is in ``failures``).
        failures: why it failed, one sentence each (litesim's wording).
        invalid: why the scenario was not realised, one sentence each.
        summary: the whole summary (what ``litesim run`` writes as summary.json).
        kpis: the summary's measurements: ``actors``, ``pairs`` (min distance,
            min TTC, collisions), ``ego``, ``goals``.
    """

    def __init__(self, native: "_native.NativeRun"):
        self._native = native
        self.passed: bool = native.passed
        self.failures: List[str] = list(native.failures)
        # The summary is parsed when first read: a batch that looks at the
        # verdict only does not pay for it (half of the Python layer's cost).
        self._summary: Optional[Dict[str, Any]] = None
        self.verdict: str = native.verdict
        self._log = None

    @property
    def invalid(self) -> List[str]:
        """Why the scenario was not realised (empty when it was)."""
        return list(self.summary.get("invalid", []))

    @property
    def summary(self) -> Dict[str, Any]:
        """The whole summary (what ``litesim run`` writes as summary.json)."""
        if self._summary is None:
            self._summary = json.loads(self._native.summary_json)
        return self._summary

    @property
    def kpis(self) -> Dict[str, Any]:
        """The summary's measurements: actors, pairs, ego, goals."""
        return {k: self.summary.get(k) for k in ("actors", "pairs", "ego", "goals")}

    @property
    def log(self):
        """The log, one row per actor and tick (tick, time, actor, mode, x, y,
        yaw, vx, vy, speed, yaw_rate, throttle, brake, steering, acceleration,
        lateral_acceleration): a pandas DataFrame, or a dict of numpy arrays
        when pandas is not installed; None when the run did not record."""
        if self._log is None:
            cols = self._native.log_columns()
            if cols is None:
                return None
            import numpy as np

            arrays = {
                k: np.asarray(v, dtype=object if k in ("actor", "mode") else None)
                for k, v in cols.items()
            }
            try:
                import pandas as pd
            except ImportError:
                self._log = arrays
            else:
                self._log = pd.DataFrame(arrays)
        return self._log

    def log_json(self) -> Optional[str]:
        """The log as litesim's JSON (the bytes `litesim run` writes as log.json)."""
        return self._native.log_json()

    def __repr__(self) -> str:
        s = self.summary
        return (
            f"Result({s.get('test')!r} seed {s.get('seed')}: {self.verdict}, "
            f"{s.get('steps')} steps, sut {s.get('sut')})"
        )


def _path(name: str, v: Any) -> str:
    if isinstance(v, (str, os.PathLike)):
        return os.fspath(v)
    raise TypeError(f"{name}: expected a path (str or os.PathLike), got {type(v).__name__}")


class Prepared:
    """A test read, checked and elaborated, with its map loaded
    (:func:`prepare`): what every run of it shares, made once. Pass it to
    :func:`run` in place of the path to run the test again without reading
    it again (a batch does the same per test). It holds what was read: edit
    the files and prepare again to see the change."""

    __slots__ = ("_native",)

    def __init__(self, native: Any):
        self._native = native

    @property
    def path(self) -> str:
        """The test file."""
        return os.fspath(self._native.path)

    @property
    def source_hash(self) -> str:
        """SHA-256 of the test's sources as read (the file and its imports)."""
        return self._native.source_hash

    def __repr__(self) -> str:
        return f"Prepared({self.path!r})"


def _load_options(map: Any, include: Any, dialect: Any, map_dir: Any):
    if isinstance(include, (str, os.PathLike)):
        include = [include]
    inc = [_path("include", p) for p in include]
    m = None if map is None else _path("map", map)
    if dialect not in (None, "litesim", "carla"):
        raise ValueError(f"dialect: expected 'litesim', 'carla' or None, got {dialect!r}")
    md = None if map_dir is None else _path("map_dir", map_dir)
    return m, inc, dialect, md


def prepare(
    test: PathLike,
    *,
    map: Optional[PathLike] = None,
    include: Sequence[PathLike] = (),
    dialect: Optional[str] = None,
    map_dir: Optional[PathLike] = None,
) -> Prepared:
    """Reads, checks and elaborates a test and loads its map, once, for many
    :func:`run` calls: ``p = litesim.prepare(path); litesim.run(p, seed=s)``
    gives the same result as ``litesim.run(path, seed=s)``, without reading
    the test again. The load options are :func:`run`'s.

    Raises:
        TypeError / ValueError: a parameter of the wrong type or value (named).
        LitesimError: the test or its map could not be read (litesim's message).
    """
    test = _path("test", test)
    m, inc, d, md = _load_options(map, include, dialect, map_dir)
    return Prepared(_native.prepare(test, m, inc, d, md))


def run(
    test: Union[PathLike, Prepared],
    seed: Optional[int] = None,
    sut: Any = None,
    *,
    mode: Optional[str] = None,
    record: bool = True,
    map: Optional[PathLike] = None,
    include: Sequence[PathLike] = (),
    sut_timeout: Optional[float] = None,
    dialect: Optional[str] = None,
    map_dir: Optional[PathLike] = None,
    npc: str = "driver",
) -> Result:
    """Runs an OpenSCENARIO DSL test once.

    Args:
        test: the .osc (or .xosc) file, or a :class:`Prepared` test (then
            ``map``, ``include``, ``dialect`` and ``map_dir`` were
            :func:`prepare`'s and are not given again).
        seed: the seed (default: the test's, else 1).
        sut: what drives sut.car: None (its plan), ``"acc"``, ``"acc-aeb"``,
            ``"fmt-mpc"``,
            ``"grpc://HOST:PORT"``, or an object with ``step(observation)``
            returning a :class:`Command` (or a dict of throttle/brake/steering
            or acceleration/curvature) and optionally ``reset(info)``.
        mode: ``"kinematic"`` or ``"dynamic"`` (default: the test's).
        record: keep the log (``Result.log``).
        map: an OpenDRIVE map overriding the test's.
        include: import search paths.
        sut_timeout: seconds a gRPC SUT may take per call.
        dialect: ``"litesim"`` or ``"carla"`` (CARLA scenario_runner's OSC2,
            docs/carla.md); default: detected.
        map_dir: folder of OpenDRIVE maps for a CARLA scenario's
            ``path.set_map("Town04")`` (``Town04.xodr``).
        npc: what drives the other vehicles: ``"driver"`` (a driver each,
            the default) or ``"planned"`` (each replays its plan), as
            ``litesim run --npc``.

    Raises:
        TypeError / ValueError: a parameter of the wrong type or value (named).
        LitesimError: the test could not be read or run (litesim's message).
    """
    # With a Prepared test, load options given again are refused by the
    # native run (a ValueError naming the first).
    target = test._native if isinstance(test, Prepared) else _path("test", test)
    if npc not in ("driver", "planned"):
        raise ValueError(f"npc: expected 'driver' or 'planned', got {npc!r}")
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int)):
        raise TypeError(f"seed: expected an int, got {type(seed).__name__}")
    if seed is not None and seed < 0:
        raise ValueError(f"seed: {seed} is negative; seeds are 0..2**64-1")
    if not isinstance(record, bool):
        raise TypeError(f"record: expected a bool, got {type(record).__name__}")
    if mode is not None and not isinstance(mode, str):
        raise TypeError(f"mode: expected 'kinematic', 'dynamic' or None, got {type(mode).__name__}")
    m, inc, d, md = _load_options(map, include, dialect, map_dir)
    return Result(
        _native.run(target, seed, sut, mode, record, m, inc, sut_timeout, d, md, npc)
    )
