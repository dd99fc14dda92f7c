"""The seed's reference approach: the same nine-panel dashboard drawn with
matplotlib (Agg, 1600 x 1200 px) from a litesim log.json, timed.

    python3 crates/litesim-viz/benches/matplotlib_dashboard.py LOG.json [OUT.png]

Prints the median seconds to draw + save over 5 runs (after one warm-up).
"""
import json
import statistics
import sys
import time

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.collections import PolyCollection  # noqa: E402


def nan(v):
    return [float("nan") if x is None else x for x in v]


def draw(log, out):
    ego = next((t for t in log["tracks"] if t["id"] == "ego"), log["tracks"][0])
    times = dict(zip(log["tick"], log["time"]))
    t = [times.get(k, k * log["dt"]) for k in ego["tick"]]
    st, ctl, der = ego["state"], ego["control"], ego["derived"]
    tr = log.get("tracking") or {}
    tt = [times.get(k, k * log["dt"]) for k in tr.get("tick", [])]
    fig, ax = plt.subplots(3, 3, figsize=(16, 12), dpi=100)
    a = ax[0][0]
    plan = log.get("plan")
    if plan:
        g = plan["grid"]
        res, (x0, y0) = g["resolution"], g["origin"]
        polys, cols = [], []
        colour = ["#f4f4f0", "#f6c28b", "#3a3a3a"]
        for j in range(g["height"]):
            i = 0
            row = g["cells"][j * g["width"]:(j + 1) * g["width"]]
            while i < g["width"]:
                v, s = row[i], i
                while i < g["width"] and row[i] == v:
                    i += 1
                xa, xb, ya = x0 + s * res, x0 + i * res, y0 + j * res
                polys.append([(xa, ya), (xb, ya), (xb, ya + res), (xa, ya + res)])
                cols.append(colour[min(v, 2)])
        a.add_collection(PolyCollection(polys, facecolors=cols, edgecolors="none"))
        a.plot(*zip(*plan["raw_path"]), color="#9467bd", lw=1, label="raw path")
        a.plot(*zip(*plan["corridor"]), color="#2ca02c", lw=2, label="corridor")
    a.plot(st["x"], st["y"], color="#1f5fbf", lw=2, label="driven")
    a.set_aspect("equal")
    a.set_title("trajectory")
    a.legend()
    panels = [
        (ax[0][1], "velocity", [(t, st["speed"], "speed")]),
        (ax[0][2], "acceleration", [(t, nan(der["longitudinal_acceleration"]), "applied"), (tt, tr.get("cmd_acceleration", []), "MPC")]),
        (ax[1][0], "steering angle", [(t, nan(ctl["steering_angle"]), "applied"), (tt, tr.get("cmd_steering", []), "MPC")]),
        (ax[1][1], "combined control magnitude", [(t, [abs(x or 0) for x in der["longitudinal_acceleration"]], "|u|")]),
        (ax[1][2], "tracking errors", [(tt, tr.get("lateral_error", []), "lateral"), (tt, tr.get("heading_error", []), "heading")]),
        (ax[2][0], "corridor progress", [(tt, tr.get("progress", []), "progress")]),
        (ax[2][1], "lateral force estimate", [(t, der["force_lateral_n"], "F_y")]),
        (ax[2][2], "slip indicators", [(t, der["slip_angle"], "beta"), (t, der["friction_use"], "friction use")]),
    ]
    for a, title, series in panels:
        for x, y, name in series:
            a.plot(x, y, label=name)
        a.set_title(title)
        a.set_xlabel("t [s]")
        a.grid(True)
        a.legend()
    fig.tight_layout()
    fig.savefig(out)
    plt.close(fig)


def main():
    log = json.load(open(sys.argv[1]))
    out = sys.argv[2] if len(sys.argv) > 2 else "/tmp/matplotlib_dashboard.png"
    draw(log, out)
    runs = []
    for _ in range(5):
        t0 = time.perf_counter()
        draw(log, out)
        runs.append(time.perf_counter() - t0)
    print(f"{statistics.median(runs):.4f}")


if __name__ == "__main__":
    main()
