"""python3 -m ballvision_link.teach PORT (--floor X Y | --omni U V | --persp U V) [--baud N]

Teaches the ball's colour on the coprocessor in one step (docs/protocol.md, "Teach"): "the ball
lies at floor point (X, Y)" (metres, robot frame) or "at pixel (U, V) of the omni / persp
camera". The coprocessor learns from its next frame pair, stores the new table A/B with CRC as
an upload would, and answers; a refusal (no ball there, the colour would take the field) keeps
the old table. PORT: a serial port (pyserial) or tcp:HOST:PORT."""
import argparse
import sys
import time

from . import commands
from .protocol import Decoder
from .sync import _Link

SEQ = 7000


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python3 -m ballvision_link.teach", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("port")
    where = ap.add_mutually_exclusive_group(required=True)
    where.add_argument("--floor", nargs=2, type=float, metavar=("X", "Y"))
    where.add_argument("--omni", nargs=2, type=float, metavar=("U", "V"))
    where.add_argument("--persp", nargs=2, type=float, metavar=("U", "V"))
    ap.add_argument("--baud", type=int, default=921600)
    ap.add_argument("--timeout", type=float, default=5.0,
                    help="seconds to wait for the answer (it follows the next frame pair)")
    a = ap.parse_args(argv)
    kind, (x, y) = ((commands.TEACH_FLOOR, a.floor) if a.floor else
                    (commands.TEACH_OMNI_PIXEL, a.omni) if a.omni else
                    (commands.TEACH_PERSP_PIXEL, a.persp))
    try:
        frame = commands.teach_ball(SEQ, kind, x, y)
        link = _Link(a.port, a.baud)
        link.write(frame)
        dec, deadline = Decoder(), time.monotonic() + a.timeout
        while time.monotonic() < deadline:
            for msg in dec.feed(link.read()):
                reply = commands.parse_reply(msg[0], msg[2]) if isinstance(msg, tuple) else None
                if reply is None or reply[0] != commands.TEACH_BALL or reply[1] != SEQ:
                    continue
                if reply[2] is not None:
                    print(f"ballvision_link.teach: refused: {reply[2]}; the old table stays",
                          file=sys.stderr)
                    return 1
                print("taught: the new colour table is stored and in use")
                return 0
    except (OSError, EOFError, ValueError) as e:
        print(f"ballvision_link.teach: {e}", file=sys.stderr)
        return 1
    print(f"ballvision_link.teach: no answer within {a.timeout:g} s; the old table stays",
          file=sys.stderr)
    return 1


if __name__ == "__main__":
    sys.exit(main())
