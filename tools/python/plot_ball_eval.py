#!/usr/bin/python3
"""Matplotlib versions of the paper's Fig. 4 and Fig. 5 from `ballvision eval --plots DIR`.

    ballvision eval SEQ --calib CALIB --plots DIR      # writes DIR/{measurements,states,prediction}.csv
    /usr/bin/python3 tools/python/plot_ball_eval.py fig4 SEQ DIR   # static_grid -> DIR/fig4_mpl.png
    /usr/bin/python3 tools/python/plot_ball_eval.py fig5 SEQ DIR   # bounce      -> DIR/fig5_mpl.png

Fig. 4: 3D error of the per-frame measurement (no filter, no ground constraint) against the
distance for the three ball heights, with the omni-only "2D" estimate (ray on the floor plane)
dashed. Fig. 5: height and vertical velocity, estimated vs true, and the height predicted from
the chosen time (`--at-ms` of eval).
"""
import csv
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def read(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def num(row, key):
    v = row.get(key, "")
    return float(v) if v not in ("", None) else math.nan


def fig4(seq, out):
    truth = {r["index"]: r for r in read(os.path.join(seq, "truth.csv"))}
    grid = read(os.path.join(seq, "grid.csv"))
    meas = {r["index"]: r for r in read(os.path.join(out, "measurements.csv"))}
    series = {}
    for g in grid:
        i = g["index"]
        if i not in meas or i not in truth:
            continue
        t, m = truth[i], meas[i]
        tx, ty, tz = num(t, "ball_x"), num(t, "ball_y"), num(t, "ball_z")
        e3 = math.dist((num(m, "mx"), num(m, "my"), num(m, "mz")), (tx, ty, tz))
        e2 = math.dist((num(m, "gx"), num(m, "gy"), num(m, "gz")), (tx, ty, tz))
        series.setdefault(float(g["z_m"]), []).append((float(g["distance_m"]), e3, e2))
    fig, ax = plt.subplots(figsize=(8, 5))
    for (h, pts), c in zip(sorted(series.items()), ["tab:red", "tab:green", "tab:blue"]):
        pts.sort()
        d = [p[0] for p in pts]
        ax.plot(d, [p[1] * 100 for p in pts], "o-", color=c, label=f"3D, z = {h * 100:.0f} cm")
        if h > 0.15:
            ax.plot(d, [p[2] * 100 for p in pts], "--", color=c, label=f"2D (omni only), z = {h * 100:.0f} cm")
    ax.set_xlabel("distance [m]")
    ax.set_ylabel("error [cm]")
    ax.set_yscale("log")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    ax.set_title("3D error vs distance (rendered reference rig, static grid)")
    path = os.path.join(out, "fig4_mpl.png")
    fig.savefig(path, dpi=120, bbox_inches="tight")
    print("wrote", path)


def fig5(seq, out):
    truth = read(os.path.join(seq, "truth.csv"))
    states = read(os.path.join(out, "states.csv"))
    pred = read(os.path.join(out, "prediction.csv"))
    tt = [num(r, "t_us") * 1e-6 for r in truth]
    ts = [num(r, "t_us") * 1e-6 for r in states]
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(13, 5))
    a1.plot(tt, [num(r, "ball_z") for r in truth], "-", color="tab:green", label="true height")
    a1.plot(ts, [num(r, "z") for r in states], ".-", color="tab:red", label="estimated height")
    a1.plot(tt, [num(r, "ball_vz") for r in truth], "-", color="tab:orange", label="true vz")
    a1.plot(ts, [num(r, "vz") for r in states], ".-", color="tab:blue", label="estimated vz")
    a1.set_xlabel("time [s]")
    a1.set_ylabel("z [m], vz [m/s]")
    a1.grid(alpha=0.3)
    a1.legend()
    a2.plot(tt, [num(r, "ball_z") for r in truth], "-", color="tab:green", label="true height")
    a2.plot(ts, [num(r, "z") for r in states], ".", color="tab:red", label="estimated height")
    if pred:
        a2.plot([num(r, "t_s") for r in pred], [num(r, "z") for r in pred], ":", color="tab:blue",
                lw=2, label=f"prediction made at {num(pred[0], 't_s'):.2f} s")
    a2.set_xlabel("time [s]")
    a2.set_ylabel("z [m]")
    a2.grid(alpha=0.3)
    a2.legend()
    path = os.path.join(out, "fig5_mpl.png")
    fig.savefig(path, dpi=120, bbox_inches="tight")
    print("wrote", path)


if __name__ == "__main__":
    if len(sys.argv) != 4 or sys.argv[1] not in ("fig4", "fig5"):
        sys.exit(__doc__)
    {"fig4": fig4, "fig5": fig5}[sys.argv[1]](sys.argv[2], sys.argv[3])
