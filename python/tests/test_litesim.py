"""litesim from Python, as a user drives it (run by `cargo test` through
crates/litesim-cli/tests/python_package.rs, after `pip install ./python`)."""
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import litesim

ROOT = Path(__file__).resolve().parents[2]
CUT_IN = str(ROOT / "examples/scenarios/cut_in.osc")
COVERAGE = "examples/scenarios/cut_in_coverage.osc"  # relative: names in results are as given
LITESIM = os.environ.get("LITESIM_BIN", str(ROOT / "target/debug/litesim"))


def test_run_gives_verdict_failures_kpis_and_a_log():
    r = litesim.run(CUT_IN, seed=3)
    assert r.passed and r.verdict == "pass" and r.failures == []
    assert r.summary["seed"] == 3 and r.summary["steps"] == 500
    pair = r.kpis["pairs"][0]
    assert {pair["a"], pair["b"]} == {"sut.car", "other"} and pair["min_distance"] > 0
    log = r.log
    import pandas as pd

    assert isinstance(log, pd.DataFrame)
    assert set(log["actor"]) == {"sut.car", "other"} and len(log) == 1000
    ego = log[log["actor"] == "sut.car"]
    assert ego["x"].is_monotonic_increasing
    # The same run twice: the same log, bit for bit.
    assert litesim.run(CUT_IN, seed=3).log_json() == r.log_json()


def test_a_prepared_test_runs_as_its_path_does(tmp_path):
    p = litesim.prepare(CUT_IN)
    assert p.path == CUT_IN and len(p.source_hash) == 64 and "cut_in" in repr(p)

    class Const:
        def step(self, o):
            return litesim.Command.pedals(0.3, 0.0, 0.0)

    # The same bytes as the path, for several seeds and SUTs, run after run.
    for seed, sut in [(1, None), (2, "acc"), (3, Const())]:
        a = litesim.run(p, seed=seed, sut=sut)
        b = litesim.run(CUT_IN, seed=seed, sut=sut)
        assert a.log_json() == b.log_json() and a.summary == b.summary
    # The load options were the preparation's: given again, an error naming one.
    with pytest.raises(ValueError, match="map: a prepared test"):
        litesim.run(p, map=str(ROOT / "examples/maps/straight.xodr"))
    with pytest.raises(ValueError, match="include"):
        litesim.run(p, include=["x"])
    # An edit after preparing is not seen: the test as read is what runs.
    src = tmp_path / "cut_in.osc"
    src.write_text(Path(CUT_IN).read_text().replace('import "../../osc/', f'import "{ROOT}/osc/'))
    q = litesim.prepare(src, map=str(ROOT / "examples/maps/straight.xodr"))
    before = litesim.run(q, seed=1).log_json()
    src.write_text("not a scenario")
    assert litesim.run(q, seed=1).log_json() == before
    with pytest.raises(litesim.LitesimError):
        litesim.prepare(src)
    with pytest.raises(litesim.LitesimError, match="nope.osc"):
        litesim.prepare(tmp_path / "nope.osc")
    with pytest.raises(TypeError, match="test: expected a path"):
        litesim.prepare(3)


def test_a_carla_scenario_runs_as_written(tmp_path):
    carla = str(ROOT / "examples/carla/slow_lead.osc")
    r = litesim.run(carla, sut="acc")
    assert r.passed, r.failures
    assert r.summary["profile"] == "carla-0.9.15"
    assert set(r.log["actor"]) == {"sut.car", "lead", "truck"}
    # A map folder without the map: litesim's message names the line and the folder.
    with pytest.raises(litesim.LitesimError, match=r"slow_lead.osc:10:5: map 'straight': no straight.xodr"):
        litesim.run(carla, map_dir=tmp_path)
    with pytest.raises(ValueError, match="dialect"):
        litesim.run(carla, dialect="scenic")
    # Read as a litesim program it has no basic.osc to import.
    with pytest.raises(litesim.LitesimError, match="E0202"):
        litesim.run(carla, dialect="litesim")


def test_an_openscenario_xml_file_runs_with_a_python_sut():
    # The cut-in as ASAM OpenSCENARIO XML: the entity with the
    # ExternalController is the one the SUT drives (here litesim's ACC).
    xosc = str(ROOT / "examples/xosc/cut_in.xosc")
    r = litesim.run(xosc, sut="acc")
    assert r.passed, r.failures
    assert set(r.log["actor"]) == {"Ego", "Cutter"}
    starts = [t for t in r.summary["triggers"] if t["element"] == "CutInEvent"]
    assert len(starts) == 1 and 0.0 < starts[0]["t"] < 1.0
    # A bad file: the reader's message, with its place.
    with pytest.raises(litesim.LitesimError, match=r"cut_in_sweep.xosc:.*parameter distribution file"):
        litesim.run(str(ROOT / "examples/xosc/cut_in_sweep.xosc"))


def test_a_failing_run_says_why():
    # sut.car replays its plan into the box standing in its lane: its failure.
    r = litesim.run(str(ROOT / "examples/scenarios/obstacle_goal.osc"), seed=1)
    assert not r.passed and r.verdict == "fail"
    assert any("sut.car's front struck box's rear" in f for f in r.failures), r.failures
    assert r.invalid == []


def test_a_scenario_that_did_not_happen_is_invalid_not_a_failure():
    # Seed 6's cutting car cannot reach its gap within a driver's limits.
    r = litesim.run(str(ROOT / COVERAGE), seed=6)
    assert not r.passed and r.verdict == "invalid" and r.failures == []
    assert r.invalid[0].startswith("scenario not realised: "), r.invalid


def test_without_pandas_the_log_is_numpy_arrays(monkeypatch):
    monkeypatch.setitem(sys.modules, "pandas", None)
    r = litesim.run(CUT_IN, seed=1)
    assert isinstance(r.log, dict) and isinstance(r.log["x"], np.ndarray)
    assert r.log["x"].dtype == np.float64 and len(r.log["x"]) == 1000


class Cruise:
    """Hold the requested speed, keep the lane: five lines of a user's SUT."""

    def reset(self, info):
        self.info = info

    def step(self, o):
        return litesim.Command.accel(max(-6.0, min(1.5, 1.5 * (o.requested_speed - o.ego.speed))), 0.0)


def test_a_python_object_drives_sut_car():
    r = litesim.run(CUT_IN, seed=1, sut=Cruise(), mode="dynamic")
    assert r.summary["sut"] == "python:Cruise"
    ego = r.log[r.log["actor"] == "sut.car"]
    assert ego["speed"].iloc[-1] > 5.0


def test_an_observation_a_sut_keeps_is_that_steps_and_stays_so():
    """The observation a Python SUT gets is shared with the run, which
    changes its own copy-on-write: one kept past its call still shows its
    step afterwards, and every kept one shows a different step."""

    class Keeper:
        def __init__(self):
            self.kept = []

        def step(self, o):
            self.kept.append((o, o.tick, o.time, o.ego.x, o.ego.speed, o.to_json()))
            return litesim.Command.pedals(0.3, 0.0, 0.0)

    k = Keeper()
    r = litesim.run(CUT_IN, seed=1, sut=k, mode="dynamic")
    assert r.verdict != "error" and len(k.kept) > 100
    for o, tick, t, x, v, js in k.kept:
        assert (o.tick, o.time, o.ego.x, o.ego.speed, o.to_json()) == (tick, t, x, v, js)
    assert [o.tick for o, *_ in k.kept] == list(range(len(k.kept)))
    assert len({x for _, _, _, x, _, _ in k.kept}) > 100


def test_other_python_threads_run_while_a_python_sut_drives():
    """litesim.run with a Python SUT keeps the interpreter between the
    SUT's calls; the SUT's own code hands it to other threads at Python's
    switch interval, so a busy thread beside the run keeps counting."""
    import threading

    count, stop = [0], threading.Event()

    def busy():
        while not stop.is_set():
            count[0] += 1

    class Thinking:
        """A SUT that computes for a while each step (~20 µs of Python)."""

        def step(self, o):
            acc = 0.0
            for k in range(200):
                acc += k * o.time
            return litesim.Command.pedals(0.3, 0.0, 0.0)

    # A short interval (Python's default is 5 ms); several runs, so that a
    # loaded machine that wakes the waiting thread late still shows it.
    interval = sys.getswitchinterval()
    sys.setswitchinterval(1e-4)
    th = threading.Thread(target=busy)
    th.start()
    try:
        seen = []
        for _ in range(5):
            before = count[0]
            r = litesim.run(CUT_IN, seed=1, sut=Thinking(), mode="dynamic", record=False)
            seen.append(count[0] - before)
            assert r.verdict != "error"
            if seen[-1] > 0:
                break
    finally:
        stop.set()
        th.join()
        sys.setswitchinterval(interval)
    assert seen[-1] > 0, seen


def test_a_python_sut_can_reverse():
    """Reverse gear from Python: the car is braked to rest, then backs up;
    a dict says the same with "reverse", and a "reverse" that is not a
    bool is an error naming it."""

    class Back:
        def __init__(self, as_dict):
            self.as_dict = as_dict

        def step(self, o):
            if self.as_dict:
                return {"acceleration": 8.0, "reverse": True}
            return litesim.Command.accel(8.0, 0.0, reverse=True)

    for as_dict in (False, True):
        r = litesim.run(CUT_IN, seed=1, sut=Back(as_dict))
        v = r.log[r.log["actor"] == "sut.car"]["speed"].to_numpy()
        assert v[0] > 1.0 and v.min() < -1.0
        first = int(np.argmax(v < 0.0))
        assert abs(v[first - 1]) < 1e-9 and (v[:first] >= 0.0).all()
    r = litesim.run(CUT_IN, seed=1, sut=type("Odd", (), {"step": lambda self, o: {"reverse": "yes"}})())
    assert r.verdict == "error" and "'reverse' is not a bool" in r.failures[0]


def test_a_sut_that_raises_ends_the_run_with_its_traceback():
    class Broken:
        def step(self, o):
            if o.time > 1.0:
                raise RuntimeError("lost the lane")
            return {"throttle": 0.2}

    r = litesim.run(CUT_IN, seed=1, sut=Broken())
    assert r.verdict == "error"
    text = "\n".join(r.failures)
    assert "lost the lane" in text and "Traceback" in text and "RuntimeError" in text
    # A wrong answer is a sut error too, naming what was wrong.
    r = litesim.run(CUT_IN, seed=1, sut=type("Odd", (), {"step": lambda self, o: 42})())
    assert r.verdict == "error" and "returned a int" in r.failures[0]
    r = litesim.run(CUT_IN, seed=1, sut=type("Far", (), {"step": lambda self, o: {"throttle": 3.0}})())
    assert r.verdict == "error" and "throttle is 3" in r.failures[0]


def test_bad_parameters_are_python_exceptions_naming_them():
    with pytest.raises(TypeError, match="seed"):
        litesim.run(CUT_IN, seed="three")
    with pytest.raises(ValueError, match="seed"):
        litesim.run(CUT_IN, seed=-1)
    with pytest.raises(TypeError, match="test"):
        litesim.run(42)
    with pytest.raises(ValueError, match="mode"):
        litesim.run(CUT_IN, mode="warp")
    with pytest.raises(ValueError, match="sut"):
        litesim.run(CUT_IN, sut="autopilot")
    with pytest.raises(TypeError, match="step"):
        litesim.run(CUT_IN, sut=object())
    with pytest.raises(litesim.LitesimError, match="nope.osc"):
        litesim.run("nope.osc")
    with pytest.raises(ValueError, match="throttle"):
        litesim.Command.pedals(throttle=float("nan"))
    with pytest.raises(ValueError, match="sut_timeout"):
        litesim.run(CUT_IN, sut="acc", sut_timeout=-1.0)


class Agent:
    """examples/sut/agent.py's controller, line for line, as an in-process SUT."""

    def reset(self, info):
        self.info = info

    def step(self, obs):
        info, e = self.info, obs.ego
        c, s = math.cos(e.yaw), math.sin(e.yaw)
        gap = math.inf
        for o in obs.objects:
            ahead, side = (o.x - e.x) * c + (o.y - e.y) * s, -(o.x - e.x) * s + (o.y - e.y) * c
            if ahead > 0 and abs(side) < (e.width + o.width) / 2 + 0.3:
                gap = min(gap, ahead - (e.length + o.length) / 2)
        want = min(obs.requested_speed, max(0.0, (gap - 2.0) / 2.0))
        accel = max(-min(info["max_decel"], 6.0), min(info["max_accel"], 1.5 * (want - e.speed)))
        pts = info["route"]
        tx, ty = next(((p[0], p[1]) for p in pts if (p[0] - e.x) * c + (p[1] - e.y) * s > 8.0), (pts[-1][0], pts[-1][1]))
        lx, ly = (tx - e.x) * c + (ty - e.y) * s, -(tx - e.x) * s + (ty - e.y) * c
        curv = 2.0 * ly / max(lx * lx + ly * ly, 1e-6)
        return litesim.Command.accel(accel, curv)


def test_the_same_sut_in_process_and_over_grpc_gives_identical_logs():
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    agent = subprocess.Popen(
        [sys.executable, str(ROOT / "examples/sut/agent.py"), "--port", str(port)],
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert "listening" in agent.stdout.readline()
        remote = litesim.run(CUT_IN, seed=2, sut=f"grpc://127.0.0.1:{port}")
        local = litesim.run(CUT_IN, seed=2, sut=Agent())
    finally:
        agent.kill()
    assert remote.summary["steps"] == local.summary["steps"] == 500
    assert local.log_json() == remote.log_json()
    assert local.failures == remote.failures


def test_the_gym_env_passes_gymnasiums_checker_and_drives():
    from gymnasium.utils.env_checker import check_env

    from litesim.gym import ScenarioEnv

    env = ScenarioEnv(CUT_IN)
    check_env(env, skip_render_check=True)
    obs, info = env.reset(seed=4)
    assert obs.shape == env.observation_space.shape and env.observation_space.contains(obs)
    total, steps = 0.0, 0
    while True:
        obs, reward, terminated, truncated, info = env.step(np.array([0.3, 0.0, 0.0], dtype=np.float32))
        total += reward
        steps += 1
        if terminated or truncated:
            break
    assert steps == 500 and "passed" in info
    # Reset twice with one seed: the same first observation.
    a, _ = env.reset(seed=9)
    b, _ = env.reset(seed=9)
    assert np.array_equal(a, b)
    env.close()


def test_a_stepped_run_is_the_same_run_as_with_the_sut_inside():
    """The caller as the SUT (SteppedRun, no thread): the same summary as
    litesim.run with the same controller called by the run."""
    from litesim import _native

    for seed in (2, 7):
        called = Agent()
        inside = litesim.run(CUT_IN, seed=seed, sut=called, record=False).summary
        run = _native.SteppedRun(CUT_IN, seed)
        # The controller is told what litesim.run told it (its vehicle, route).
        agent, steps = Agent(), 0
        agent.reset(called.info)
        while True:
            ev = run.next()
            if ev[0] == "done":
                break
            run.send(agent.step(ev[1]))
            steps += 1
        outside = json.loads(ev[3])
        assert steps == inside["steps"] == outside["steps"] == 500
        for k in ("verdict", "failures", "invalid", "actors", "pairs", "ego", "goals"):
            assert outside[k] == inside[k], k
        with pytest.raises(_native.LitesimError, match="over"):
            run.next()


def test_gym_env_step_and_reset_costs():
    """Prints the figures BENCHMARKS.md quotes: ScenarioEnv.step and reset
    medians, a 500-step episode."""
    from litesim.gym import ScenarioEnv

    env = ScenarioEnv(CUT_IN)
    env.reset(seed=1)  # the first reset builds what episodes share
    act = np.array([0.3, 0.0, 0.0], dtype=np.float32)
    resets, steps, episodes = [], [], []
    for _ in range(20):
        t = time.perf_counter()
        env.reset()
        resets.append(time.perf_counter() - t)
        e0 = time.perf_counter()
        while True:
            t = time.perf_counter()
            _, _, terminated, _, _ = env.step(act)
            steps.append(time.perf_counter() - t)
            if terminated:
                break
        episodes.append(time.perf_counter() - e0)
    med = lambda v: sorted(v)[len(v) // 2]
    print(f"\nScenarioEnv: step median {med(steps) * 1e6:.1f} µs, reset median {med(resets) * 1e6:.0f} µs, 500-step episode median {med(episodes) * 1e3:.2f} ms")
    # Loose bounds (a noisy CI machine); BENCHMARKS.md has the figures.
    assert med(steps) < 100e-6 and med(resets) < 5e-3


def _ray_init(tmp_path):
    import ray

    if not ray.is_initialized():
        ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    # SUT classes defined here travel to the workers by value (the workers
    # cannot import this test module), as a user's notebook classes do.
    ray.cloudpickle.register_pickle_by_value(sys.modules[__name__])
    return ray


def test_ray_batch_of_2000_runs_equals_litesim_batch_byte_for_byte(tmp_path):
    import litesim.ray

    _ray_init(tmp_path)
    local = tmp_path / "local"
    t = time.perf_counter()
    subprocess.run([LITESIM, "batch", COVERAGE, "--seeds", "1..2000", "-q", "--threads", "2", "-o", str(local)], cwd=ROOT, check=False)
    local_s = time.perf_counter() - t
    out = tmp_path / "ray"
    cwd = os.getcwd()
    os.chdir(ROOT)
    try:
        t = time.perf_counter()
        runs, passed, failed = litesim.ray.batch([COVERAGE], range(1, 2001), out=str(out), address=None, runs_per_task=100, progress=False)
        ray_s = time.perf_counter() - t
    finally:
        os.chdir(cwd)
    assert runs == 2000 and passed + failed == 2000
    for f in ["results.jsonl", "results.csv", "coverage.json", "manifest.json"]:
        assert (out / f).read_bytes() == (local / f).read_bytes(), f
    print(f"\nbatch of 2000: local {2000 / local_s:.0f} runs/s, ray {2000 / ray_s:.0f} runs/s")


class CrashOnce:
    """A SUT whose worker process dies once, mid-batch (the marker file says
    whether it already did)."""

    def __init__(self, marker, seed):
        self.marker, self.seed = marker, seed

    def reset(self, info):
        if info["seed"] == self.seed and not os.path.exists(self.marker):
            open(self.marker, "w").close()
            os._exit(9)

    def step(self, o):
        return litesim.Command.accel(max(-6.0, min(1.5, 1.5 * (o.requested_speed - o.ego.speed))), 0.0)


def test_a_worker_killed_mid_batch_loses_and_duplicates_nothing(tmp_path):
    import litesim.ray
    from litesim import _native

    _ray_init(tmp_path)
    marker = str(tmp_path / "crashed")
    sut = CrashOnce(marker, seed=58)
    cwd = os.getcwd()
    os.chdir(ROOT)
    try:
        out = tmp_path / "ray"
        runs, _, _ = litesim.ray.batch([COVERAGE], range(1, 201), sut, out=str(out), address=None, runs_per_task=20, progress=False)
        assert os.path.exists(marker), "the worker did not crash"
        # The same jobs in this process (no crash now: the marker exists).
        jobs = [(COVERAGE, s) for s in range(1, 201)]
        ref = tmp_path / "ref"
        _native.write_batch([COVERAGE], 1, 200, str(ref), _native.run_lines(jobs, sut), sut)
    finally:
        os.chdir(cwd)
    assert runs == 200
    lines = (out / "results.jsonl").read_text().splitlines()
    assert len(lines) == 200 and len({(json.loads(l)["test"], json.loads(l)["seed"]) for l in lines}) == 200
    for f in ["results.jsonl", "results.csv", "coverage.json"]:
        assert (out / f).read_bytes() == (ref / f).read_bytes(), f


def test_litesim_batch_with_ray_writes_the_same_folder(tmp_path):
    local, ray_out = tmp_path / "local", tmp_path / "ray"
    l = subprocess.run([LITESIM, "batch", COVERAGE, "--seeds", "1..60", "-q", "-o", str(local)], cwd=ROOT, check=False)
    p = subprocess.run(
        [LITESIM, "batch", COVERAGE, "--seeds", "1..60", "-q", "--ray", "local", "-o", str(ray_out)],
        cwd=ROOT, capture_output=True, text=True,
    )
    assert p.returncode == l.returncode, p.stdout + p.stderr  # the same verdict
    for f in ["results.jsonl", "results.csv", "coverage.json", "manifest.json"]:
        assert (ray_out / f).read_bytes() == (local / f).read_bytes(), f


def test_npc_planned_is_refused_by_ray_rather_than_dropped(tmp_path):
    p = subprocess.run(
        [LITESIM, "batch", COVERAGE, "--seeds", "1..2", "--npc", "planned", "--ray", "local", "-o", str(tmp_path / "b")],
        cwd=ROOT, capture_output=True, text=True,
    )
    assert p.returncode == 1 and "--npc planned" in p.stderr, p.stdout + p.stderr


def test_a_ray_address_that_does_not_answer_is_an_error_within_ten_seconds(tmp_path):
    import litesim.ray

    t = time.perf_counter()
    with pytest.raises(litesim.LitesimError, match="does not answer"):
        litesim.ray.batch([COVERAGE], range(1, 3), address="127.0.0.1:9", out=str(tmp_path / "b"), progress=False)
    assert time.perf_counter() - t <= 10.0


def test_the_simulator_api_in_process():
    sim = litesim.Simulator(profile="dummy", step_ms=20, seed=1)
    assert sim.step_ms == 20
    d = sim.create_actor("car", 0.0, 0.0, yaw=0.0, speed=10.0)
    assert d["length"] > 0
    sim.create_actor("walker", 20.0, 5.0, kind="Pedestrian")
    sim.create_actor("b", 0.0, 3.5, speed=5.0)
    sim.set_pedals_many(["car", "b"], np.array([0.3, 0.0]), np.array([0.0, 0.2]), np.array([0.0, 0.0]))
    t = sim.step(50)
    assert abs(t - 1.0) < 1e-9
    st = sim.states()
    assert st["id"] == ["car", "walker", "b"] and isinstance(st["x"], np.ndarray)
    assert st["x"][0] > 9.0 and st["speed"][2] < 5.0
    sim.set_trajectory("walker", np.array([1.0, 2.0, 3.0]), np.array([20.0, 20.0, 20.0]), np.array([5.0, 6.0, 7.0]))
    sim.step(100)
    assert abs(sim.states()["y"][1] - 7.0) < 0.5
    with pytest.raises(litesim.LitesimError):
        sim.set_pedals("nobody", 0.1, 0.0, 0.0)
    with pytest.raises(ValueError, match="x"):
        sim.create_actor("bad", float("nan"), 0.0)
    with pytest.raises(ValueError, match="actor_ids"):
        sim.set_pedals_many(["car"], np.array([0.1, 0.2]), np.array([0.0]), np.array([0.0]))
    assert sim.close() == 150


def test_overheads():
    """Prints the figures BENCHMARKS.md quotes (medians of 30)."""

    def median(f, n=30):
        ts = []
        for _ in range(n):
            t = time.perf_counter()
            f()
            ts.append(time.perf_counter() - t)
        return sorted(ts)[n // 2]

    run = median(lambda: litesim.run(CUT_IN, seed=1, record=False))

    class Const:
        cmd = litesim.Command.pedals(0.3, 0.0, 0.0)

        def step(self, o):
            return self.cmd

    planned_dyn = median(lambda: litesim.run(CUT_IN, seed=1, record=False, mode="dynamic"))
    py = median(lambda: litesim.run(CUT_IN, seed=1, record=False, sut=Const(), mode="dynamic"))
    per_step_us = (py - planned_dyn) / 500 * 1e6
    print(f"\nlitesim.run(cut_in, record=False) median {run * 1e3:.2f} ms; python SUT run {py * 1e3:.2f} ms vs planned dynamic {planned_dyn * 1e3:.2f} ms: ≤ {per_step_us:.2f} µs per step")
    prep = litesim.prepare(CUT_IN)
    py_prep = median(lambda: litesim.run(prep, seed=1, record=False, sut=Const(), mode="dynamic"))
    dyn_prep = median(lambda: litesim.run(prep, seed=1, record=False, mode="dynamic"))
    print(f"prepared once: python SUT run {py_prep * 1e3:.2f} ms, planned dynamic {dyn_prep * 1e3:.2f} ms")
