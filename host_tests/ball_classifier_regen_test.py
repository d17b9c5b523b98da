"""The committed ball classifier is what its committed training command makes (issue 39): the
dev-set candidates are extracted afresh with this build, the classifier is trained as
tools/python/train_ball_classifier.py does, and every weights file must come out byte for byte.
Run by ctest with the host build's ballvision:  python3 ball_classifier_regen_test.py BALLVISION
Exits 77 (skipped) when ../shared/data/msl_robocup_ml is absent."""
import filecmp
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
SHARED = os.path.join(ROOT, "..", "shared", "data")
COMMITTED = {
    "ball_classifier_weights.cpp": os.path.join(ROOT, "core", "ball_check",
                                                "ball_classifier_weights.cpp"),
    "builtin.bin": os.path.join(HERE, "data", "ball_classifier", "builtin.bin"),
    "without_2019.bin": os.path.join(HERE, "data", "ball_classifier", "without_2019.bin"),
    "without_2022.bin": os.path.join(HERE, "data", "ball_classifier", "without_2022.bin"),
}


def main():
    if not os.path.exists(os.path.join(SHARED, "msl_robocup_ml", "annotations_px.txt")):
        print("skipped: no dev set at", SHARED)
        return 77
    with tempfile.TemporaryDirectory() as out:
        r = subprocess.run(["/usr/bin/python3", os.path.join(ROOT, "tools", "python",
                                                             "train_ball_classifier.py"),
                            "--ballvision", sys.argv[1], "--shared", SHARED, "--out-dir", out],
                           capture_output=True, text=True, timeout=900)
        print(r.stdout)
        if r.returncode != 0:
            print(r.stderr)
            return 1
        bad = [n for n, p in COMMITTED.items() if not filecmp.cmp(os.path.join(out, n), p,
                                                                   shallow=False)]
        if bad:
            print("differ from the committed files: %s (features, training data or the script "
                  "changed: rerun tools/python/train_ball_classifier.py and commit its output)"
                  % ", ".join(bad))
            return 1
    print("the committed classifier regenerates byte for byte")
    return 0


if __name__ == "__main__":
    sys.exit(main())
