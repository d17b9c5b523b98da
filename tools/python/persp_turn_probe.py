#!/usr/bin/python3
"""Measures how far the persp camera's rays disagree with the omni camera's on a ball at rest
or rolling on the floor: the groundwork of issue 40's "persp camera turned" check.

    /usr/bin/python3 tools/python/persp_turn_probe.py --calib CALIB --states STATES.csv \
        [--ballvision build/host/tools/ballvision]

The two cameras' rays to a ball lie nearly in one vertical plane (both cameras sit on the
robot's axis and look out at the ball), so a persp camera pitched up or down moves the point
where they cross along the omni ray: the ray gap hardly sees it, the range does. On the floor
it is fixed: the omni ray meets the plane z = ball radius at P, and the persp ray should point
at P. For each frame of `ballvision run`'s states.csv where the track rolls (mode rolling,
z < 0.2 m) and both cameras saw the ball, it prints the persp ray's elevation and azimuth
minus those of the direction from the persp camera to P, and their median, in degrees.
"""
import argparse
import csv
import math
import statistics
import subprocess

BALL_RADIUS_M = 0.11


def rays(bv, calib, camera, pixels):
    text = "".join(f"{u} {v}\n" for u, v in pixels)
    out = subprocess.run([bv, "calib", "rays", calib, "--camera", camera], input=text,
                         capture_output=True, text=True, check=True).stdout
    result = []
    for line in out.splitlines():
        f = line.split(",")
        if len(f) < 9 or f[2] != "1":
            result.append(None)
            continue
        result.append(tuple(float(x) for x in f[3:9]))
    return result


def angles(d):
    return (math.degrees(math.atan2(d[2], math.hypot(d[0], d[1]))),
            math.degrees(math.atan2(d[1], d[0])))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--calib", required=True)
    ap.add_argument("--states", required=True)
    ap.add_argument("--ballvision", default="build/host/tools/ballvision")
    a = ap.parse_args()
    rows = []
    with open(a.states) as f:
        for r in csv.DictReader(f):
            if r["mode"] != "rolling" or not r["z"] or float(r["z"]) > 0.2:
                continue
            if not (r["omni_u"] and r["persp_u"]):
                continue
            rows.append(r)
    if not rows:
        raise SystemExit("no rolling frames seen by both cameras")
    omni = rays(a.ballvision, a.calib, "omni", [(r["omni_u"], r["omni_v"]) for r in rows])
    persp = rays(a.ballvision, a.calib, "persp", [(r["persp_u"], r["persp_v"]) for r in rows])
    d_elev, d_az = [], []
    for r, o, p in zip(rows, omni, persp):
        if o is None or p is None or o[5] >= 0:
            continue
        t = (BALL_RADIUS_M - o[2]) / o[5]
        target = [o[i] + t * o[3 + i] - p[i] for i in range(3)]
        e1, a1 = angles(p[3:6])
        e2, a2 = angles(target)
        d_elev.append(e1 - e2)
        d_az.append((a1 - a2 + 180) % 360 - 180)
        print(f"{r['index']:>5}  range {math.hypot(*target[:2]):5.2f} m  "
              f"elevation {e1 - e2:+6.2f} deg  azimuth {d_az[-1]:+6.2f} deg")
    print(f"{len(d_elev)} frames: median elevation {statistics.median(d_elev):+.2f} deg, "
          f"azimuth {statistics.median(d_az):+.2f} deg")


if __name__ == "__main__":
    main()
