#!/usr/bin/env python3
"""The ball state's 3D error of a `ballvision run` states.csv against a rendered sequence's
truth.csv, over the last part of the frames with a state (issue 40's goals count the scene's last
two thirds: a changed rig is judged after it had time to be noticed).

    state_error.py STATES.csv SEQ_DIR [--skip-fraction 0.333] [--frames]

Prints the frame count, the median and the p90 (nearest rank below, in cm); --frames adds one line
per frame: index, error (cm), the truth's ball state, check_omni and check_persp.
"""
import argparse
import csv
import math
import sys


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("states")
    ap.add_argument("seq")
    ap.add_argument("--skip-fraction", type=float, default=1.0 / 3.0,
                    help="leading fraction of the frames with a state left out (default 1/3)")
    ap.add_argument("--frames", action="store_true", help="one line per frame")
    a = ap.parse_args()
    if not 0.0 <= a.skip_fraction < 1.0:
        sys.exit("state_error.py: --skip-fraction must be in [0, 1)")
    try:
        with open(a.seq + "/truth.csv", newline="") as f:
            truth = {r["index"]: r for r in csv.DictReader(f)}
        with open(a.states, newline="") as f:
            states = [r for r in csv.DictReader(f) if r.get("found") == "1"]
    except (OSError, KeyError) as e:
        sys.exit(f"state_error.py: {e}")
    rows = []
    for r in states:
        t = truth.get(r["index"])
        if t is None:
            sys.exit(f"state_error.py: frame {r['index']} of {a.states} is not in {a.seq}/truth.csv")
        try:
            p = [float(r[k]) for k in "xyz"]
            q = [float(t["ball_" + k]) for k in "xyz"]
        except (KeyError, ValueError) as e:
            sys.exit(f"state_error.py: frame {r['index']}: {e}")
        rows.append((int(r["index"]), 100.0 * math.dist(p, q), t.get("ball_state", ""),
                     r.get("check_omni", ""), r.get("check_persp", "")))
    if not rows:
        sys.exit("state_error.py: no frame with a state")
    part = rows[int(len(rows) * a.skip_fraction):]
    errs = sorted(e for _, e, *_ in part)
    median = errs[len(errs) // 2]
    p90 = errs[int(0.9 * (len(errs) - 1))]
    print(f"{a.states}: {len(rows)} frames with a state; frames {part[0][0]}-{part[-1][0]} "
          f"({len(part)}): median {median:.1f} cm, p90 {p90:.1f} cm")
    if a.frames:
        for i, e, state, co, cp in rows:
            print(f"{i} {e:.1f} {state} {co} {cp}")


if __name__ == "__main__":
    main()
