"""Commands to the coprocessor (core/protocol/commands.h): status request, parameters and
chunked uploads of the calibration or colour-LUT blob. Each command is answered with an ack
(type 0x10) or an error (type 0x11: cmd_type u8 | cmd_seq u32 | code u8 | detail u32)."""
import struct
import zlib
from typing import List

from .protocol import encode_frame

MSG_ACK, MSG_ERROR = 0x10, 0x11
REQUEST_STATUS, SET_PARAM, UPLOAD_BEGIN, UPLOAD_CHUNK, UPLOAD_COMMIT = 0x20, 0x21, 0x22, 0x23, 0x24
TARGET_CALIBRATION, TARGET_LUT = 1, 2
MAX_CHUNK = 512
ERRORS = {1: "unknown command", 2: "bad length", 3: "bad target", 4: "no upload", 5: "bad offset",
          6: "too large", 7: "verify failed", 8: "storage failed", 9: "unknown parameter",
          10: "bad value", 11: "incomplete"}


def request_status(seq: int) -> bytes:
    return encode_frame(REQUEST_STATUS, seq, b"")


def set_param(seq: int, param_id: int, value: float) -> bytes:
    return encode_frame(SET_PARAM, seq, struct.pack("<Hf", param_id, value))


def upload(seq: int, target: int, blob: bytes, chunk: int = MAX_CHUNK) -> List[bytes]:
    """Frames of a complete upload (begin, chunks, commit), sequence numbers from `seq`."""
    frames = [encode_frame(UPLOAD_BEGIN, seq, struct.pack("<BII", target, len(blob),
                                                         zlib.crc32(blob)))]
    for off in range(0, len(blob), chunk):
        seq += 1
        frames.append(encode_frame(UPLOAD_CHUNK, seq,
                                   struct.pack("<BI", target, off) + blob[off:off + chunk]))
    frames.append(encode_frame(UPLOAD_COMMIT, seq + 1, struct.pack("<B", target)))
    return frames


def parse_reply(mtype: int, payload: bytes):
    """(cmd_type, cmd_seq, error text or None) of an ack / error frame, else None."""
    if mtype == MSG_ACK and len(payload) == 5:
        t, s = struct.unpack("<BI", payload)
        return t, s, None
    if mtype == MSG_ERROR and len(payload) == 10:
        t, s, code, detail = struct.unpack("<BIBI", payload)
        return t, s, f"{ERRORS.get(code, code)} (detail {detail})"
    return None
