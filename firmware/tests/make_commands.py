#!/usr/bin/env python3
"""Writes command frames for the firmware's UART input with the main computer's own package
(tools/python/ballvision_link).
  make_commands.py OUT [CALIBRATION_BLOB]
OUT gets: request-status, set-param(frame period = 20000 us), set-param(unknown id 77) and, with
a blob, its complete chunked upload."""
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "tools", "python"))
from ballvision_link import commands  # noqa: E402


def main():
    out = commands.request_status(1)
    out += commands.set_param(2, 1, 20000.0)
    out += commands.set_param(3, 77, 1.0)
    if len(sys.argv) > 2:
        blob = open(sys.argv[2], "rb").read()
        out += b"".join(commands.upload(4, commands.TARGET_CALIBRATION, blob))
    open(sys.argv[1], "wb").write(out)


if __name__ == "__main__":
    main()
