#!/usr/bin/python3
"""Pools the ball state's uncertainty calibration over several evaluated sequences.

usage: /usr/bin/python3 pool_sigma.py BALLVISION CALIB.json SEQ[:stills] ... [--lut L] [--scale C]
Runs `ballvision eval SEQ --calib CALIB --lut L --sigma-errors F` per sequence (`:stills` adds
--stills) and prints, per sequence and pooled over all scored axes, how often |error| lies within
1 / 2 / 3 sigma (68.3 / 95.4 / 99.7 % for a calibrated Gaussian), |error| / sigma at the 68th /
95th / 99.7th percentile and its rms (1 for a right variance). --scale C scores C x sigma (what
another report_sigma_scale would give). Per-sequence percentages alone cannot be pooled: the sets
differ in size and a shared error is one draw per sequence.
"""
import argparse
import csv
import os
import subprocess
import sys
import tempfile

import numpy as np


def summary(r):
    return "within 1 / 2 / 3 sigma %5.1f / %5.1f / %5.1f %%, 68th / 95th / 99.7th %.2f / %.2f / %.2f, rms %.2f" % (
        100 * np.mean(r <= 1), 100 * np.mean(r <= 2), 100 * np.mean(r <= 3),
        np.percentile(r, 68), np.percentile(r, 95), np.percentile(r, 99.7),
        np.sqrt(np.mean(np.minimum(r, 1e3) ** 2)))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("ballvision")
    ap.add_argument("calib")
    ap.add_argument("seqs", nargs="+", metavar="SEQ[:stills]")
    ap.add_argument("--lut", default="builtin")
    ap.add_argument("--scale", type=float, default=1.0)
    a = ap.parse_args()
    if not a.scale > 0:
        sys.exit("pool_sigma: --scale must be a positive number, got %r" % a.scale)
    pooled = []
    with tempfile.TemporaryDirectory() as tmp:
        for k, spec in enumerate(a.seqs):
            seq, _, opt = spec.rpartition(":") if spec.endswith(":stills") else (spec, "", "")
            out = os.path.join(tmp, "%d.csv" % k)
            cmd = [a.ballvision, "eval", seq, "--calib", a.calib, "--lut", a.lut,
                   "--sigma-errors", out] + (["--stills"] if opt == "stills" else [])
            p = subprocess.run(cmd, capture_output=True, text=True)
            if p.returncode != 0:
                last = (p.stderr.strip().splitlines() or ["no message"])[-1]
                sys.exit("pool_sigma: %s failed (%d): %s" % (" ".join(cmd), p.returncode, last))
            with open(out) as f:
                rows = list(csv.DictReader(f))
            if not rows:
                print("%s: no scored axes" % seq)
                continue
            err = np.array([abs(float(r["error_m"])) for r in rows])
            sig = a.scale * np.array([float(r["sigma_m"]) for r in rows])
            r = np.where(sig > 0, err / np.maximum(sig, 1e-12), 1e9)
            pooled.append(r)
            print("%s (%d axes): %s" % (seq, len(r), summary(r)))
    if not pooled:
        sys.exit("pool_sigma: no sequence had scored axes")
    r = np.concatenate(pooled)
    print("pooled over %d sequences (%d axes)%s: %s" % (
        len(pooled), len(r), "" if a.scale == 1.0 else ", sigma x %g" % a.scale, summary(r)))


if __name__ == "__main__":
    main()
