#!/usr/bin/python3
"""Trains the ball classifier of core/ball_check (an int8 MLP on BallFeatures) and writes its
weights: the built-in blob and its C++ array, and two blobs each trained without one venue of the
dev set (for honest figures on that venue).

Training data (host_tests/data/ball_classifier/README.md):
  - real: the candidates `ballvision detect-eval --protocol all --classifier off --candidates`
    finds on ../shared/data/msl_robocup_ml (every set, all three protocols' colour tables),
    labelled by the dataset's ball boxes; extracted afresh by this script;
  - renders: host_tests/data/ball_classifier/candidates_sim.csv.gz, the candidates of six venue
    renders (seeds 601-606, yellow, orange and red balls), labelled by truth.csv.
A row is a candidate the classifier would see (it passed the shape and the place test); its label
is 1 when it lies on a ball.

    /usr/bin/python3 tools/python/train_ball_classifier.py --ballvision build/host/tools/ballvision \
        --shared ../shared/data --out-dir OUT [--report]

writes OUT/builtin.bin, OUT/without_2019.bin, OUT/without_2022.bin and
OUT/ball_classifier_weights.cpp (core/ball_check's built-in). Deterministic: the same build and
data give the same bytes (lbfgs, fixed seed, one BLAS thread); host_tests regenerates them.
--compact-sim CSV... writes the compact render table from detect-eval --sim tables instead.
"""
import argparse
import gzip
import io
import os
import struct
import sys
import zlib

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

FEATURES = 28            # kBallFeatureCount
FEATURE_SET_VERSION = 1  # kBallFeatureSetVersion
HIDDEN = 16
INPUT_SCALE = 32.0       # BallClassifier: int8 input = standardised value x 32
BLOB_KIND = 3            # BlobKind::kBallClassifier
BLOB_VERSION = 1
MAGIC = 0x31425642       # "BVB1"


def read_table(path):
    raw = open(path, "rb").read()
    if path.endswith(".gz"):
        raw = gzip.decompress(raw)
    lines = raw.decode().splitlines()
    head = lines[0].split(",")
    col = {n: i for i, n in enumerate(head)}
    for need in ["protocol", "set", "image", "box", "refusal", "height_m", "floor_ratio",
                 "f0", "f%d" % (FEATURES - 1)]:
        if need not in col:
            sys.exit("%s: no column '%s' (not a detect-eval --candidates table)" % (path, need))
    rows = [ln.split(",") for ln in lines[1:] if ln]
    return col, rows


def load(paths):
    """Features, labels, venue (image-name prefix; 'sim' for renders), image key, place prior."""
    X, y, group, image, prior = [], [], [], [], []
    for p in paths:
        col, rows = read_table(p)
        fi = [col["f%d" % i] for i in range(FEATURES)]
        for r in rows:
            if r[col["refusal"]] not in ("none", "look"):
                continue  # the classifier never sees what shape and place refused
            X.append([float(r[i]) for i in fi])
            # box -2, a ball matched only beyond the image border that cuts it, stays a negative as
            # before detect-eval told it apart: dropping those 15 rows moved the weights more than
            # they weigh (core/ball_check/README.md, "Training is not stable").
            y.append(1 if int(r[col["box"]]) >= 0 else 0)
            proto = r[col["protocol"]]
            group.append("sim" if proto == "sim" else r[col["set"]][:4])
            image.append((os.path.basename(p), proto, r[col["set"]], r[col["image"]],
                          int(r[col["countable"]])))
            h, fr = float(r[col["height_m"]]), float(r[col["floor_ratio"]])
            known = h != 0.0 or fr != 0.0
            prior.append(np.exp(-max(0.0, h - 0.22) / 1.5) if known else 1.0)
    return (np.array(X, dtype=np.float64), np.array(y), np.array(group), image,
            np.array(prior))


ALPHAS = (3.0, 10.0, 30.0, 100.0, 300.0, 1000.0)  # L2 weights tried


def fit(X, y, alpha):
    from sklearn.neural_network import MLPClassifier
    mean = X.mean(0)
    sd = X.std(0)
    sd[sd < 1e-6] = 1.0
    m = MLPClassifier(hidden_layer_sizes=(HIDDEN,), activation="relu", solver="lbfgs",
                      alpha=alpha, max_iter=4000, random_state=0)
    m.fit((X - mean) / sd, y)
    return mean, sd, m


def choose_alpha(X, y, sets, image, prior):
    """The L2 weight by the task's own score, leave-one-set-out over the training sets only (each
    real date_robot set and the renders one group; a venue left out for figures never sees it):
    images whose first ball is right minus images whose first ball is wrong. A tie goes to the
    larger weight: the simpler model, when the folds cannot tell them apart."""
    best = None
    for alpha in ALPHAS:
        score = 0
        for s in sorted(set(sets)):
            te = np.where(sets == s)[0]
            tr = sets != s
            if y[tr].min() == y[tr].max():
                continue
            mean, sd, m = fit(X[tr], y[tr], alpha)
            p = m.predict_proba((X[te] - mean) / sd)[:, 1]
            f, _, fa, _ = image_figures([image[i] for i in te], y[te],
                                        ranked(p, p > 0.5, prior[te]))
            score += f - fa
        if best is None or score >= best[1]:
            best = (alpha, score)
    return best[0]


def ranked(p, passed, prior):
    """A candidate's rank key as core/detect has it: look probability times place prior; -1 when
    the look check refuses it."""
    return np.where(passed, prior * p, -1.0)


def train(X, y, sets, image, prior, keep):
    """Trains on the rows of `keep`, the L2 weight chosen on them alone."""
    idx = np.flatnonzero(keep)
    alpha = choose_alpha(X[idx], y[idx], sets[idx], [image[i] for i in idx], prior[idx])
    mean, sd, m = fit(X[idx], y[idx], alpha)
    return mean, sd, m, alpha


def quantise(mean, sd, m, X):
    """The int8 network of BallClassifier::Logit, and a function that evaluates it exactly so."""
    W1, W2 = m.coefs_[0].T, m.coefs_[1][:, 0]   # (hidden, features), (hidden,)
    b1, b2 = m.intercepts_[0], float(m.intercepts_[1][0])
    in_scale = (INPUT_SCALE / sd).astype(np.float32)
    in_mean = mean.astype(np.float32)
    s_w1 = np.abs(W1).max() / 127.0
    w1 = np.clip(np.round(W1 / s_w1), -127, 127).astype(np.int8)
    b1q = np.round(b1 * INPUT_SCALE / s_w1).astype(np.int64)

    def inputs(F):
        F = F.astype(np.float32)
        q = np.round((F - in_mean) * in_scale)
        return np.clip(q, -127, 127).astype(np.int64)

    acc = inputs(X) @ w1.T.astype(np.int64) + b1q
    act_max = max(float((np.maximum(acc, 0) * (s_w1 / INPUT_SCALE)).max()), 1e-6)
    s_a = act_max / 127.0
    s1 = np.float32(s_w1 / INPUT_SCALE / s_a)
    s_w2 = max(np.abs(W2).max(), 1e-9) / 127.0
    w2 = np.clip(np.round(W2 / s_w2), -127, 127).astype(np.int8)
    b2q = int(round(b2 / (s_w2 * s_a)))
    s2 = np.float32(s_w2 * s_a)

    def logit(F):
        a = inputs(F) @ w1.T.astype(np.int64) + b1q
        a = np.where(a > 0, np.minimum(np.round(a.astype(np.float32) * s1), 127), 0)
        return (a.astype(np.int64) @ w2.astype(np.int64) + b2q).astype(np.float32) * s2

    q = dict(in_mean=in_mean, in_scale=in_scale, w1=w1, b1=b1q, s1=s1, w2=w2, b2=b2q, s2=s2)
    return q, logit


def blob(q, threshold):
    p = struct.pack("<BBBB", FEATURE_SET_VERSION, FEATURES, HIDDEN, 0)
    p += struct.pack("<%df" % FEATURES, *q["in_mean"])
    p += struct.pack("<%df" % FEATURES, *q["in_scale"])
    p += q["w1"].astype(np.int8).tobytes()
    p += struct.pack("<%di" % HIDDEN, *[int(v) for v in q["b1"]])
    p += struct.pack("<f", float(q["s1"]))
    p += q["w2"].astype(np.int8).tobytes()
    p += struct.pack("<if", int(q["b2"]), float(q["s2"]))
    p += struct.pack("<f", threshold)
    head = struct.pack("<IHHII", MAGIC, BLOB_KIND, BLOB_VERSION, len(p), zlib.crc32(p))
    return head + p


def image_figures(image, y, score):
    """First ball per image (highest positive score), scored as detect-eval does."""
    best = {}
    for i, key in enumerate(image):
        k = key[:4]
        if score[i] > 0 and (k not in best or score[i] > score[best[k]]):
            best[k] = i
    countable = {}
    for key in image:
        countable[key[:4]] = max(countable.get(key[:4], 0), key[4])
    found = sum(1 for k, i in best.items() if y[i] == 1 and countable[k])
    false = sum(1 for k, i in best.items() if y[i] == 0)
    return found, sum(countable.values()), false, len(countable)


KEEP = ["protocol", "set", "image", "countable", "box", "refusal", "height_m", "floor_ratio"]


def compact(paths, out):
    """The rows the classifier sees, the columns it needs, 4 significant digits; gzip (mtime 0)."""
    lines = [",".join(KEEP + ["f%d" % i for i in range(FEATURES)])]
    for p in paths:
        col, rows = read_table(p)
        idx = [col[k] for k in KEEP] + [col["f%d" % i] for i in range(FEATURES)]
        for r in rows:
            if r[col["refusal"]] not in ("none", "look"):
                continue
            v = [r[i] for i in idx]
            v[len(KEEP):] = ["%.4g" % float(x) for x in v[len(KEEP):]]
            lines.append(",".join(v))
    data = ("\n".join(lines) + "\n").encode()
    with open(out, "wb") as f:
        with gzip.GzipFile(fileobj=f, mode="wb", mtime=0, filename="") as g:
            g.write(data)
    return len(lines) - 1


def extract_real(ballvision, shared, more_boxes, out):
    import subprocess
    d = os.path.join(shared, "msl_robocup_ml")
    raw = out + ".raw"
    cmd = [ballvision, "detect-eval", "--boxes", os.path.join(d, "annotations_px.txt"),
           "--more-boxes", more_boxes, "--images", os.path.join(d, "images"), "--protocol", "all",
           "--classifier", "off", "--candidates", raw]
    r = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    if r.returncode != 0:
        sys.exit("train_ball_classifier: %s failed: %s" % (" ".join(cmd), r.stderr))
    n = compact([raw], out)
    os.remove(raw)
    return n


CPP = """// Generated by tools/python/train_ball_classifier.py: do not edit (host_tests regenerates it).
// The built-in ball classifier's weights blob (BlobKind::kBallClassifier), trained on every set of
// ../shared/data/msl_robocup_ml and the six venue renders of host_tests/data/ball_classifier.
#include "core/ball_check/ball_check.h"

namespace bv {
namespace {
// clang-format off
constexpr uint8_t kBlob[] = {
%s};
// clang-format on
}  // namespace

std::span<const uint8_t> BuiltInBallClassifierBlob() { return kBlob; }

}  // namespace bv
"""


def cpp_source(data):
    rows = []
    for i in range(0, len(data), 12):
        rows.append("    " + ", ".join("0x%02x" % b for b in data[i:i + 12]) + ",")
    return CPP % "\n".join(rows) + ""


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--ballvision", help="the host build's ballvision (extracts the real rows)")
    ap.add_argument("--shared", help="../shared/data")
    ap.add_argument("--sim-table", default=os.path.join(
        os.path.dirname(os.path.abspath(__file__)), "..", "..", "host_tests", "data",
        "ball_classifier", "candidates_sim.csv.gz"))
    ap.add_argument("--more-boxes", default=os.path.join(
        os.path.dirname(os.path.abspath(__file__)), "..", "..", "host_tests", "data",
        "msl_more_boxes", "unlabelled_balls.txt"), help="balls the dataset's boxes leave out")
    ap.add_argument("--out-dir")
    ap.add_argument("--threshold", type=float, default=0.0, help="logit above which: a ball")
    ap.add_argument("--report", action="store_true", help="leave-one-venue-out figures")
    ap.add_argument("--compact-sim", nargs="+", metavar="CSV",
                    help="write --sim-table from these detect-eval --sim tables and stop")
    a = ap.parse_args()
    if a.compact_sim:
        print("wrote %s: %d rows" % (a.sim_table, compact(a.compact_sim, a.sim_table)))
        return
    if not (a.ballvision and a.shared and a.out_dir):
        ap.error("--ballvision, --shared and --out-dir are needed")
    os.makedirs(a.out_dir, exist_ok=True)
    real = os.path.join(a.out_dir, "candidates_real.csv.gz")
    extract_real(a.ballvision, a.shared, a.more_boxes, real)
    X, y, group, image, prior = load([real, a.sim_table])
    sets = np.array([g if g == "sim" else key[2] for g, key in zip(group, image)])
    if a.report:
        for v in sorted(set(group) - {"sim"}):
            tr = group != v
            mean, sd, m, alpha = train(X, y, sets, image, prior, tr)
            q, logit = quantise(mean, sd, m, X[tr])
            te = np.where(group == v)[0]
            lg = logit(X[te])
            s = ranked(1 / (1 + np.exp(-np.clip(lg, -50, 50))), lg > a.threshold, prior[te])
            for proto in sorted(set(image[i][1] for i in te)):
                sel = [k for k, i in enumerate(te) if image[i][1] == proto]
                f, n, fa, imgs = image_figures([image[te[k]] for k in sel], y[te][sel], s[sel])
                print("venue %s left out (L2 %g), %-8s found %3d / %3d (%5.1f %%), false %3d / %3d "
                      "(%4.1f %%)" % (v, alpha, proto, f, n, 100.0 * f / max(n, 1), fa, imgs,
                                      100.0 * fa / max(imgs, 1)))
    for name, leave_out in (("builtin", None), ("without_2019", "2019"),
                            ("without_2022", "2022")):
        keep = group != leave_out if leave_out else np.ones(len(y), dtype=bool)
        mean, sd, m, alpha = train(X, y, sets, image, prior, keep)
        q, logit = quantise(mean, sd, m, X[keep])
        acc = ((logit(X[keep]) > a.threshold) == (y[keep] == 1)).mean()
        data = blob(q, a.threshold)
        with open(os.path.join(a.out_dir, name + ".bin"), "wb") as f:
            f.write(data)
        if leave_out is None:
            with open(os.path.join(a.out_dir, "ball_classifier_weights.cpp"), "w") as f:
                f.write(cpp_source(data))
        print("%s: %d bytes, %d candidates (%d balls), L2 %g by leave-one-set-out, training "
              "accuracy %.3f" % (name, len(data), keep.sum(), y[keep].sum(), alpha, acc))


if __name__ == "__main__":
    main()
