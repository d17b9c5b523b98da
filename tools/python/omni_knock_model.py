#!/usr/bin/python3
"""How well small models of a knocked mirror explain its ground map (issue 40 B5).

Two renders of one scene (../shared/render writes omni_ground_map.npz: each pixel's floor point,
robot frame): one with the mirror as calibrated, one knocked. The unchanged map stands for the
calibration. Each model turns the unchanged floor points into the knocked ones:
  rotation:        the rays turned about the robot's x and y axes through the viewpoint;
  rotation+shift:  the same, the floor points then shifted (x, y) and the viewpoint raised (z).
Printed: the fitted parameters and the floor error relative to range (rms, p90), over all pixels
whose floor point lies 0.6-6 m away, and fitted on the forward sector alone (within 40 deg of +y,
where the persp camera sees the ball), then scored on all.
  omni_knock_model.py KNOCKED_SEQ UNCHANGED_SEQ [--viewpoint 0.776]"""
import argparse
import os

import numpy as np


def least_squares(res, p0, iterations=30):
    """Levenberg-Marquardt with a forward-difference Jacobian (numpy only: CI has no scipy)."""
    p = np.array(p0, float)
    r = res(p)
    lam = 1e-3
    for _ in range(iterations):
        jac = np.empty((r.size, p.size))
        for k in range(p.size):
            q = p.copy()
            q[k] += 1e-6
            jac[:, k] = (res(q) - r) / 1e-6
        jtj, jtr = jac.T @ jac, jac.T @ r
        while True:
            step = np.linalg.solve(jtj + lam * np.diag(np.diag(jtj) + 1e-12), -jtr)
            r_new = res(p + step)
            if r_new @ r_new <= r @ r or lam > 1e6:
                break
            lam *= 10
        if r_new @ r_new <= r @ r:
            p, r, lam = p + step, r_new, lam / 10
        if np.abs(step).max() < 1e-9:
            break
    return p


def rot(a, b):
    ca, sa, cb, sb = np.cos(a), np.sin(a), np.cos(b), np.sin(b)
    rx = np.array([[1, 0, 0], [0, ca, -sa], [0, sa, ca]])
    ry = np.array([[cb, 0, sb], [0, 1, 0], [-sb, 0, cb]])
    return ry @ rx


def moved(p, x0, y0, h):
    a, b = p[0], p[1]
    ox, oy, oz = (p[2], p[3], p[4]) if len(p) > 2 else (0.0, 0.0, 0.0)
    d = np.stack([x0, y0, -h * np.ones_like(x0)], 1) @ rot(a, b).T
    t = (h + oz) / np.maximum(-d[:, 2], 1e-3)
    return ox + d[:, 0] * t, oy + d[:, 1] * t


def rel_err(p, x0, y0, gx, gy, h):
    x, y = moved(p, x0, y0, h)
    return np.hypot(x - gx, y - gy) / np.hypot(gx, gy)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("knocked")
    ap.add_argument("unchanged")
    ap.add_argument("--viewpoint", type=float, default=0.776)
    args = ap.parse_args()
    m = np.load(os.path.join(args.knocked, "omni_ground_map.npz"))
    s = np.load(os.path.join(args.unchanged, "omni_ground_map.npz"))
    xm, ym, xs, ys = m["ground_x"], m["ground_y"], s["ground_x"], s["ground_y"]
    ds, dm = np.hypot(xs, ys), np.hypot(xm, ym)
    ok = (ds > 0.6) & (ds < 6) & (dm > 0.6) & (dm < 6)
    ok[1::3, :] = False
    ok[:, 1::3] = False
    x0, y0, gx, gy = xs[ok], ys[ok], xm[ok], ym[ok]
    fwd = np.abs(np.degrees(np.arctan2(x0, y0))) < 40.0
    h = args.viewpoint

    def fit(n, sel):
        def res(p):
            x, y = moved(p, x0[sel], y0[sel], h)
            g = np.hypot(gx[sel], gy[sel])
            return np.concatenate([(x - gx[sel]) / g, (y - gy[sel]) / g])
        return least_squares(res, np.zeros(n))

    def show(name, p):
        r = rel_err(p, x0, y0, gx, gy, h)
        extra = " shift %.3f %.3f m, viewpoint %+.3f m" % tuple(p[2:]) if len(p) > 2 else ""
        print("%-34s about x %5.2f deg, about y %5.2f deg%s: error rms %.3f, p90 %.3f" % (
            name, np.degrees(p[0]), np.degrees(p[1]), extra, np.sqrt(np.mean(r ** 2)),
            np.percentile(r, 90)))

    r0 = rel_err(np.zeros(2), x0, y0, gx, gy, h)
    print("%d pixels, %d in the forward sector" % (len(x0), int(fwd.sum())))
    print("%-34s error rms %.3f, p90 %.3f" % ("none (the calibration as it is)",
                                             np.sqrt(np.mean(r0 ** 2)), np.percentile(r0, 90)))
    everywhere = np.ones_like(fwd)
    show("rotation", fit(2, everywhere))
    show("rotation+shift", fit(5, everywhere))
    show("rotation, fitted forward only", fit(2, fwd))
    show("rotation+shift, fitted fwd only", fit(5, fwd))


if __name__ == "__main__":
    main()
