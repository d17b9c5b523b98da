"""python3 -m ballvision_link.upload PORT calibration|lut|classifier BLOB [--baud N]

Uploads a calibration, colour-LUT or teach-file blob (`ballvision calib to-blob`, `ballvision lut
train`, `ballvision lut teach`) or a ball classifier's weights (tools/python/train_ball_classifier.py)
to the coprocessor: begin, 512-byte chunks, commit, each acknowledged before the next is sent.
The coprocessor activates it only after the whole blob verified; a cut link keeps the old one."""
import argparse
import sys
import time

from . import commands
from .protocol import Decoder


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python3 -m ballvision_link.upload", description=__doc__)
    ap.add_argument("port")
    ap.add_argument("target", choices=["calibration", "lut", "classifier"])
    ap.add_argument("blob")
    ap.add_argument("--baud", type=int, default=921600)
    a = ap.parse_args(argv)
    try:
        import serial  # pyserial (Debian python3-serial)
    except ImportError:
        print("ballvision_link.upload: needs pyserial (apt install python3-serial, or pip "
              "install pyserial)", file=sys.stderr)
        return 1
    port = serial.Serial(a.port, baudrate=a.baud, timeout=0.1)
    target = {"calibration": commands.TARGET_CALIBRATION, "lut": commands.TARGET_LUT,
              "classifier": commands.TARGET_CLASSIFIER}[a.target]
    dec = Decoder()
    for frame in commands.upload(1000, target, open(a.blob, "rb").read()):
        port.write(frame)
        deadline = time.monotonic() + 2.0
        reply = None
        while reply is None and time.monotonic() < deadline:
            for msg in dec.feed(port.read(4096)):
                if isinstance(msg, tuple):
                    reply = commands.parse_reply(msg[0], msg[2])
        if reply is None:
            print("no reply from the coprocessor", file=sys.stderr)
            return 1
        if reply[2] is not None:
            print(f"refused: {reply[2]}", file=sys.stderr)
            return 1
    print(f"uploaded {a.blob} as the {a.target}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
