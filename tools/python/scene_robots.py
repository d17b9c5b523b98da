#!/usr/bin/python3
"""Writes the other robots' true positions (robot frame, m) of a rendered scene as CSV
(index,x,y,radius), from the renderer's own scene description (../shared/render/scenes.py):
the obstacle truth for `ballvision eval-field --robots`.

  /usr/bin/python3 tools/python/scene_robots.py SEQ_DIR > robots.csv
SEQ_DIR/scene.json names the scene and seed; the renderer must be at ../shared/render (or
--render DIR). Robots of the reference scenes are 0.5 m wide octagons with a 0.262 m bumper."""
import argparse
import json
import os
import sys

ROBOT_RADIUS_M = 0.262


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("seq")
    here = os.path.dirname(os.path.abspath(__file__))
    ap.add_argument("--render", default=os.path.join(here, "..", "..", "..", "shared", "render"))
    a = ap.parse_args()
    sys.path.insert(0, os.path.abspath(a.render))
    import rigmodel as rm  # noqa: E402
    from scenes import build_scene  # noqa: E402
    meta = json.load(open(os.path.join(a.seq, "scene.json")))
    rig_path = os.path.join(a.seq, "rig_truth.json")
    rig = json.load(open(os.path.join(a.render, "rig.json")))
    if os.path.exists(rig_path):
        rt = json.load(open(rig_path))
        rig = rt.get("rig_input", rig)
    scene = build_scene(meta["name"], rig, meta["seed"], rm.OmniModel(rig), rm.PerspModel(rig))
    kept = set(meta.get("frame_indices", []))
    print("index,x,y,radius")
    for fr in scene["frames"]:
        if kept and fr["index"] not in kept:
            continue
        for (x, y, _h) in fr.get("robots", []):
            print("%d,%.4f,%.4f,%.3f" % (fr["index"], x, y, ROBOT_RADIUS_M))


if __name__ == "__main__":
    main()
