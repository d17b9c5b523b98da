#!/usr/bin/python3
"""Scores the omni section of a calibration JSON against the renderer's true ground map.

usage: /usr/bin/python3 score_omni_calib.py CALIB.json SEQ [--step N] [--csv OUT.csv]
SEQ must hold omni_ground_map.npz (+ omni_selfmask.png); both are scoring-only truth.
Prints the ground-distance error (|predicted - true| / true distance) by true distance for the
model-free map and for the symmetric one-direction fit (omni.symmetric_support_px).
The mapping below restates core/calibration/calibration.cpp (OmniPixelToGround) in numpy.
"""
import argparse, json, math, os, sys
import numpy as np


def pixel_to_ground(o, support, u, v):
    cu, cv = o["center_u"], o["center_v"]
    edges = np.asarray(o["edge_ground_m"], float)
    sv = np.asarray(support, float)  # (45, 12)
    S = sv.shape[0]
    du, dv = u - cu, v - cv
    r = np.hypot(du, dv)
    phi = np.mod(np.arctan2(dv, du), 2 * math.pi)
    pos = phi / (2 * math.pi / S) - 0.5
    fl = np.floor(pos)
    w = pos - fl
    s0 = np.mod(fl.astype(int), S)
    s1 = np.mod(s0 + 1, S)
    svp = (1 - w)[:, None] * sv[s0] + w[:, None] * sv[s1]  # (n, 12)
    rr = np.concatenate([np.zeros((len(r), 1)), svp], axis=1)
    fo = o["viewpoint_z_m"]
    dd = np.concatenate([[0.0], np.arctan(edges / fo)])  # interpolate in the ray angle
    d = np.full(len(r), np.nan)
    for k in range(1, rr.shape[1]):
        m = (r <= rr[:, k]) & np.isnan(d)
        t = (r[m] - rr[m, k - 1]) / (rr[m, k] - rr[m, k - 1])
        d[m] = dd[k - 1] + t * (dd[k] - dd[k - 1])
    # first segment: psi = a r + b r^2 through (0,0) and the first two support vectors
    r0, r1 = svp[:, 0], svp[:, 1]
    p0, p1 = dd[1], dd[2]
    b = (p1 / r1 - p0 / r0) / (r1 - r0)
    a = p0 / r0 - b * r0
    q = (r <= r0) & (a > 0) & (a + 2 * b * r0 > 0)
    d[q] = a[q] * r[q] + b[q] * r[q] ** 2
    d = fo * np.tan(d)
    h1c, h1s, h2c, h2s = o.get("azimuth_harmonics_rad", [0.0] * 4)  # mirror tilt (blob v3)
    turn = h1c * np.cos(phi) + h1s * np.sin(phi) + h2c * np.cos(2 * phi) + h2s * np.sin(2 * phi)
    theta = o.get("image_angle_sign", 1) * (phi - o.get("image_angle_offset_rad", 0.0) - turn)
    return d * np.cos(theta), d * np.sin(theta)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("calib")
    ap.add_argument("seq")
    ap.add_argument("--step", type=int, default=2)
    ap.add_argument("--csv", help="write a subsampled fixture u,v,x,y (true ground)")
    ap.add_argument("--csv-step", type=int, default=6)
    a = ap.parse_args()
    o = json.load(open(a.calib))["omni"]
    g = np.load(os.path.join(a.seq, "omni_ground_map.npz"))
    gx, gy = g["ground_x"], g["ground_y"]
    mask = np.zeros(gx.shape, bool)
    mpath = os.path.join(a.seq, "omni_selfmask.png")
    if os.path.exists(mpath):
        import cv2
        mask = cv2.imread(mpath, 0) > 127
    vv, uu = np.mgrid[0:gx.shape[0]:a.step, 0:gx.shape[1]:a.step]
    u, v = uu.ravel().astype(float), vv.ravel().astype(float)
    tx, ty = gx[vv, uu].ravel(), gy[vv, uu].ravel()
    ok = np.isfinite(tx) & ~mask[vv, uu].ravel()
    u, v, tx, ty = u[ok], v[ok], tx[ok], ty[ok]
    td = np.hypot(tx, ty)
    print("pixels scored: %d (every %d px, not self-masked, ground hit)" % (len(u), a.step))
    res = {}
    for name, sup in [("model-free", o["support_px"]),
                      ("symmetric", [o["symmetric_support_px"]] * len(o["support_px"]))
                      if "symmetric_support_px" in o else (None, None)]:
        if sup is None:
            continue
        px, py = pixel_to_ground(o, sup, u, v)
        pd = np.hypot(px, py)
        res[name] = (np.abs(pd - td) / td, np.hypot(px - tx, py - ty))
    print("%-10s %7s | %-34s | %-34s" % ("dist_m", "pixels", "model-free dist err % med/p90/max",
                                        "symmetric dist err % med/p90/max"))
    for lo in np.arange(0.5, 6.5, 0.5):
        m = (td >= lo) & (td < lo + 0.5)
        line = "%4.1f-%-4.1f  %7d |" % (lo, lo + 0.5, m.sum())
        for name in ["model-free", "symmetric"]:
            if name not in res:
                continue
            e = res[name][0][m]
            e = e[np.isfinite(e)]
            if len(e):
                line += "  %6.2f %6.2f %7.2f (n %6d)     |" % (100 * np.median(e), 100 * np.percentile(e, 90),
                                                    100 * e.max(), len(e))
        print(line)
    for name in res:
        e = res[name][0][(td <= 5.0)]
        e = e[np.isfinite(e)]
        print("%-10s up to 5 m: median %.3f %%, rms %.3f %%, p95 %.3f %% (n %d, %d outside the map)"
              % (name, 100 * np.median(e), 100 * np.sqrt(np.mean(e ** 2)), 100 * np.percentile(e, 95),
                 len(e), int(np.sum(td <= 5.0)) - len(e)))
    for name in res:
        e = res[name][0][(td >= 0.4) & (td <= 5.0)]
        e = e[np.isfinite(e)]
        print("%-10s 0.4-5 m: median %.3f %%, rms %.3f %%, p95 %.3f %%, max %.3f %% (n %d)"
              % (name, 100 * np.median(e), 100 * np.sqrt(np.mean(e ** 2)), 100 * np.percentile(e, 95),
                 100 * e.max(), len(e)))
    if "symmetric" in res:
        a5 = res["model-free"][0][(td >= 0.4) & (td <= 5.0)]
        b5 = res["symmetric"][0][(td >= 0.4) & (td <= 5.0)]
        both = np.isfinite(a5) & np.isfinite(b5)
        print("symmetric / model-free rms ratio 0.4-5 m: %.2f" %
              (np.sqrt(np.mean(b5[both] ** 2)) / np.sqrt(np.mean(a5[both] ** 2))))
        a5 = res["model-free"][0][td <= 5.0]
        b5 = res["symmetric"][0][td <= 5.0]
        both = np.isfinite(a5) & np.isfinite(b5)
        print("symmetric / model-free rms ratio up to 5 m: %.2f" %
              (np.sqrt(np.mean(b5[both] ** 2)) / np.sqrt(np.mean(a5[both] ** 2))))
    if a.csv:
        vv, uu = np.mgrid[0:gx.shape[0]:a.csv_step, 0:gx.shape[1]:a.csv_step]
        x, y = gx[vv, uu], gy[vv, uu]
        ok = np.isfinite(x) & ~mask[vv, uu] & (np.hypot(x, y) <= 6.5)
        with open(a.csv, "w") as f:
            f.write("u,v,x_m,y_m\n")
            for uu_, vv_, x_, y_ in zip(uu[ok], vv[ok], x[ok], y[ok]):
                f.write("%d,%d,%.4f,%.4f\n" % (uu_, vv_, x_, y_))
        print("wrote %s (%d points)" % (a.csv, int(ok.sum())))


if __name__ == "__main__":
    main()
