#!/usr/bin/python3
"""The smallest image size of a ball on the floor by image radius, from a calibration's omni
distance map: the groundwork of issue 40's A2 (the scan's ball-size profile from the camera
model instead of the reference mirror's hand-made one in ReferenceOmniScanConfig).

  /usr/bin/python3 tools/python/omni_ball_profile.py CALIB.json [--radius M]

Per ground distance d: the image radius of the ball's centre, and its diameter along the image
radius (the near and far tangents from the mirror viewpoint, projected to the floor, through
the map: median over the 45 directions) and across it (the angle it subtends times its radius).
Beyond the map's last edge the map is continued linearly: rough."""
import argparse
import json
import math
import statistics


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("calib")
    ap.add_argument("--radius", type=float, default=0.11, help="ball radius, m")
    a = ap.parse_args()
    with open(a.calib) as fh:
        c = json.load(fh)["omni"]
    f, edges, rows = c["viewpoint_z_m"], c["edge_ground_m"], c["support_px"]
    sup = [statistics.median(row[k] for row in rows) for k in range(len(edges))]

    def r_of(x):  # image radius of ground distance x (piecewise linear, continued at both ends)
        if x <= edges[0]:
            return sup[0] * x / edges[0]
        for k in range(len(edges) - 1):
            if x <= edges[k + 1] or k == len(edges) - 2:
                t = (x - edges[k]) / (edges[k + 1] - edges[k])
                return sup[k] + t * (sup[k + 1] - sup[k])

    R = a.radius
    print("d_m,r_px,radial_px,tangential_px")
    for d in [0.8, 1.0, 1.5, 2.0, 3.0, 4.0, 5.0, 5.5, 6.0, 6.3]:
        centre = math.atan2(R - f, d)  # viewpoint -> ball centre, below the horizontal
        half = math.asin(R / math.hypot(d, f - R))
        near, far = centre - half, centre + half
        x_near = f / math.tan(-near)
        radial = r_of(f / math.tan(-far)) - r_of(x_near) if far < 0 else float("nan")
        r_c = r_of(d * f / (f - R))
        print(f"{d:.1f},{r_c:.1f},{radial:.1f},{r_c * 2 * math.asin(R / d):.1f}")


if __name__ == "__main__":
    main()
