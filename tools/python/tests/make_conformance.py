"""Writes host_tests/data/protocol_conformance.json: byte streams and the verdicts both decoders
(core/protocol's Decoder, ballvision_link.protocol.Decoder) must reach. The expected counters are
written out by hand from docs/protocol.md and the receive limits (payload <= 1024 bytes, raw
frame <= 1038, wire frame <= 1044 bytes without the delimiter); they are not taken from either
decoder. Run again only to add cases:  python3 tools/python/tests/make_conformance.py"""
import json
import math
import os
import struct
import sys
import zlib

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
from ballvision_link.protocol import HEADER, SCHEMA_HASH, VERSION, cobs_encode  # noqa: E402

OUT = os.path.join(os.path.dirname(__file__), "..", "..", "..", "host_tests", "data",
                   "protocol_conformance.json")
BALL, STATUS = 0x01, 0x02
BALL_FMT = struct.Struct("<QHBB3f3ff2f2fQ2fI3fI3H3HBBHH")
STATUS_FMT = struct.Struct("<Q12IBBBB13IHHBB")


def raw(mtype, seq, payload, version=VERSION, schema=SCHEMA_HASH, length=None, crc_xor=0):
    body = HEADER.pack(version, mtype, schema, seq, len(payload) if length is None else length)
    body += payload
    return body + struct.pack("<I", (zlib.crc32(body) ^ crc_xor) & 0xFFFFFFFF)


def wire(r):
    return cobs_encode(r) + b"\x00"


def ball(t_us=1000000, flags=3, mode=1, found=1, x=0.25):
    return BALL_FMT.pack(t_us, flags, mode, found, x, 3.5, 0.11, -1, 0.5, 0, 0.004, 100.5,
                         200.25, 300, 240, 0, 0, 0, 0, 0, 0, 0, 1234, 12, 15, 40, 0, 0, 0,
                         0, 3 | 5 << 2, 0, 0)  # persp unusable: repeated, dark


def status(cal_state=0, lut_state=0):
    return STATUS_FMT.pack(5000000, 30, 30000, 0, 0, 0, 0, 0, 0, 0, 0, 0x1234, 0x5678,
                           cal_state, lut_state, 0, 3 | 5 << 2, 0, 0, 0, 100, 200, 0, 0, 0, 0, 0,
                           0, 0, 12, 0, 125, 0, 90)


def case(name, data, msgs=(), **counters):
    c = {k: 0 for k in ("frames_ok", "crc", "cobs", "oversize", "short", "version", "length",
                        "bytes_discarded", "bad_payload")}
    c.update(counters)
    return {"name": name, "hex": data.hex(), "messages": [list(m) for m in msgs], "expect": c}


def cases():
    w_ball = wire(raw(BALL, 41, ball()))
    big = bytes((i % 255) + 1 for i in range(1024))
    w1025 = cobs_encode(raw(0x23, 9, big + b"\x07"))
    w1500 = cobs_encode(raw(0x23, 9, bytes((i % 255) + 1 for i in range(1500))))
    bad_crc = wire(raw(BALL, 1, ball(), crc_xor=1))
    garbage = b"\x11" * 3000
    out = [
        case("valid_ball", w_ball, [(BALL, 41)], frames_ok=1),
        case("valid_status", wire(raw(STATUS, 7, status())), [(STATUS, 7)], frames_ok=1),
        case("valid_unknown_type", wire(raw(0x7F, 3, b"abc")), [(0x7F, 3)], frames_ok=1),
        case("valid_empty_payload", wire(raw(0x20, 0, b"")), [(0x20, 0)], frames_ok=1),
        case("limit_seq_and_time_max", wire(raw(BALL, 0xFFFFFFFF, ball(t_us=2**64 - 1))),
             [(BALL, 0xFFFFFFFF)], frames_ok=1),
        case("limit_payload_1024", wire(raw(0x23, 5, big)), [(0x23, 5)], frames_ok=1),
        case("limit_payload_1024_zeros", wire(raw(0x23, 6, bytes(1024))), [(0x23, 6)],
             frames_ok=1),
        # 1025 bytes still fit the wire buffer (1044) but not the raw one (1038): COBS error.
        case("over_payload_1025", w1025 + b"\x00", cobs=1, bytes_discarded=len(w1025)),
        # The example: valid CRC, payload_len 1500 > 1024. Discarded to the next 0x00.
        case("over_payload_1500", w1500 + b"\x00", oversize=1,
             bytes_discarded=len(w1500) - 1044),
        case("over_garbage_then_valid", garbage + b"\x00" + w_ball, [(BALL, 41)], frames_ok=1,
             oversize=1, bytes_discarded=3000 - 1044),
        case("corrupt_crc", bad_crc, crc=1, bytes_discarded=len(bad_crc) - 1),
        case("corrupt_version", wire(raw(BALL, 1, ball(), version=1)), version=1,
             bytes_discarded=len(wire(raw(BALL, 1, ball()))) - 1),
        case("corrupt_schema", wire(raw(BALL, 1, ball(), schema=SCHEMA_HASH ^ 1)), version=1,
             bytes_discarded=len(wire(raw(BALL, 1, ball()))) - 1),
        case("corrupt_length_field", wire(raw(BALL, 1, ball(), length=91)), length=1,
             bytes_discarded=len(wire(raw(BALL, 1, ball()))) - 1),
        case("corrupt_short_frame", wire(b"\x01" * 13), short=1,
             bytes_discarded=len(wire(b"\x01" * 13)) - 1),
        case("corrupt_cobs_code_past_end", b"\x05\x01\x02\x00", cobs=1, bytes_discarded=3),
        case("corrupt_then_resync", b"\x01\x01\x01\x00" + w_ball, [(BALL, 41)], frames_ok=1,
             short=1, bytes_discarded=3),
        case("empty_frames_ignored", b"\x00\x00\x00" + w_ball + b"\x00", [(BALL, 41)],
             frames_ok=1),
        case("truncated_no_delimiter", w_ball[:-1]),
        case("payload_ball_bad_mode", wire(raw(BALL, 2, ball(mode=4))), frames_ok=1,
             bad_payload=1),
        case("payload_ball_found_2", wire(raw(BALL, 2, ball(found=2))), frames_ok=1,
             bad_payload=1),
        case("payload_ball_found_nan", wire(raw(BALL, 2, ball(x=math.nan))), frames_ok=1,
             bad_payload=1),
        case("payload_ball_not_found_nan_ok", wire(raw(BALL, 2, ball(found=0, x=math.nan))),
             [(BALL, 2)], frames_ok=1),
        case("payload_ball_short", wire(raw(BALL, 2, ball()[:91])), frames_ok=1, bad_payload=1),
        case("payload_status_bad_state", wire(raw(STATUS, 2, status(cal_state=3))),
             frames_ok=1, bad_payload=1),
        case("payload_status_state_limit", wire(raw(STATUS, 2, status(2, 2))), [(STATUS, 2)],
             frames_ok=1),
    ]
    return out


if __name__ == "__main__":
    with open(OUT, "w") as f:
        json.dump({"_doc": __doc__.split("\n")[0], "cases": cases()}, f, indent=1)
        f.write("\n")
    print(f"wrote {os.path.normpath(OUT)}")
