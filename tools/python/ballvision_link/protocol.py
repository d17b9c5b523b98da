"""Pure-Python decoder for the ballvision serial protocol (mirrors core/protocol)."""
import math
import struct
import zlib
from dataclasses import dataclass
from typing import List, Optional, Tuple

VERSION = 4
MSG_BALL_STATE = 0x01
MSG_STATUS = 0x02
MSG_POSE = 0x03
MSG_LINE_POINTS = 0x04
MSG_OBSTACLES = 0x05
MSG_GOALS = 0x06
MSG_CLOCK_SYNC_REPLY = 0x0A
MSG_CAPTURE_FRAME, MSG_CAPTURE_CHUNK, MSG_CAPTURE_END = 0x0B, 0x0C, 0x0D
MSG_BLOB_DATA = 0x0E
BLOB_DATA_BYTES = 512
HEADER = struct.Struct("<BBHIH")
WIRE_OVERHEAD_BYTES = HEADER.size + 4  # header + CRC-32
MAX_PAYLOAD = 1024
# Receive limits of core/protocol's Decoder (kMaxRawFrameBytes, kMaxWireFrameBytes): a frame
# beyond them is refused the same way by both decoders
# (host_tests/data/protocol_conformance.json).
MAX_RAW_FRAME = HEADER.size + MAX_PAYLOAD + 4
MAX_WIRE_FRAME = MAX_RAW_FRAME + MAX_RAW_FRAME // 254 + 2

# Must equal the text in core/protocol/protocol.cpp: the hash guards against layout drift.
_SCHEMA = (
    "ball:t_us u64,flags u16,mode u8,found u8,x y z f32,vx vy vz f32,ray_gap f32,"
    "omni_u omni_v f32,persp_u persp_v f32,t_bounce_us u64,bounce_x bounce_y f32,"
    "predict_ahead_us u32,px py pz f32,proc_us u32,sigma_x sigma_y sigma_z u16,"
    "psigma_x psigma_y psigma_z u16,omni_check persp_check u8,"
    "omni_change_cdeg persp_change_cdeg u16;"
    "status:uptime_us u64,frames_processed frame_rate_mhz frames_dropped deadline_overruns "
    "packets_dropped pairs_omni_missing pairs_persp_missing pairs_out_of_sync pairs_out_of_order "
    "pairs_torn calibration_id lut_id u32,calibration_state lut_state u8,check_omni check_persp u8,"
    "rx_errors command_errors pipeline_errors last_proc_us max_proc_us fault_flags u32,"
    "rx_overruns rx_ring_full rx_line_errors u32,feature_packets_dropped line_points_unsent u32,"
    "pairs_omni_unusable pairs_persp_unusable u32,change_omni_cdeg change_persp_cdeg u16,"
    "confidence_omni_pct confidence_persp_pct u8;"
    "pose:t_us u64,state u8,flags u8,points_used inliers u16,x y heading f32,"
    "sigma_x sigma_y sigma_heading f32,quality f32;"
    "lines:t_us u64,found u16,count u8,reserved u8,count*(x_mm y_mm i16);"
    "obstacles:t_us u64,found count u8,count*(x_mm y_mm i16,radius_mm u16);"
    "goals:t_us u64,found count u8,count*(x_mm y_mm bearing_mrad i16,half_width_mrad u16,"
    "rays post_rays u8,which i8,flags u8);"
    "sync:id u32,t1_host_us t2_rx_us t3_tx_us u64;"
    "capture_frame:capture_id pair_index count u16,mode cameras u8,width height u16,"
    "exposure_us omni_exposure_us persp_exposure_us u64,omni_sequence persp_sequence u32,"
    "image_bytes u32;"
    "capture_chunk:capture_id pair_index u16,camera reserved u8,offset u32,data;"
    "capture_end:capture_id requested pairs_sent u16,reason u8;"
    "read_blob:target u8,offset u32,length u16;"
    "blob_data:cmd_seq u32,target u8,total_len blob_crc32 offset u32,data")
SCHEMA_HASH = zlib.crc32(_SCHEMA.encode()) & 0xFFFF

MODES = ("none", "rolling", "flying", "bouncing")
FLAG_SEEN_OMNI, FLAG_SEEN_PERSP, FLAG_HAS_BOUNCE, FLAG_HAS_PREDICTION = 1, 2, 1 << 11, 1 << 12
FLAG_UNOBSERVABLE, FLAG_PREDICTION_UNCERTAIN = 1 << 13, 1 << 14
# A camera check byte (core/common/ball_state.h CameraCheck): state, then why frames were refused.
CAMERA_STATES = ("as calibrated", "changed, corrected", "changed, not corrected", "unusable")
CAMERA_FAULTS = ("repeated", "stale time", "dark", "saturated", "flat", "missing")


def camera_check_text(byte: int) -> str:
    """As the C++ CameraCheckText: "unusable (repeated, dark)"."""
    why = [n for b, n in enumerate(CAMERA_FAULTS) if byte >> 2 & 1 << b]
    return CAMERA_STATES[byte & 3] + (f" ({', '.join(why)})" if why else "")

_BALL = struct.Struct("<QHBB3f3ff2f2fQ2fI3fI3H3HBBHH")
_STATUS = struct.Struct("<Q12IBBBB13IHHBB")
_POSE = struct.Struct("<QBBHH7f")
_LINES_HEAD = struct.Struct("<QHBB")
_OBSTACLES_HEAD = struct.Struct("<QBB")
assert _BALL.size == 110 and _STATUS.size == 118 and _POSE.size == 42
_SYNC_REPLY = struct.Struct("<IQQQ")
_CAPTURE_FRAME = struct.Struct("<HHHBBHHQQQIII")
_CAPTURE_CHUNK_HEAD = struct.Struct("<HHBBI")
_BLOB_DATA_HEAD = struct.Struct("<IBIII")
_CAPTURE_END = struct.Struct("<HHHB")
assert _LINES_HEAD.size == 12 and _OBSTACLES_HEAD.size == 10
assert _SYNC_REPLY.size == 28 and _CAPTURE_FRAME.size == 48 and _CAPTURE_CHUNK_HEAD.size == 10
assert _CAPTURE_END.size == 7
# full, half, quarter, scanlines (the samples lie in a 640x480 image; image_bytes is both
# cameras' streams: 8 header bytes and 3 per sample each)
CAPTURE_MODES = {0: (640, 480), 1: (320, 240), 2: (160, 120), 3: (640, 480)}
CAPTURE_SCANLINES = 3
SCAN_STREAM_HEADER_BYTES, SCAN_SAMPLE_BYTES, SCAN_MAX_SAMPLES = 8, 3, 65535
CAPTURE_MAX_PAIRS, CAPTURE_CHUNK_BYTES, FRAME_BYTES = 100, 512, 640 * 480 * 2
CAPTURE_END_REASONS = ("complete", "stopped", "camera finished")
MAX_LINE_POINTS, MAX_OBSTACLES, MAX_GOALS = 64, 16, 2
_GOAL = struct.Struct("<hhhHBBbB")
assert _GOAL.size == 12
POSE_STATES = ("unknown", "searching", "tracking", "coasting")
POSE_AMBIGUOUS, POSE_HINT_REJECTED, POSE_USABLE = 1, 2, 4


@dataclass
class BallState:
    seq: int
    t_us: int
    flags: int
    mode: str
    found: bool
    x: float
    y: float
    z: float
    vx: float
    vy: float
    vz: float
    ray_gap: float
    omni_u: Optional[float]
    omni_v: Optional[float]
    persp_u: Optional[float]
    persp_v: Optional[float]
    t_bounce_us: Optional[int]
    bounce_x: float
    bounce_y: float
    predict_ahead_us: int
    px: float
    py: float
    pz: float
    proc_us: int
    sigma_x: float  # position 1-sigma per axis, m (mm resolution; 65.535 = unknown)
    sigma_y: float
    sigma_z: float
    psigma_x: float  # 1-sigma of px, py, pz, m (as sigma_x)
    psigma_y: float
    psigma_z: float
    omni_check: int  # camera check byte: state in bits 0-1, faults in bits 2-7 (CAMERA_*)
    persp_check: int
    omni_change_deg: float  # estimated pose change since calibration (0.01 deg resolution)
    persp_change_deg: float


@dataclass
class StatusReport:
    seq: int
    uptime_us: int
    frames_processed: int
    frame_rate_hz: float
    frames_dropped: int
    deadline_overruns: int
    packets_dropped: int
    pairs_omni_missing: int
    pairs_persp_missing: int
    pairs_out_of_sync: int
    pairs_out_of_order: int
    pairs_torn: int
    calibration_id: int
    lut_id: int
    calibration_state: int
    lut_state: int
    check_omni: int  # camera check bytes of the last pair, as BallState.omni_check
    check_persp: int
    rx_errors: int
    command_errors: int
    pipeline_errors: int
    last_proc_us: int
    max_proc_us: int
    fault_flags: int
    rx_overruns: int
    rx_ring_full: int
    rx_line_errors: int
    feature_packets_dropped: int
    line_points_unsent: int
    pairs_omni_unusable: int
    pairs_persp_unusable: int
    change_omni_deg: float  # estimated pose change since calibration (0.01 deg resolution)
    change_persp_deg: float
    confidence_omni: float  # 0..1
    confidence_persp: float


@dataclass
class Pose:
    """Self-localisation: field frame (origin centre spot, m); heading of the robot's +y."""
    seq: int
    t_us: int
    state: str
    ambiguous: bool
    hint_rejected: bool
    usable: bool
    points_used: int
    inliers: int
    x: float
    y: float
    heading: float
    sigma_x: float
    sigma_y: float
    sigma_heading: float
    quality: float


@dataclass
class LinePoints:
    """Floor points on field lines, robot frame, metres (sent as int16 mm)."""
    seq: int
    t_us: int
    found: int  # found by the coprocessor this frame; len(points) of them were sent
    points: List[Tuple[float, float]]


@dataclass
class Obstacles:
    """Obstacle footprints: (x, y, radius) in metres, robot frame."""
    seq: int
    t_us: int
    found: int
    obstacles: List[Tuple[float, float, float]]


@dataclass
class ClockSyncReply:
    """Answer to a clock sync request: t1 echoed (host clock), t2 / t3 coprocessor clock."""
    seq: int
    id: int
    t1_host_us: int
    t2_rx_us: int
    t3_tx_us: int


@dataclass
class CaptureFrame:
    """Announces one captured pair; its images follow as CaptureChunk packets."""
    seq: int
    capture_id: int
    pair_index: int
    count: int
    mode: int
    cameras: int  # bit 0 omni, bit 1 persp
    width: int
    height: int
    exposure_us: int
    omni_exposure_us: int
    persp_exposure_us: int
    omni_sequence: int
    persp_sequence: int
    image_bytes: int


@dataclass
class CaptureChunk:
    seq: int
    capture_id: int
    pair_index: int
    camera: int  # 0 omni, 1 persp
    offset: int
    data: bytes


@dataclass
class BlobData:
    """Bytes [offset, offset + len(data)) of the device's snapshot of a blob in use (target 1
    calibration, 2 colour table), answering read command `cmd_seq`; blob_crc32 names the
    snapshot (zlib.crc32 of the whole blob)."""
    seq: int
    cmd_seq: int
    target: int
    total_len: int
    blob_crc32: int
    offset: int
    data: bytes


@dataclass
class CaptureEnd:
    seq: int
    capture_id: int
    requested: int
    pairs_sent: int
    reason: str


@dataclass
class Goals:
    """Goal mouths seen: (x, y, bearing, half_width, rays, post_rays, which, which_ambiguous);
    x, y m (centre of the seen mouth, robot frame), bearing +- half_width rad (robot frame, CCW
    from +x), which +1 / -1 (the goal at field +X / -X, from the pose) or 0 (unknown)."""
    seq: int
    t_us: int
    found: int
    goals: List[Tuple[float, float, float, float, int, int, int, bool]]


def cobs_encode(data: bytes) -> bytes:
    out = bytearray([0])
    code_pos, code = 0, 1
    for b in data:
        if b == 0:
            out[code_pos] = code
            code_pos, code = len(out), 1
            out.append(0)
            continue
        out.append(b)
        code += 1
        if code == 0xFF:
            out[code_pos] = code
            code_pos, code = len(out), 1
            out.append(0)
    out[code_pos] = code
    return bytes(out)


def cobs_decode(data: bytes) -> Optional[bytes]:
    out = bytearray()
    i = 0
    while i < len(data):
        code = data[i]
        i += 1
        if code == 0 or i + code - 1 > len(data):
            return None
        run = data[i:i + code - 1]
        if 0 in run:
            return None
        out += run
        i += code - 1
        if code != 0xFF and i < len(data):
            out.append(0)
    return bytes(out)


def parse_ball_state(seq: int, payload: bytes) -> Optional[BallState]:
    if len(payload) != _BALL.size:
        return None
    v = _BALL.unpack(payload)
    (t_us, flags, mode, found, x, y, z, vx, vy, vz, gap, ou, ov, pu, pv, tb, bx, by, ahead,
     px, py, pz, proc, sx, sy, sz, psx, psy, psz, check_o, check_p, change_o, change_p) = v
    if mode >= len(MODES) or found > 1:
        return None
    if found and not all(math.isfinite(a) for a in (x, y, z, vx, vy, vz)):
        return None
    seen_o, seen_p = flags & FLAG_SEEN_OMNI, flags & FLAG_SEEN_PERSP
    return BallState(seq, t_us, flags, MODES[mode], bool(found), x, y, z, vx, vy, vz, gap,
                     ou if seen_o else None, ov if seen_o else None,
                     pu if seen_p else None, pv if seen_p else None,
                     tb if flags & FLAG_HAS_BOUNCE else None, bx, by, ahead, px, py, pz, proc,
                     sx / 1000.0, sy / 1000.0, sz / 1000.0, psx / 1000.0, psy / 1000.0,
                     psz / 1000.0, check_o, check_p, change_o / 100.0, change_p / 100.0)


def parse_status(seq: int, payload: bytes) -> Optional[StatusReport]:
    if len(payload) != _STATUS.size:
        return None
    v = list(_STATUS.unpack(payload))
    v[2] = v[2] / 1000.0  # millihertz -> Hz
    if v[13] > 2 or v[14] > 4 or v[-2] > 100 or v[-1] > 100:
        return None
    v[-4:] = [v[-4] / 100.0, v[-3] / 100.0, v[-2] / 100.0, v[-1] / 100.0]
    return StatusReport(seq, *v)


def parse_pose(seq: int, payload: bytes) -> Optional[Pose]:
    if len(payload) != _POSE.size:
        return None
    t_us, state, flags, used, inliers, *f = _POSE.unpack(payload)
    if state >= len(POSE_STATES) or flags & ~7 or inliers > used:
        return None
    usable = bool(flags & POSE_USABLE)
    if usable and not all(math.isfinite(v) for v in f[:6]):
        return None
    if not 0.0 <= f[6] <= 1.0:
        return None
    return Pose(seq, t_us, POSE_STATES[state], bool(flags & POSE_AMBIGUOUS),
                bool(flags & POSE_HINT_REJECTED), usable, used, inliers, *f)


def parse_line_points(seq: int, payload: bytes) -> Optional[LinePoints]:
    if len(payload) < _LINES_HEAD.size:
        return None
    t_us, found, count, reserved = _LINES_HEAD.unpack_from(payload)
    if count > MAX_LINE_POINTS or count > found or reserved or \
            len(payload) != _LINES_HEAD.size + 4 * count:
        return None
    xy = struct.unpack_from(f"<{2 * count}h", payload, _LINES_HEAD.size)
    return LinePoints(seq, t_us, found,
                      [(xy[2 * i] / 1000.0, xy[2 * i + 1] / 1000.0) for i in range(count)])


def parse_obstacles(seq: int, payload: bytes) -> Optional[Obstacles]:
    if len(payload) < _OBSTACLES_HEAD.size:
        return None
    t_us, found, count = _OBSTACLES_HEAD.unpack_from(payload)
    if count > MAX_OBSTACLES or count > found or len(payload) != _OBSTACLES_HEAD.size + 6 * count:
        return None
    v = struct.unpack_from("<" + "hhH" * count, payload, _OBSTACLES_HEAD.size)
    return Obstacles(seq, t_us, found, [(v[3 * i] / 1000.0, v[3 * i + 1] / 1000.0,
                                         v[3 * i + 2] / 1000.0) for i in range(count)])


def parse_clock_sync_reply(seq: int, payload: bytes) -> Optional[ClockSyncReply]:
    if len(payload) != _SYNC_REPLY.size:
        return None
    rid, t1, t2, t3 = _SYNC_REPLY.unpack(payload)
    if t3 < t2:
        return None
    return ClockSyncReply(seq, rid, t1, t2, t3)


def parse_capture_frame(seq: int, payload: bytes) -> Optional[CaptureFrame]:
    if len(payload) != _CAPTURE_FRAME.size:
        return None
    f = CaptureFrame(seq, *_CAPTURE_FRAME.unpack(payload))
    size = CAPTURE_MODES.get(f.mode)
    if size is None or f.cameras not in (1, 2, 3) or (f.width, f.height) != size:
        return None
    if f.mode == CAPTURE_SCANLINES:
        streams = bin(f.cameras).count("1")
        one, most = SCAN_STREAM_HEADER_BYTES + SCAN_SAMPLE_BYTES, \
            SCAN_STREAM_HEADER_BYTES + SCAN_SAMPLE_BYTES * SCAN_MAX_SAMPLES
        if not streams * one <= f.image_bytes <= streams * most:
            return None
    elif f.image_bytes != f.width * f.height * 2:
        return None
    if not 0 < f.count <= CAPTURE_MAX_PAIRS or f.pair_index >= f.count:
        return None
    return f


def parse_capture_chunk(seq: int, payload: bytes) -> Optional[CaptureChunk]:
    n = len(payload) - _CAPTURE_CHUNK_HEAD.size
    if not 0 < n <= CAPTURE_CHUNK_BYTES:
        return None
    cid, pair, camera, reserved, offset = _CAPTURE_CHUNK_HEAD.unpack_from(payload)
    if camera > 1 or reserved or offset + n > FRAME_BYTES:
        return None
    return CaptureChunk(seq, cid, pair, camera, offset, bytes(payload[_CAPTURE_CHUNK_HEAD.size:]))


def parse_blob_data(seq: int, payload: bytes) -> Optional[BlobData]:
    n = len(payload) - _BLOB_DATA_HEAD.size
    if not 0 < n <= BLOB_DATA_BYTES:
        return None
    cmd_seq, target, total, crc, offset = _BLOB_DATA_HEAD.unpack_from(payload)
    if target not in (1, 2, 3) or offset + n > total:
        return None
    return BlobData(seq, cmd_seq, target, total, crc, offset, bytes(payload[_BLOB_DATA_HEAD.size:]))


def parse_capture_end(seq: int, payload: bytes) -> Optional[CaptureEnd]:
    if len(payload) != _CAPTURE_END.size:
        return None
    cid, requested, sent, reason = _CAPTURE_END.unpack(payload)
    if reason >= len(CAPTURE_END_REASONS) or sent > requested:
        return None
    return CaptureEnd(seq, cid, requested, sent, CAPTURE_END_REASONS[reason])


def parse_goals(seq: int, payload: bytes) -> Optional[Goals]:
    if len(payload) < _OBSTACLES_HEAD.size:  # the same 10-byte head
        return None
    t_us, found, count = _OBSTACLES_HEAD.unpack_from(payload)
    if count > MAX_GOALS or count > found or len(payload) != _OBSTACLES_HEAD.size + _GOAL.size * count:
        return None
    goals = []
    for i in range(count):
        x, y, b, hw, rays, posts, which, flags = _GOAL.unpack_from(
            payload, _OBSTACLES_HEAD.size + _GOAL.size * i)
        if abs(b) > 3142 or hw > 3142 or posts > rays or which not in (-1, 0, 1) or flags & ~1:
            return None
        goals.append((x / 1000.0, y / 1000.0, b / 1000.0, hw / 1000.0, rays, posts, which,
                      bool(flags & 1)))
    return Goals(seq, t_us, found, goals)


_PARSERS = {MSG_BALL_STATE: parse_ball_state,
            MSG_STATUS: parse_status,
            MSG_POSE: parse_pose,
            MSG_LINE_POINTS: parse_line_points,
            MSG_OBSTACLES: parse_obstacles,
            MSG_CLOCK_SYNC_REPLY: parse_clock_sync_reply,
            MSG_CAPTURE_FRAME: parse_capture_frame,
            MSG_CAPTURE_CHUNK: parse_capture_chunk,
            MSG_CAPTURE_END: parse_capture_end,
            MSG_BLOB_DATA: parse_blob_data,
            MSG_GOALS: parse_goals}


class Decoder:
    """Streaming decoder: feed() bytes, get verified messages; corrupt frames are counted."""

    def __init__(self, max_frame: int = MAX_WIRE_FRAME):
        self._buf = bytearray()
        self._overflow = False
        self.max_frame = max_frame
        self.errors = {"crc": 0, "cobs": 0, "oversize": 0, "short": 0, "version": 0,
                       "length": 0, "payload": 0}
        self.frames_ok = 0
        self.bytes_discarded = 0

    def feed(self, data: bytes) -> List[object]:
        """All messages completed by `data`, in order. A list, not a generator: the decoder's
        state advances whether or not the caller looks at the result, so nothing is lost."""
        out = []
        for b in data:
            if b != 0:
                if len(self._buf) < self.max_frame:
                    self._buf.append(b)
                else:
                    if not self._overflow:
                        self.errors["oversize"] += 1
                    self._overflow = True
                    self.bytes_discarded += 1
                continue
            frame, overflow = bytes(self._buf), self._overflow
            self._buf.clear()
            self._overflow = False
            if overflow or not frame:
                continue
            before = self.frames_ok
            msg = self._finish(frame)
            if self.frames_ok == before:
                self.bytes_discarded += len(frame)
            if msg is not None:
                out.append(msg)
        return out

    def _finish(self, frame: bytes):
        raw = cobs_decode(frame)
        if raw is not None and len(raw) > MAX_RAW_FRAME:
            raw = None  # the C++ decoder's buffer is full: counted as a COBS error there too
        if raw is None:
            self.errors["cobs"] += 1
            return None
        if len(raw) < HEADER.size + 4:
            self.errors["short"] += 1
            return None
        body, crc = raw[:-4], struct.unpack("<I", raw[-4:])[0]
        if zlib.crc32(body) != crc:
            self.errors["crc"] += 1
            return None
        version, mtype, schema, seq, length = HEADER.unpack(body[:HEADER.size])
        if version != VERSION or schema != SCHEMA_HASH:
            self.errors["version"] += 1
            return None
        payload = body[HEADER.size:]
        if length != len(payload):
            self.errors["length"] += 1
            return None
        self.frames_ok += 1
        parser = _PARSERS.get(mtype)
        if parser is None:
            return (mtype, seq, payload)
        msg = parser(seq, payload)
        if msg is None:
            self.errors["payload"] += 1
        return msg


def encode_frame(mtype: int, seq: int, payload: bytes) -> bytes:
    if len(payload) > MAX_PAYLOAD:
        raise ValueError("payload larger than 1024 bytes")
    body = HEADER.pack(VERSION, mtype, SCHEMA_HASH, seq, len(payload)) + payload
    return cobs_encode(body + struct.pack("<I", zlib.crc32(body))) + b"\x00"
