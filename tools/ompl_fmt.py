"""OMPL's FMT* on litesim's FMT* benchmark map, for the ratio in BENCHMARKS.md.

The map of `cargo bench -p litesim-plan --bench plan` (fmt_star_80x40): an
80 × 40 m yard with one rectangle [32, 48] × [6, 34], a vehicle radius of
0.9 m plus a 0.4 m margin (so the rectangle grows by 1.3 m, and the yard
shrinks by 1.3 m), start (5, 20), goal (75, 20). OMPL (PyPI `ompl`, C++ with
Python bindings) samples n states and checks motions at 0.5 % of the
space's extent; the state validity checker is a Python function (the
analytic test of the inflated rectangle), so every check crosses into
Python — as any Python user of OMPL pays. Prints the median wall time of
`solve` over the repetitions, the path length, and the length with the
straight rest to the goal (OMPL stops within 0.5 m of it; litesim's path
ends on it), each run drawing other samples.

    python3 tools/ompl_fmt.py [n] [repetitions]
"""
import statistics
import sys
import time

from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou

N = int(sys.argv[1]) if len(sys.argv) > 1 else 2000
REPS = int(sys.argv[2]) if len(sys.argv) > 2 else 20
INFL = 0.9 + 0.4


def valid(state):
    x, y = state[0], state[1]
    if not (INFL <= x <= 80.0 - INFL and INFL <= y <= 40.0 - INFL):
        return False
    return not (32.0 - INFL <= x <= 48.0 + INFL and 6.0 - INFL <= y <= 34.0 + INFL)


def once():
    space = ob.RealVectorStateSpace(2)
    bounds = ob.RealVectorBounds(2)
    bounds.setLow(0, 0.0)
    bounds.setHigh(0, 80.0)
    bounds.setLow(1, 0.0)
    bounds.setHigh(1, 40.0)
    space.setBounds(bounds)
    ss = og.SimpleSetup(space)
    ss.setStateValidityChecker(valid)
    start, goal = space.allocState(), space.allocState()
    start[0], start[1] = 5.0, 20.0
    goal[0], goal[1] = 75.0, 20.0
    ss.setStartAndGoalStates(start, goal, 0.5)
    planner = og.FMT(ss.getSpaceInformation())
    planner.setNumSamples(N)
    ss.setPlanner(planner)
    ss.setup()
    t0 = time.perf_counter()
    solved = ss.solve(60.0)
    dt = time.perf_counter() - t0
    if not solved:
        return dt, float("nan"), float("nan")
    path = ss.getSolutionPath()
    end = path.getState(path.getStateCount() - 1)
    # OMPL stops within 0.5 m of the goal; litesim's path ends on it. The
    # comparable cost adds the straight rest of the way.
    rest = ((end[0] - goal[0]) ** 2 + (end[1] - goal[1]) ** 2) ** 0.5
    return dt, path.length(), path.length() + rest


if __name__ == "__main__":
    ou.setLogLevel(ou.LogLevel.LOG_WARN)
    ou.RNG.setSeed(1)  # once per process: OMPL refuses to re-seed later
    runs = [once() for _ in range(REPS)]
    times = [t for t, _, _ in runs]
    print(f"OMPL FMT n={N}: median {statistics.median(times) * 1e3:.2f} ms over {REPS} runs, "
          f"median path {statistics.median(l for _, l, _ in runs):.2f} m, "
          f"to the goal {statistics.median(c for _, _, c in runs):.2f} m")
