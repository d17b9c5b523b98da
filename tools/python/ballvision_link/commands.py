"""Commands to the coprocessor (core/protocol/commands.h): status request, parameters,
localisation hints (field half, odometry, pose) and chunked uploads of the calibration or
colour-LUT blob. Each command is answered with an ack
(type 0x10) or an error (type 0x11: cmd_type u8 | cmd_seq u32 | code u8 | detail u32)."""
import struct
import zlib
from typing import List

from .protocol import encode_frame

MSG_ACK, MSG_ERROR = 0x10, 0x11
REQUEST_STATUS, SET_PARAM, UPLOAD_BEGIN, UPLOAD_CHUNK, UPLOAD_COMMIT = 0x20, 0x21, 0x22, 0x23, 0x24
SET_FIELD_HALF, ODOMETRY, SET_POSE = 0x25, 0x26, 0x27
CLOCK_SYNC, CAPTURE_START, CAPTURE_STOP, TEACH_BALL, READ_BLOB = 0x28, 0x29, 0x2A, 0x2B, 0x2C
TEACH_FLOOR, TEACH_OMNI_PIXEL, TEACH_PERSP_PIXEL = 0, 1, 2
CAPTURE_FULL, CAPTURE_HALF, CAPTURE_QUARTER, CAPTURE_SCANLINES = 0, 1, 2, 3
CAPTURE_OMNI, CAPTURE_PERSP = 1, 2
TARGET_CALIBRATION, TARGET_LUT, TARGET_CLASSIFIER = 1, 2, 3
# Parameters (firmware/main_loop.h ParamId; docs/protocol.md).
PARAM_FRAME_PERIOD_US, PARAM_STATUS_INTERVAL_US = 1, 2
PARAM_COLOR_ADAPTATION, PARAM_SAVE_COLOR_TABLE, PARAM_SAVE_CORRECTION = 20, 21, 22
MAX_CHUNK = 512
ERRORS = {1: "unknown command", 2: "bad length", 3: "bad target", 4: "no upload", 5: "bad offset",
          6: "too large", 7: "verify failed", 8: "storage failed", 9: "unknown parameter",
          10: "bad value", 11: "incomplete", 12: "busy (a capture, an open upload or a pending teach)",
          13: "unsupported by this board", 14: "no capture running",
          15: "no ball-coloured region where the ball was said to lie",
          16: "the taught colour would take the field",
          17: "no read-back snapshot (read again from offset 0)"}


def request_status(seq: int) -> bytes:
    return encode_frame(REQUEST_STATUS, seq, b"")


def set_param(seq: int, param_id: int, value: float) -> bytes:
    return encode_frame(SET_PARAM, seq, struct.pack("<Hf", param_id, value))


def save_correction(seq: int) -> bytes:
    """Stores the calibration in use with the camera correction the coprocessor estimated
    (a turned persp camera) folded in, under a new calibration id; error 10 while none stands,
    12 while an upload is open or a teach is pending. Read it back with read_blob."""
    return set_param(seq, PARAM_SAVE_CORRECTION, 1.0)


def set_field_half(seq: int, half: int) -> bytes:
    """Which half the robot is in (sign of its field x): -1, +1, or 0 to clear the hint."""
    if half not in (-1, 0, 1):
        raise ValueError("half must be -1, 0 or 1")
    return encode_frame(SET_FIELD_HALF, seq, struct.pack("<b", half))


def odometry(seq: int, dx: float, dy: float, dheading: float) -> bytes:
    """Robot motion since the previous frame (m, m, rad; robot frame of the previous pose)."""
    return encode_frame(ODOMETRY, seq, struct.pack("<3f", dx, dy, dheading))


def set_pose(seq: int, x: float, y: float, heading: float, known: bool = True) -> bytes:
    """The robot's field pose (m, m, rad: field angle of the robot's +y); known=False forgets it."""
    return encode_frame(SET_POSE, seq, struct.pack("<B3f", 1 if known else 0, x, y, heading))


def clock_sync(seq: int, rid: int, t1_us: int) -> bytes:
    """Clock sync request: `rid` identifies it, `t1_us` is this computer's clock (µs) now;
    answered by a ClockSyncReply (feed both to ClockSync)."""
    return encode_frame(CLOCK_SYNC, seq, struct.pack("<IQ", rid, t1_us))


def capture_start(seq: int, count: int, mode: int = CAPTURE_FULL,
                  cameras: int = CAPTURE_OMNI | CAPTURE_PERSP) -> bytes:
    """Stream the next `count` pairs (1..100; 1 = a snapshot) at full, half or quarter size, or
    (CAPTURE_SCANLINES) only the scan-table samples: per camera sample_count u32,
    positions_crc32 u32, then Y U V per sample in table order (docs/protocol.md, "Capture")."""
    if not 1 <= count <= 100:
        raise ValueError("capture: count must be 1..100")
    if mode not in (CAPTURE_FULL, CAPTURE_HALF, CAPTURE_QUARTER, CAPTURE_SCANLINES) or \
            cameras not in (1, 2, 3):
        raise ValueError("capture: mode 0..3, cameras 1..3")
    return encode_frame(CAPTURE_START, seq, struct.pack("<HBB", count, mode, cameras))


def teach_ball(seq: int, where: int, a: float, b: float) -> bytes:
    """The ball lies at floor point (a, b) m (where=TEACH_FLOOR, robot frame) or at pixel (a, b)
    of the omni / persp camera: the coprocessor learns its colour from the next frame pair and
    stores the new table as an upload would; ack or error follows that pair."""
    if where not in (TEACH_FLOOR, TEACH_OMNI_PIXEL, TEACH_PERSP_PIXEL):
        raise ValueError("teach: where must be 0 (floor), 1 (omni pixel) or 2 (persp pixel)")
    return encode_frame(TEACH_BALL, seq, struct.pack("<Bff", where, a, b))


def read_blob(seq: int, target: int, offset: int, length: int = MAX_CHUNK) -> bytes:
    """Read back `length` (1..512) bytes at `offset` of the blob `target` has in use (1
    calibration, 2 colour table, as adapted); offset 0 takes a new snapshot. Answered by a
    BlobData packet or an error (17: no snapshot, 12: busy, retry)."""
    if target not in (TARGET_CALIBRATION, TARGET_LUT, TARGET_CLASSIFIER) or \
            not 1 <= length <= MAX_CHUNK:
        raise ValueError("read_blob: target 1 or 2, length 1..512")
    return encode_frame(READ_BLOB, seq, struct.pack("<BIH", target, offset, length))


def capture_stop(seq: int) -> bytes:
    return encode_frame(CAPTURE_STOP, seq, b"")


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
