#!/usr/bin/env python3
"""Checks the QEMU teach test's UART output: the teach command (seq 100) answered by one ack and
no error, the colour table stored and active at the end (lut_state 0, a new lut_id), the ball
found in the pairs after the teach.
  check_teach_replies.py UART_BIN"""
import os
import struct
import sys

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "tools", "python"))
from ballvision_link import commands, protocol  # noqa: E402


def main():
    dec = protocol.Decoder()
    msgs = dec.feed(open(sys.argv[1], "rb").read())
    acks, errors, statuses, found_after = [], [], [], 0
    taught = False
    for m in msgs:
        if isinstance(m, tuple) and m[0] in (commands.MSG_ACK, commands.MSG_ERROR):
            cmd_type, cmd_seq = struct.unpack("<BI", m[2][:5])
            if cmd_type == commands.TEACH_BALL and cmd_seq == 100:
                (acks if m[0] == commands.MSG_ACK else errors).append(m)
                taught = m[0] == commands.MSG_ACK
        elif isinstance(m, protocol.StatusReport):
            statuses.append(m)
        elif isinstance(m, protocol.BallState) and taught and m.found:
            found_after += 1
    fail = []
    if len(acks) != 1 or errors:
        fail.append("teach: %d acks, errors %s" % (len(acks), [commands.parse_reply(e[0], e[2])
                                                             for e in errors]))
    first, last = statuses[0], statuses[-1]
    if first.lut_state != 3:
        fail.append("boot lut_state %d, expected 3 (built-in, none stored)" % first.lut_state)
    if last.lut_state != 0 or last.lut_id == first.lut_id:
        fail.append("end: lut_state %d lut_id %08x (boot %08x): the taught table is not active" %
                    (last.lut_state, last.lut_id, first.lut_id))
    if found_after == 0:
        fail.append("no ball found after the teach")
    print("teach: %d ack, lut_id %08x -> %08x, ball found in %d pairs after it" %
          (len(acks), first.lut_id, last.lut_id, found_after))
    if fail:
        print("FAIL: " + "; ".join(fail))
        sys.exit(1)


if __name__ == "__main__":
    main()
