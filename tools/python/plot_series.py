#!/usr/bin/python3
"""Draws the line plots of `ballvision eval --plots` and `ballvision demo` with matplotlib.

    /usr/bin/python3 tools/python/plot_series.py SPEC.json OUTDIR

SPEC.json: {"plots": [{"file": "name.png", "title", "xlabel", "ylabel", "ylim": [lo, hi] | null,
"series": [{"name", "x": [...], "y": [...], "color": "#rrggbb",
"style": "line" | "points" | "dashed" | "linepoints"}]}]}; null in x or y breaks a line.
Each plot is written to OUTDIR/<file>; the caller (tools/ballvision/plot.cpp) moves it to its
target, so the rules for replacing files live in one place. Exit 3 when matplotlib is missing
(the caller then writes text tables), 2 on a bad spec, 0 otherwise.
"""
import json
import math
import os
import sys

NO_MATPLOTLIB = 3
STYLES = {"line": {"linestyle": "-"},
          "points": {"linestyle": "none", "marker": "o", "markersize": 3.5},
          "dashed": {"linestyle": "--"},
          "linepoints": {"linestyle": "-", "marker": "o", "markersize": 3.5}}


def values(seq):
    return [math.nan if v is None else float(v) for v in seq]


def draw(plt, plot, out_dir):
    fig, ax = plt.subplots(figsize=(9, 5.6), dpi=100)
    for s in plot["series"]:
        style = STYLES[s.get("style", "line")]
        ax.plot(values(s["x"]), values(s["y"]), color=s.get("color", "#000000"), linewidth=1.8,
                label=s["name"], **style)
    ax.set_title(plot.get("title", ""))
    ax.set_xlabel(plot.get("xlabel", ""))
    ax.set_ylabel(plot.get("ylabel", ""))
    if plot.get("ylim"):
        ax.set_ylim(*plot["ylim"])
    ax.grid(True, color="#e1e1e1")
    if plot["series"]:
        ax.legend(loc="best", fontsize="small")
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, os.path.basename(plot["file"])), format="png")
    plt.close(fig)


def main(argv):
    if len(argv) != 3:
        print(__doc__.strip().splitlines()[2].strip(), file=sys.stderr)
        return 2
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as e:
        print(f"matplotlib not available ({e})", file=sys.stderr)
        return NO_MATPLOTLIB
    try:
        with open(argv[1]) as f:
            spec = json.load(f)
        for plot in spec["plots"]:
            draw(plt, plot, argv[2])
    except (OSError, ValueError, KeyError, TypeError) as e:
        print(f"{argv[1]}: {type(e).__name__}: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
