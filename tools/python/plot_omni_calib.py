#!/usr/bin/python3
"""Plot of the omni calibration like the paper's Fig. 2 (top right / bottom).

usage: /usr/bin/python3 plot_omni_calib.py REPORT_DIR [OUT.png]
REPORT_DIR is what `ballvision calibrate omni ... --report REPORT_DIR` wrote:
omni_samples.csv (every observed edge), omni_support.csv (45 x 12 support vectors, smoothed,
interpolated sectors flagged), omni_symmetric.csv (the one-direction fit).
Top: samples (crosses) and support vectors (lines) per image direction; grey bands: sectors
interpolated (mirror struts). Bottom: zoom on the 3.3 m and 3.8 m edges with the symmetric fit
dashed, as in the paper's Fig. 2 bottom.
"""
import csv, os, sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np


def read(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def main():
    d = sys.argv[1]
    out = sys.argv[2] if len(sys.argv) > 2 else os.path.join(d, "omni_calibration.png")
    s = read(os.path.join(d, "omni_samples.csv"))
    sup = read(os.path.join(d, "omni_support.csv"))
    sym = read(os.path.join(d, "omni_symmetric.csv"))
    phi = np.array([float(r["phi_deg"]) for r in s])
    rad = np.array([float(r["r_px"]) for r in s])
    edge = np.array([int(r["edge"]) for r in s])
    keys = [k for k in sup[0].keys() if k.startswith("r_")]
    centres = np.array([float(r["phi_centre_deg"]) for r in sup])
    flags = np.array([int(r["interpolated"]) for r in sup])
    sv = np.array([[float(r[k]) for k in keys] for r in sup])
    sym_r = np.array([float(r["r_px"]) for r in sym])
    sym_m = [float(r["edge_m"]) for r in sym]
    fig, (a, b) = plt.subplots(2, 1, figsize=(10, 9), gridspec_kw={"height_ratios": [3, 2]})
    for ax in (a, b):
        for c, f in zip(centres, flags):
            if f:
                ax.axvspan(c - 4, c + 4, color="0.85", zorder=0)
    cc = np.concatenate([centres, [centres[0] + 360]])
    for k in range(sv.shape[1]):
        m = edge == k
        a.plot(phi[m], rad[m], "x", ms=3, color="C%d" % (k % 10), alpha=0.5)
        a.plot(cc, np.concatenate([sv[:, k], [sv[0, k]]]), "-", color="C%d" % (k % 10), lw=1.2)
    a.set_xlim(0, 360)
    a.set_xlabel("image direction (deg)")
    a.set_ylabel("distance from image centre (px)")
    a.set_title("omni calibration: %d edge samples, 45 directions x 12 support vectors "
                "(grey: interpolated)" % len(phi))
    for k, m_ in enumerate(sym_m):
        if abs(m_ - 3.3) < 1e-6 or abs(m_ - 3.8) < 1e-6:
            m = edge == k
            b.plot(phi[m], rad[m], "x", ms=4, color="C%d" % (k % 10), alpha=0.6)
            b.plot(cc, np.concatenate([sv[:, k], [sv[0, k]]]), "-", color="C%d" % (k % 10),
                   label="model-free, %.1f m" % m_)
            b.axhline(sym_r[k], ls="--", color="C%d" % (k % 10), label="symmetric fit, %.1f m" % m_)
    b.set_xlim(0, 360)
    b.set_xlabel("image direction (deg)")
    b.set_ylabel("px")
    b.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=90)
    try:  # palette PNG: a quarter of the size
        from PIL import Image
        Image.open(out).convert("RGB").quantize(64).save(out, optimize=True)
    except ImportError:
        pass
    print("wrote", out)


if __name__ == "__main__":
    main()
