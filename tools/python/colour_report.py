#!/usr/bin/env python3
"""Ball-colour figures per scene and camera (issue #11 item 4), from the full pipeline.

For every rendered sequence given (with truth.csv), runs `ballvision eval-field` three times:
  (a) with the built-in colour model's table, no teaching;
  (c) the same with online colour adaptation on (`--adapt`, as the device's parameter 20);
  (b) after a one-click teach: `ballvision lut teach SEQ --click ...`, the click being the
      persp ball centre of the first frame where the ball is fully visible and at least 8 px
      across (what a user would click), taken from truth.csv.
and prints recall (frames with the ball at least 4 px across that found it), centre error
median / p90 against the visible-silhouette centroid, and false balls, per camera.

    tools/python/colour_report.py --ballvision build/host/tools/ballvision \
        --calib host_tests/data/reference_rig_calib.json SEQ [SEQ ...]
"""
import argparse
import csv
import math
import os
import re
import subprocess
import sys
import tempfile

LINE = re.compile(
    r"^ball (omni|persp)\s+found (\d+) of (\d+) visible \(([\d.]+) %\), false (\d+), "
    r"centre error median ([\d.]+) px p90 ([\d.]+) px")


def run(cmd):
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit("colour_report: %s failed (%d):\n%s" % (" ".join(cmd), p.returncode, p.stderr))
    return p.stdout


def figures(ballvision, seq, calib, lut, adapt=False):
    out = run([ballvision, "eval-field", seq, "--calib", calib, "--lut", lut] +
              (["--adapt"] if adapt else []))
    got = {}
    for line in out.splitlines():
        m = LINE.match(line)
        if m:
            got[m.group(1)] = dict(found=int(m.group(2)), visible=int(m.group(3)),
                                   recall=float(m.group(4)), false=int(m.group(5)),
                                   median=float(m.group(6)), p90=float(m.group(7)))
    if set(got) != {"omni", "persp"}:
        sys.exit("colour_report: no per-camera ball lines from eval-field on %s" % seq)
    return got


def click_from_truth(seq):
    with open(os.path.join(seq, "truth.csv")) as f:
        for row in csv.DictReader(f):
            if row["visible_persp"] != "1" or float(row["visfrac_persp"]) < 0.95:
                continue
            if 2 * math.sqrt(float(row["area_persp"]) / math.pi) < 8:
                continue
            return "%s:persp:%.0f,%.0f" % (row["index"], float(row["cu_persp"]),
                                          float(row["cv_persp"]))
    return None


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--ballvision", required=True)
    ap.add_argument("--calib", required=True)
    ap.add_argument("seqs", nargs="+")
    a = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for seq in a.seqs:
            name = os.path.basename(os.path.dirname(os.path.abspath(seq))) + "/" + \
                os.path.basename(os.path.abspath(seq))
            rows.append((name, "(a) built-in", figures(a.ballvision, seq, a.calib, "builtin")))
            rows.append((name, "(c) built-in + adaptation",
                         figures(a.ballvision, seq, a.calib, "builtin", adapt=True)))
            click = click_from_truth(seq)
            if click is None:
                rows.append((name, "(b) one click", None))
                continue
            lut = os.path.join(tmp, "taught.lut")
            run([a.ballvision, "lut", "teach", seq, "--out", lut, "--click", click])
            rows.append((name, "(b) click " + click,
                         figures(a.ballvision, seq, a.calib, lut)))
    print("| scene | colour | omni recall | omni err med/p90 px | omni false | "
          "persp recall | persp err med/p90 px | persp false |")
    print("|---|---|---|---|---|---|---|---|")
    for name, how, f in rows:
        if f is None:
            print("| %s | %s | no frame to click on | | | | | |" % (name, how))
            continue
        cells = []
        for cam in ("omni", "persp"):
            c = f[cam]
            cells += ["%.1f %% (%d/%d)" % (c["recall"], c["found"], c["visible"]),
                      "%.2f / %.2f" % (c["median"], c["p90"]), str(c["false"])]
        print("| %s | %s | %s |" % (name, how, " | ".join(cells)))


if __name__ == "__main__":
    main()
