"""Change indication (issue 14): the full pipeline on the shared rendered sets, per-frame ball
states and the eval figures, against the committed files in this folder. A behaviour change
fails with the diff; after an intended change, regenerate and commit the files with the reason:

    python3 host_tests/change_indication/check.py build/host/tools/ballvision --update

usage: check.py BALLVISION [--sim DIR] [--update]   (DIR default ../shared/data/sim)
Exit 0 same, 1 changed (diff on stdout), 77 the shared data is absent (ctest: skipped)."""
import argparse
import csv
import difflib
import io
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
CALIB = os.path.join(REPO, "host_tests", "data", "reference_rig_calib.json")
SETS = ("static_grid", "bounce", "clutter")
SKIP = 77

# Decimals per column: 0.1 mm, 1 mm/s, 0.01 px, 0.01 deg. Columns not named here are kept as
# written (a new column shows in the diff); proc_us is the host's timing, not behaviour.
DECIMALS = {"x": 4, "y": 4, "z": 4, "px": 4, "py": 4, "pz": 4, "ray_gap": 4,
            "pose_x": 4, "pose_y": 4, "vx": 3, "vy": 3, "vz": 3,
            "omni_u": 2, "omni_v": 2, "persp_u": 2, "persp_v": 2, "pose_heading_deg": 2}
DROP = {"proc_us"}


def rounded(text):
    rows = list(csv.reader(io.StringIO(text)))
    header = rows[0]
    keep = [i for i, name in enumerate(header) if name not in DROP]
    out = [",".join(header[i] for i in keep)]
    for row in rows[1:]:
        fields = []
        for i in keep:
            value, places = row[i], DECIMALS.get(header[i])
            if value and places is not None:
                value = f"{float(value):.{places}f}"
                if float(value) == 0:
                    value = f"{0:.{places}f}"  # no "-0.0000"
            fields.append(value)
        out.append(",".join(fields))
    return "\n".join(out) + "\n"


def outputs(bv, sim, name, tmp):
    """{file name: text} of one set: states and the eval figures."""
    seq = os.path.join(sim, name)
    states = os.path.join(tmp, name + "_states.csv")
    env = {k: v for k, v in os.environ.items() if k != "BV_LUT"}
    r = subprocess.run([bv, "eval", seq, "--calib", CALIB, "--out", states],
                       capture_output=True, text=True, env=env, timeout=300)
    if r.returncode != 0:
        sys.exit(f"{name}: ballvision eval failed ({r.returncode}):\n{r.stderr}")
    with open(states) as f:
        states_text = rounded(f.read())
    return {name + "_states.csv": states_text,
            name + "_eval.txt": r.stdout.replace(seq, name)}


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("ballvision")
    p.add_argument("--sim", default=os.path.join(REPO, "..", "shared", "data", "sim"))
    p.add_argument("--update", action="store_true", help="rewrite the committed files")
    a = p.parse_args()
    if not all(os.path.isfile(os.path.join(a.sim, s, "frames.csv")) for s in SETS):
        print(f"shared data not found in {a.sim}: skipped")
        return SKIP
    changed = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in SETS:
            for fname, text in outputs(a.ballvision, a.sim, name, tmp).items():
                path = os.path.join(HERE, fname)
                old = open(path).read() if os.path.exists(path) else ""
                if old == text:
                    continue
                changed.append(fname)
                if a.update:
                    with open(path, "w") as f:
                        f.write(text)
                else:
                    sys.stdout.writelines(difflib.unified_diff(
                        old.splitlines(True), text.splitlines(True),
                        "committed/" + fname, "now/" + fname))
    if a.update:
        print("rewrote " + (", ".join(changed) if changed else "nothing (no change)"))
        return 0
    if changed:
        print("\nbehaviour changed in " + ", ".join(changed) + ". If intended, regenerate with\n"
              "  python3 host_tests/change_indication/check.py BALLVISION --update\n"
              "and commit the files with the reason.")
        return 1
    print("no change: " + ", ".join(SETS))
    return 0


if __name__ == "__main__":
    sys.exit(main())
