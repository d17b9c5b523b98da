#!/usr/bin/env python3
"""Writes the command stream of the QEMU teach test with the main computer's own package
(tools/python/ballvision_link): "the ball lies at pixel (U, V) of the persp camera".
  make_teach_commands.py OUT U V"""
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "tools", "python"))
from ballvision_link import commands  # noqa: E402


def main():
    out = commands.teach_ball(100, commands.TEACH_PERSP_PIXEL, float(sys.argv[2]),
                              float(sys.argv[3]))
    open(sys.argv[1], "wb").write(out)


if __name__ == "__main__":
    main()
