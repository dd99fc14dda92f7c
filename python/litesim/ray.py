"""Batches on a Ray cluster: the runs fan out as tasks of many runs each;
the folder written is the one `litesim batch` writes for the same tests and
seeds, byte for byte (manifest, results.jsonl, results.csv, coverage.json).

    import litesim.ray
    litesim.ray.batch(["examples/scenarios/cut_in.osc"], range(1, 2001), out="b", address="auto")

or from the command line: ``litesim batch TESTS --seeds 1..2000 --ray auto``
(which runs ``python3 -m litesim.ray``). A task whose worker dies is run
again (Ray's retries); each (test, seed) keeps one line, so nothing is
duplicated.
"""
from __future__ import annotations

import argparse
import os
import socket
import sys
import time
from typing import Any, Iterable, List, Optional, Sequence, Tuple, Union

from . import _native
from ._native import LitesimError

Seeds = Union[range, Tuple[int, int], str]


def _seed_range(seeds: Seeds) -> Tuple[int, int]:
    """Inclusive (first, last)."""
    if isinstance(seeds, range):
        if seeds.step != 1 or len(seeds) == 0:
            raise ValueError(f"seeds: expected a non-empty range with step 1, got {seeds!r}")
        return seeds.start, seeds.stop - 1
    if isinstance(seeds, str):
        a, sep, b = seeds.partition("..")
        try:
            lo, hi = int(a), int(b) if sep else int(a)
        except ValueError:
            raise ValueError(f"seeds: '{seeds}' is not A..B (inclusive)") from None
    elif isinstance(seeds, tuple) and len(seeds) == 2:
        lo, hi = seeds
    else:
        raise TypeError(f"seeds: expected a range, (first, last) or 'A..B', got {type(seeds).__name__}")
    if not (isinstance(lo, int) and isinstance(hi, int)) or lo < 0 or hi < lo:
        raise ValueError(f"seeds: {seeds!r} is not a range of seeds (0 ≤ first ≤ last)")
    return lo, hi


def _check_address(address: str, timeout: float) -> None:
    """A cluster address that does not answer is an error within `timeout` s
    (ray.init would wait much longer)."""
    if address in ("auto", "local") or address.startswith("ray://"):
        target = address[len("ray://"):] if address.startswith("ray://") else None
    else:
        target = address
    if not target:
        return
    host, _, port = target.rpartition(":")
    try:
        with socket.create_connection((host or "127.0.0.1", int(port)), timeout=timeout):
            pass
    except (OSError, ValueError) as e:
        raise LitesimError(f"Ray cluster at {address} does not answer ({e}); start one with `ray start --head` or give --ray auto") from None


def _connect(address: Optional[str], timeout: float):
    import ray

    if address not in (None, "local"):
        _check_address(address, timeout)
    if ray.is_initialized():
        return ray
    if address in (None, "local"):
        ray.init(include_dashboard=False, log_to_driver=False)
        return ray
    try:
        ray.init(address=address, log_to_driver=False)
    except ConnectionError as e:
        raise LitesimError(f"no Ray cluster at {address}: {e}") from None
    return ray


def _chunk(jobs: List[Tuple[str, int]], sut: Any, mode: Optional[str], root: str) -> List[str]:
    from litesim import _native as native

    # Tests are named relative to the driver's folder, and results (and
    # the messages in them) must read exactly as a local batch's: work from
    # that folder. A worker runs one task at a time.
    os.chdir(root)
    return native.run_lines(jobs, sut, mode)


def batch(
    tests: Sequence[Union[str, "os.PathLike[str]"]],
    seeds: Seeds,
    sut: Any = None,
    *,
    out: Union[str, "os.PathLike[str]"] = "batch",
    address: Optional[str] = "auto",
    runs_per_task: int = 50,
    max_retries: int = 3,
    mode: Optional[str] = None,
    force_new: bool = False,
    progress: bool = True,
    connect_timeout: float = 10.0,
) -> Tuple[int, int, int]:
    """Runs every test under every seed on Ray and writes the batch folder.

    Args:
        tests: .osc files (named as given, as `litesim batch` names them).
        seeds: ``range(1, 2001)``, ``(1, 2000)`` or ``"1..2000"`` (inclusive).
        sut: as for :func:`litesim.run` (a Python object is pickled to the workers).
        out: the folder.
        address: the cluster (``"auto"``, ``"HOST:PORT"``, ``"ray://HOST:PORT"``),
            or ``"local"``/None to start one in this process.
        runs_per_task: runs per Ray task (fewer tasks, less overhead).
        max_retries: times a task whose worker died is run again.
        progress: print a progress line to stderr.

    Returns:
        (runs, passed, failed), with the most severe verdict of the folder's
        runs as ``.verdict`` (``"pass"``, ``"invalid"``, ``"fail"``,
        ``"error"``).
    """
    tests = [os.fspath(t) for t in tests]
    if not tests:
        raise ValueError("tests: at least one test")
    lo, hi = _seed_range(seeds)
    if not isinstance(runs_per_task, int) or runs_per_task < 1:
        raise ValueError(f"runs_per_task: expected an int ≥ 1, got {runs_per_task!r}")
    ray = _connect(address, connect_timeout)
    task = ray.remote(max_retries=max_retries)(_chunk)
    jobs = [(t, s) for t in tests for s in range(lo, hi + 1)]
    # Workers read relative test paths from the driver's folder (a cluster
    # of several machines needs the tests at the same path on each).
    root = os.getcwd()
    pending = [task.remote(jobs[i : i + runs_per_task], sut, mode, root) for i in range(0, len(jobs), runs_per_task)]
    lines: List[str] = []
    done = 0
    started = time.monotonic()
    while pending:
        ready, pending = ray.wait(pending, num_returns=1)
        for r in ready:
            got = ray.get(r)
            lines.extend(got)
            done += len(got)
        if progress:
            rate = done / max(time.monotonic() - started, 1e-9)
            print(f"\r{done}/{len(jobs)} runs  {rate:.0f}/s", end="", file=sys.stderr, flush=True)
    if progress:
        print(file=sys.stderr)
    runs, passed, failed, verdict = _native.write_batch(tests, lo, hi, os.fspath(out), lines, sut, mode, force_new)
    return BatchResult(runs, passed, failed, verdict)


class BatchResult(tuple):
    """(runs, passed, failed) of a batch, with its most severe verdict as
    ``verdict``."""

    verdict: str

    def __new__(cls, runs: int, passed: int, failed: int, verdict: str) -> "BatchResult":
        t = super().__new__(cls, (runs, passed, failed))
        t.verdict = verdict
        return t


def main(argv: Optional[Iterable[str]] = None) -> int:
    ap = argparse.ArgumentParser(prog="python3 -m litesim.ray", description="litesim batch on a Ray cluster")
    ap.add_argument("tests", nargs="+")
    ap.add_argument("--seeds", default="1..100")
    ap.add_argument("--ray", dest="address", default="auto", help="cluster address (auto, HOST:PORT, ray://HOST:PORT, local)")
    ap.add_argument("--sut", default=None)
    ap.add_argument("--mode", choices=["kinematic", "dynamic"], default=None)
    ap.add_argument("-o", "--out", default="batch")
    ap.add_argument("--runs-per-task", type=int, default=50)
    ap.add_argument("--force-new", action="store_true")
    ap.add_argument("-q", "--quiet", action="store_true")
    a = ap.parse_args(list(argv) if argv is not None else None)
    try:
        result = batch(
            a.tests, a.seeds, a.sut, out=a.out, address=a.address, runs_per_task=a.runs_per_task,
            mode=a.mode, force_new=a.force_new, progress=not a.quiet,
        )
    except (LitesimError, ValueError, TypeError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    runs, passed, failed = result
    print(f"{runs} runs: {passed} passed, {failed} failed ({result.verdict}) -> {a.out}")
    # As `litesim batch`: error 1, fail 2; a scenario not realised fails
    # nothing (its runs are listed).
    return {"error": 1, "fail": 2}.get(result.verdict, 0)


if __name__ == "__main__":
    sys.exit(main())
