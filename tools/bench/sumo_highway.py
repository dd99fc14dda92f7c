"""SUMO's time for the traffic engine's benchmark case (BENCHMARKS.md):
N vehicles on one straight three-lane edge of N * 6 m (6 km for 1,000),
Krauss car-following and LC2013 lane changes (SUMO's defaults), 20 ms
steps, 10 s, stepped through libsumo in this process. Vehicles start
spread evenly over the lanes at 60-79 km/h (seeded), as litesim's bench.

    pip install eclipse-sumo libsumo
    python3 tools/bench/sumo_highway.py 1000 [repeats]

Prints the median wall time of the 500 timed steps (loading and the
untimed insertion steps excluded) and of the whole. Not a test dependency: a measurement tool.
"""
import os, random, statistics, subprocess, sys, tempfile, time

import libsumo
import sumo

n = int(sys.argv[1]) if len(sys.argv) > 1 else 1000
repeats = int(sys.argv[2]) if len(sys.argv) > 2 else 5
length = n * 6.0
d = tempfile.mkdtemp()
open(f"{d}/h.nod.xml", "w").write(
    f'<nodes><node id="a" x="0" y="0"/><node id="b" x="{length}" y="0"/></nodes>')
open(f"{d}/h.edg.xml", "w").write(
    '<edges><edge id="e" from="a" to="b" numLanes="3" speed="36.1"/></edges>')
netconvert = os.path.join(sumo.SUMO_HOME, "bin", "netconvert")
subprocess.run([netconvert, "-n", f"{d}/h.nod.xml", "-e", f"{d}/h.edg.xml",
                "-o", f"{d}/h.net.xml", "--no-warnings"], check=True)
rng = random.Random(1)
spacing = length * 3 / n
with open(f"{d}/h.rou.xml", "w") as f:
    f.write('<routes><vType id="car" carFollowModel="Krauss" laneChangeModel="LC2013" '
            'length="4.5" minGap="2.0" accel="2.6" decel="4.5" emergencyDecel="9"/>'
            '<route id="r" edges="e"/>\n')
    # Front to back: each vehicle is inserted behind those already on the
    # road, at the speed that is safe behind them (departSpeed="max").
    for i in reversed(range(n)):
        lane = i % 3
        pos = 5.0 + (i // 3) * spacing
        v = (60 + rng.random() * 19) / 3.6
        f.write(f'<vehicle id="v{i}" type="car" route="r" depart="0" departLane="{lane}" '
                f'departPos="{pos:.2f}" departSpeed="max" speedFactor="{v / 36.1:.4f}"/>\n')
    f.write("</routes>\n")
steps, whole = [], []
for _ in range(repeats):
    t0 = time.perf_counter()
    libsumo.start(["sumo", "-n", f"{d}/h.net.xml", "-r", f"{d}/h.rou.xml",
                   "--step-length", "0.02", "--no-step-log", "--no-warnings",
                   "--collision.action", "warn", "--eager-insert", "true"])
    # SUMO inserts a limited number per step: step (untimed) until every
    # vehicle is on the road, then time 500 steps of all of them.
    warm = 0
    while libsumo.vehicle.getIDCount() < n and warm < 5000:
        libsumo.simulationStep()
        warm += 1
    inserted = libsumo.vehicle.getIDCount()
    t1 = time.perf_counter()
    for _ in range(500):
        libsumo.simulationStep()
    t2 = time.perf_counter()
    running = libsumo.vehicle.getIDCount()
    collisions = libsumo.simulation.getCollidingVehiclesNumber()
    libsumo.close()
    steps.append(t2 - t1)
    whole.append(t2 - t0)
print(f"sumo {n} vehicles: steps median {statistics.median(steps)*1000:.1f} ms "
      f"(min {min(steps)*1000:.1f}, max {max(steps)*1000:.1f}); with loading "
      f"{statistics.median(whole)*1000:.1f} ms; inserted {inserted} after {warm} warm-up steps, running at the end {running}, "
      f"colliding at the last step {collisions}")
