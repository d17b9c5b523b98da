#include "core/protocol/protocol.h"

#include <cmath>
#include <cstring>

#include "core/common/bytes.h"
#include "core/common/crc32.h"

namespace bv::protocol {
namespace {

// Any change to a payload layout must change this text (and so the schema hash).
constexpr char kSchema[] =
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
    "blob_data:cmd_seq u32,target u8,total_len blob_crc32 offset u32,data";

bool Finite(float v) { return std::isfinite(v); }

// Metres to int16 millimetres; false if NaN or beyond +-32.767 m.
bool ToMm(float m, int16_t& mm) {
  const float v = m * 1000.0f;
  if (!(v >= -32767.0f && v <= 32767.0f)) return false;
  mm = static_cast<int16_t>(std::lround(v));
  return true;
}

}  // namespace

uint16_t SchemaHash() {
  static const uint16_t hash = static_cast<uint16_t>(
      Crc32({reinterpret_cast<const uint8_t*>(kSchema), sizeof(kSchema) - 1}) & 0xFFFFu);
  return hash;
}

Result<size_t> CobsEncode(std::span<const uint8_t> in, std::span<uint8_t> out) {
  size_t o = 0;
  size_t code_pos = 0;
  uint8_t code = 1;
  if (out.empty()) return Status(StatusCode::kResourceExhausted, "cobs: output too small");
  o = 1;  // room for the first code byte
  for (uint8_t b : in) {
    if (b == 0) {
      out[code_pos] = code;
      code_pos = o++;
      code = 1;
      if (o > out.size()) return Status(StatusCode::kResourceExhausted, "cobs: output too small");
      continue;
    }
    if (o >= out.size()) return Status(StatusCode::kResourceExhausted, "cobs: output too small");
    out[o++] = b;
    if (++code == 0xFF) {
      out[code_pos] = code;
      code_pos = o++;
      code = 1;
      if (o > out.size()) return Status(StatusCode::kResourceExhausted, "cobs: output too small");
    }
  }
  out[code_pos] = code;
  return o;
}

Result<size_t> CobsDecode(std::span<const uint8_t> in, std::span<uint8_t> out) {
  size_t i = 0, o = 0;
  while (i < in.size()) {
    const uint8_t code = in[i++];
    if (code == 0) return Status(StatusCode::kDataLoss, "cobs: zero byte inside a frame");
    const size_t run = code - 1u;
    if (run > in.size() - i) return Status(StatusCode::kDataLoss, "cobs: code past end of frame");
    if (run > out.size() - o)
      return Status(StatusCode::kResourceExhausted, "cobs: output too small");
    for (size_t k = 0; k < run; ++k) {
      if (in[i] == 0) return Status(StatusCode::kDataLoss, "cobs: zero byte inside a frame");
      out[o++] = in[i++];
    }
    if (code != 0xFF && i < in.size()) {
      if (o >= out.size()) return Status(StatusCode::kResourceExhausted, "cobs: output too small");
      out[o++] = 0;
    }
  }
  return o;
}

Result<size_t> EncodeFrame(MsgType type, uint32_t seq, std::span<const uint8_t> payload,
                           std::span<uint8_t> out) {
  if (payload.size() > kMaxPayloadBytes) {
    return Status(StatusCode::kInvalidArgument, "protocol: payload larger than 1024 bytes");
  }
  uint8_t raw[kMaxRawFrameBytes];
  ByteWriter w(raw);
  w.U8(kVersion);
  w.U8(static_cast<uint8_t>(type));
  w.U16(SchemaHash());
  w.U32(seq);
  w.U16(static_cast<uint16_t>(payload.size()));
  w.Bytes(payload);
  w.U32(Crc32(w.written()));
  auto n = CobsEncode(w.written(), out);
  if (!n.ok()) return n.status();
  if (*n >= out.size()) return Status(StatusCode::kResourceExhausted, "protocol: no room for 0x00");
  out[*n] = 0;
  return *n + 1;
}

uint16_t BallSigmaMm(float sigma_m) {
  if (!(sigma_m >= 0.f)) return sigma_m < 0.f ? 0 : 65535;
  // Rounded up, but a value that already is whole mm (a decoded one) stays: 0.036f * 1000 is
  // 36.000002 in float.
  const float mm = std::ceil(sigma_m * 1000.f - 1e-3f);
  return mm >= 65535.f ? 65535 : static_cast<uint16_t>(mm);
}

uint16_t ChangeCentiDegrees(float deg) {
  const float c = deg * 100.0f + 0.5f;
  return c >= 65535.0f ? uint16_t{65535} : c >= 0.0f ? static_cast<uint16_t>(c) : uint16_t{0};
}

Result<size_t> EncodeBallState(const BallState& s, uint32_t seq, std::span<uint8_t> out) {
  uint8_t p[kBallStatePayloadBytes];
  ByteWriter w(p);
  w.U64(s.t_us);
  w.U16(s.flags);
  w.U8(static_cast<uint8_t>(s.mode));
  w.U8(s.found ? 1 : 0);
  w.F32(s.x_m), w.F32(s.y_m), w.F32(s.z_m);
  w.F32(s.vx_mps), w.F32(s.vy_mps), w.F32(s.vz_mps);
  w.F32(s.ray_gap_m);
  w.F32(s.omni.u_px), w.F32(s.omni.v_px);
  w.F32(s.persp.u_px), w.F32(s.persp.v_px);
  w.U64(s.t_bounce_us);
  w.F32(s.bounce_x_m), w.F32(s.bounce_y_m);
  w.U32(s.predict_ahead_us);
  w.F32(s.px_m), w.F32(s.py_m), w.F32(s.pz_m);
  w.U32(s.proc_us);
  for (const float sigma : {s.sigma_x_m, s.sigma_y_m, s.sigma_z_m}) w.U16(BallSigmaMm(sigma));
  for (const float sigma : {s.psigma_x_m, s.psigma_y_m, s.psigma_z_m}) w.U16(BallSigmaMm(sigma));
  w.U8(s.omni_check.Byte());
  w.U8(s.persp_check.Byte());
  w.U16(ChangeCentiDegrees(s.omni_check.change_deg));
  w.U16(ChangeCentiDegrees(s.persp_check.change_deg));
  static_assert(sizeof(p) == kBallStatePayloadBytes);
  if (w.size() != kBallStatePayloadBytes) return Status(StatusCode::kInternal, "ball payload size");
  return EncodeFrame(MsgType::kBallState, seq, w.written(), out);
}

Status ParseBallState(std::span<const uint8_t> payload, BallState& out) {
  if (payload.size() != kBallStatePayloadBytes) {
    return Status(StatusCode::kInvalidArgument, "ball state: wrong payload length");
  }
  ByteReader r(payload);
  BallState s;
  s.t_us = r.U64();
  s.flags = r.U16();
  const uint8_t mode = r.U8();
  const uint8_t found = r.U8();
  s.x_m = r.F32(), s.y_m = r.F32(), s.z_m = r.F32();
  s.vx_mps = r.F32(), s.vy_mps = r.F32(), s.vz_mps = r.F32();
  s.ray_gap_m = r.F32();
  s.omni.u_px = r.F32(), s.omni.v_px = r.F32();
  s.persp.u_px = r.F32(), s.persp.v_px = r.F32();
  s.t_bounce_us = r.U64();
  s.bounce_x_m = r.F32(), s.bounce_y_m = r.F32();
  s.predict_ahead_us = r.U32();
  s.px_m = r.F32(), s.py_m = r.F32(), s.pz_m = r.F32();
  s.proc_us = r.U32();
  s.sigma_x_m = r.U16() * 1e-3f, s.sigma_y_m = r.U16() * 1e-3f, s.sigma_z_m = r.U16() * 1e-3f;
  s.psigma_x_m = r.U16() * 1e-3f, s.psigma_y_m = r.U16() * 1e-3f, s.psigma_z_m = r.U16() * 1e-3f;
  for (CameraCheck* c : {&s.omni_check, &s.persp_check}) {
    const uint8_t b = r.U8();
    c->state = static_cast<CameraState>(b & 3u);
    c->faults = static_cast<uint8_t>(b >> 2);  // six bits: every value is a valid set
  }
  s.omni_check.change_deg = r.U16() * 0.01f;
  s.persp_check.change_deg = r.U16() * 0.01f;
  if (mode > static_cast<uint8_t>(BallMode::kBouncing)) {
    return Status(StatusCode::kInvalidArgument, "ball state: unknown mode");
  }
  if (found > 1) return Status(StatusCode::kInvalidArgument, "ball state: found not 0/1");
  s.mode = static_cast<BallMode>(mode);
  s.found = found == 1;
  s.omni.found = (s.flags & kFlagSeenOmni) != 0;
  s.persp.found = (s.flags & kFlagSeenPersp) != 0;
  if (s.found && !(Finite(s.x_m) && Finite(s.y_m) && Finite(s.z_m) && Finite(s.vx_mps) &&
                   Finite(s.vy_mps) && Finite(s.vz_mps))) {
    return Status(StatusCode::kInvalidArgument, "ball state: non-finite position or velocity");
  }
  out = s;
  return Status();
}

Result<size_t> EncodeStatus(const StatusReport& s, uint32_t seq, std::span<uint8_t> out) {
  uint8_t p[kStatusPayloadBytes];
  ByteWriter w(p);
  w.U64(s.uptime_us);
  for (uint32_t v :
       {s.frames_processed, s.frame_rate_mhz, s.frames_dropped, s.deadline_overruns,
        s.packets_dropped, s.pairs_omni_missing, s.pairs_persp_missing, s.pairs_out_of_sync,
        s.pairs_out_of_order, s.pairs_torn, s.calibration_id, s.lut_id}) {
    w.U32(v);
  }
  w.U8(s.calibration_state);
  w.U8(s.lut_state);
  w.U8(s.check_omni);
  w.U8(s.check_persp);
  for (uint32_t v :
       {s.rx_errors, s.command_errors, s.pipeline_errors, s.last_proc_us, s.max_proc_us,
        s.fault_flags, s.rx_overruns, s.rx_ring_full, s.rx_line_errors, s.feature_packets_dropped,
        s.line_points_unsent, s.pairs_omni_unusable, s.pairs_persp_unusable}) {
    w.U32(v);
  }
  w.U16(s.change_omni_cdeg);
  w.U16(s.change_persp_cdeg);
  w.U8(s.confidence_omni_pct);
  w.U8(s.confidence_persp_pct);
  if (w.size() != kStatusPayloadBytes) return Status(StatusCode::kInternal, "status payload size");
  return EncodeFrame(MsgType::kStatus, seq, w.written(), out);
}

Status ParseStatus(std::span<const uint8_t> payload, StatusReport& out) {
  if (payload.size() != kStatusPayloadBytes) {
    return Status(StatusCode::kInvalidArgument, "status: wrong payload length");
  }
  ByteReader r(payload);
  StatusReport s;
  s.uptime_us = r.U64();
  uint32_t* fields[] = {&s.frames_processed,    &s.frame_rate_mhz,    &s.frames_dropped,
                        &s.deadline_overruns,   &s.packets_dropped,   &s.pairs_omni_missing,
                        &s.pairs_persp_missing, &s.pairs_out_of_sync, &s.pairs_out_of_order,
                        &s.pairs_torn,          &s.calibration_id,    &s.lut_id};
  for (uint32_t* f : fields) *f = r.U32();
  s.calibration_state = r.U8();
  s.lut_state = r.U8();
  s.check_omni = r.U8();
  s.check_persp = r.U8();
  uint32_t* tail[] = {&s.rx_errors,           &s.command_errors,
                      &s.pipeline_errors,     &s.last_proc_us,
                      &s.max_proc_us,         &s.fault_flags,
                      &s.rx_overruns,         &s.rx_ring_full,
                      &s.rx_line_errors,      &s.feature_packets_dropped,
                      &s.line_points_unsent,  &s.pairs_omni_unusable,
                      &s.pairs_persp_unusable};
  for (uint32_t* f : tail) *f = r.U32();
  s.change_omni_cdeg = r.U16();
  s.change_persp_cdeg = r.U16();
  s.confidence_omni_pct = r.U8();
  s.confidence_persp_pct = r.U8();
  if (s.confidence_omni_pct > 100 || s.confidence_persp_pct > 100) {
    return Status(StatusCode::kInvalidArgument, "status: confidence above 100 %");
  }
  if (s.calibration_state > 2 || s.lut_state > 4) {
    return Status(StatusCode::kInvalidArgument, "status: unknown blob state");
  }
  out = s;
  return Status();
}

Result<size_t> EncodePose(const PoseEstimate& e, uint64_t t_us, uint32_t seq,
                          std::span<uint8_t> out) {
  uint8_t p[kPosePayloadBytes];
  ByteWriter w(p);
  w.U64(t_us);
  w.U8(static_cast<uint8_t>(e.state));
  w.U8(static_cast<uint8_t>((e.ambiguous ? kPoseAmbiguous : 0) |
                            (e.hint_rejected ? kPoseHintRejected : 0) |
                            (e.usable() ? kPoseUsable : 0)));
  w.U16(e.points_used);
  w.U16(e.inliers);
  for (float v :
       {e.x_m, e.y_m, e.heading_rad, e.sigma_x_m, e.sigma_y_m, e.sigma_heading_rad, e.quality}) {
    w.F32(v);
  }
  if (w.size() != kPosePayloadBytes) return Status(StatusCode::kInternal, "pose payload size");
  return EncodeFrame(MsgType::kPose, seq, w.written(), out);
}

Status ParsePose(std::span<const uint8_t> payload, PoseReport& out) {
  if (payload.size() != kPosePayloadBytes) {
    return Status(StatusCode::kInvalidArgument, "pose: wrong payload length");
  }
  ByteReader r(payload);
  PoseReport s;
  s.t_us = r.U64();
  s.state = r.U8();
  const uint8_t flags = r.U8();
  s.points_used = r.U16();
  s.inliers = r.U16();
  float* f[] = {&s.x_m,    &s.y_m, &s.heading_rad, &s.sigma_x_m, &s.sigma_y_m, &s.sigma_heading_rad,
                &s.quality};
  for (float* v : f) *v = r.F32();
  if (s.state > PoseEstimate::kCoasting) return Status(StatusCode::kInvalidArgument, "pose: state");
  if (flags & ~(kPoseAmbiguous | kPoseHintRejected | kPoseUsable)) {
    return Status(StatusCode::kInvalidArgument, "pose: unknown flag bits");
  }
  s.ambiguous = flags & kPoseAmbiguous;
  s.hint_rejected = flags & kPoseHintRejected;
  s.usable = flags & kPoseUsable;
  if (s.inliers > s.points_used) return Status(StatusCode::kInvalidArgument, "pose: inliers");
  if (s.usable && !(Finite(s.x_m) && Finite(s.y_m) && Finite(s.heading_rad) &&
                    Finite(s.sigma_x_m) && Finite(s.sigma_y_m) && Finite(s.sigma_heading_rad))) {
    return Status(StatusCode::kInvalidArgument, "pose: usable pose not finite");
  }
  if (!(s.quality >= 0.0f && s.quality <= 1.0f)) {
    return Status(StatusCode::kInvalidArgument, "pose: quality not in 0..1");
  }
  out = s;
  return Status();
}

Result<size_t> EncodeLinePoints(const FieldFeatures& f, uint64_t t_us, uint32_t seq,
                                std::span<uint8_t> out, size_t& sent, size_t max_points) {
  sent = 0;
  if (max_points > kMaxLinePointsPerPacket) max_points = kMaxLinePointsPerPacket;
  const size_t n = f.line_count > 0 ? static_cast<size_t>(f.line_count) : 0;
  const size_t found = n + f.lines_dropped;
  const size_t take = n < max_points ? n : max_points;
  uint8_t p[kLinePointsHeaderBytes + kMaxLinePointsPerPacket * kLinePointBytes];
  ByteWriter w(p);
  w.U64(t_us);
  w.U16(static_cast<uint16_t>(found > 0xFFFF ? 0xFFFF : found));
  w.U8(0);  // count, patched below
  w.U8(0);
  for (size_t i = 0; i < take; ++i) {
    const LinePoint& lp = f.lines[i * n / take];  // evenly spread: every ray sector keeps some
    int16_t x = 0, y = 0;
    if (!ToMm(lp.x_m, x) || !ToMm(lp.y_m, y)) continue;
    w.I16(x);
    w.I16(y);
    ++sent;
  }
  p[10] = static_cast<uint8_t>(sent);
  return EncodeFrame(MsgType::kLinePoints, seq, w.written(), out);
}

Status ParseLinePoints(std::span<const uint8_t> payload, LinePointsReport& out) {
  if (payload.size() < kLinePointsHeaderBytes) {
    return Status(StatusCode::kInvalidArgument, "line points: payload too short");
  }
  ByteReader r(payload);
  const uint64_t t_us = r.U64();
  const uint16_t found = r.U16();
  const uint8_t count = r.U8();
  const uint8_t reserved = r.U8();
  if (count > kMaxLinePointsPerPacket || count > found || reserved != 0) {
    return Status(StatusCode::kInvalidArgument, "line points: count beyond capacity or found");
  }
  if (payload.size() != kLinePointsHeaderBytes + count * kLinePointBytes) {
    return Status(StatusCode::kInvalidArgument, "line points: length disagrees with count");
  }
  out.t_us = t_us;
  out.found = found;
  out.count = count;
  for (size_t i = 0; i < count; ++i) {
    out.points[i].x_mm = r.I16();
    out.points[i].y_mm = r.I16();
  }
  return Status();
}

Result<size_t> EncodeObstacles(const FieldFeatures& f, uint64_t t_us, uint32_t seq,
                               std::span<uint8_t> out) {
  const size_t n = f.obstacle_count > 0 ? static_cast<size_t>(f.obstacle_count) : 0;
  const size_t found = n + f.obstacles_dropped;
  uint8_t p[kObstaclesHeaderBytes + kMaxObstaclesPerPacket * kObstacleBytes];
  ByteWriter w(p);
  w.U64(t_us);
  w.U8(static_cast<uint8_t>(found > 0xFF ? 0xFF : found));
  w.U8(0);  // count, patched below
  uint8_t sent = 0;
  for (size_t i = 0; i < n && i < kMaxObstaclesPerPacket; ++i) {
    const Obstacle& o = f.obstacles[i];
    int16_t x = 0, y = 0, r = 0;
    if (!ToMm(o.x_m, x) || !ToMm(o.y_m, y) || !ToMm(o.radius_m, r) || r < 0) continue;
    w.I16(x);
    w.I16(y);
    w.U16(static_cast<uint16_t>(r));
    ++sent;
  }
  p[9] = sent;
  return EncodeFrame(MsgType::kObstacles, seq, w.written(), out);
}

Status ParseObstacles(std::span<const uint8_t> payload, ObstaclesReport& out) {
  if (payload.size() < kObstaclesHeaderBytes) {
    return Status(StatusCode::kInvalidArgument, "obstacles: payload too short");
  }
  ByteReader r(payload);
  const uint64_t t_us = r.U64();
  const uint8_t found = r.U8();
  const uint8_t count = r.U8();
  if (count > kMaxObstaclesPerPacket || count > found) {
    return Status(StatusCode::kInvalidArgument, "obstacles: count beyond capacity or found");
  }
  if (payload.size() != kObstaclesHeaderBytes + count * kObstacleBytes) {
    return Status(StatusCode::kInvalidArgument, "obstacles: length disagrees with count");
  }
  out.t_us = t_us;
  out.found = found;
  out.count = count;
  for (size_t i = 0; i < count; ++i) {
    out.obstacles[i].x_mm = r.I16();
    out.obstacles[i].y_mm = r.I16();
    out.obstacles[i].radius_mm = r.U16();
  }
  return Status();
}

Result<size_t> EncodeGoals(const FieldFeatures& f, uint64_t t_us, uint32_t seq,
                           std::span<uint8_t> out) {
  const size_t n = f.goal_count > 0 ? static_cast<size_t>(f.goal_count) : 0;
  const size_t found = n + f.goals_dropped;
  uint8_t p[kGoalsHeaderBytes + kMaxGoalsPerPacket * kGoalBytes];
  ByteWriter w(p);
  w.U64(t_us);
  w.U8(static_cast<uint8_t>(found > 0xFF ? 0xFF : found));
  w.U8(0);  // count, patched below
  uint8_t sent = 0;
  for (size_t i = 0; i < n && i < kMaxGoalsPerPacket; ++i) {
    const Goal& g = f.goals[i];
    int16_t x = 0, y = 0;
    const float b = g.bearing_rad * 1000.0f, hw = g.half_width_rad * 1000.0f;
    if (!ToMm(g.x_m, x) || !ToMm(g.y_m, y) || !(std::fabs(b) <= 3142.0f) ||
        !(hw >= 0.0f && hw <= 3142.0f) || g.post_rays > g.rays || g.which < -1 || g.which > 1) {
      continue;
    }
    w.I16(x);
    w.I16(y);
    w.I16(static_cast<int16_t>(std::lround(b)));
    w.U16(static_cast<uint16_t>(std::lround(hw)));
    w.U8(g.rays);
    w.U8(g.post_rays);
    w.U8(static_cast<uint8_t>(g.which));
    w.U8(g.which_ambiguous ? kGoalWhichAmbiguous : 0);
    ++sent;
  }
  p[9] = sent;
  return EncodeFrame(MsgType::kGoals, seq, w.written(), out);
}

Status ParseGoals(std::span<const uint8_t> payload, GoalsReport& out) {
  if (payload.size() < kGoalsHeaderBytes) {
    return Status(StatusCode::kInvalidArgument, "goals: payload too short");
  }
  ByteReader r(payload);
  const uint64_t t_us = r.U64();
  const uint8_t found = r.U8();
  const uint8_t count = r.U8();
  if (count > kMaxGoalsPerPacket || count > found) {
    return Status(StatusCode::kInvalidArgument, "goals: count beyond capacity or found");
  }
  if (payload.size() != kGoalsHeaderBytes + count * kGoalBytes) {
    return Status(StatusCode::kInvalidArgument, "goals: length disagrees with count");
  }
  GoalMm g[kMaxGoalsPerPacket];
  for (size_t i = 0; i < count; ++i) {
    g[i].x_mm = r.I16();
    g[i].y_mm = r.I16();
    g[i].bearing_mrad = r.I16();
    g[i].half_width_mrad = r.U16();
    g[i].rays = r.U8();
    g[i].post_rays = r.U8();
    g[i].which = static_cast<int8_t>(r.U8());
    const uint8_t flags = r.U8();
    if (g[i].bearing_mrad < -3142 || g[i].bearing_mrad > 3142 || g[i].half_width_mrad > 3142 ||
        g[i].post_rays > g[i].rays || g[i].which < -1 || g[i].which > 1 ||
        (flags & ~kGoalWhichAmbiguous) != 0) {
      return Status(StatusCode::kInvalidArgument,
                    "goals: bearing beyond pi, post_rays > rays, which not -1/0/1 or unknown flag");
    }
    g[i].which_ambiguous = (flags & kGoalWhichAmbiguous) != 0;
  }
  out.t_us = t_us;
  out.found = found;
  out.count = count;
  for (size_t i = 0; i < count; ++i) out.goals[i] = g[i];
  return Status();
}

bool Decoder::Push(uint8_t byte, FrameView& out) {
  if (byte != 0) {
    if (len_ < sizeof(buf_)) {
      buf_[len_++] = byte;
    } else {
      if (!overflow_) ++stats_.oversize;
      overflow_ = true;
      ++stats_.bytes_discarded;
    }
    return false;
  }
  const bool ok = !overflow_ && len_ > 0 && Finish(out);
  if (!ok && !overflow_) stats_.bytes_discarded += static_cast<uint32_t>(len_);
  len_ = 0;
  overflow_ = false;
  return ok;
}

bool Decoder::Finish(FrameView& out) {
  auto n = CobsDecode({buf_, len_}, raw_);
  if (!n.ok()) {
    ++stats_.cobs_errors;
    return false;
  }
  if (*n < kHeaderBytes + kCrcBytes) {
    ++stats_.short_frames;
    return false;
  }
  const size_t body = *n - kCrcBytes;
  ByteReader crc_reader({raw_ + body, kCrcBytes});
  if (Crc32({raw_, body}) != crc_reader.U32()) {
    ++stats_.crc_errors;
    return false;
  }
  ByteReader r({raw_, body});
  const uint8_t version = r.U8();
  const uint8_t type = r.U8();
  const uint16_t schema = r.U16();
  const uint32_t seq = r.U32();
  const uint16_t len = r.U16();
  if (version != kVersion || schema != SchemaHash()) {
    ++stats_.version_errors;
    return false;
  }
  if (len != body - kHeaderBytes) {
    ++stats_.length_errors;
    return false;
  }
  out.type = static_cast<MsgType>(type);
  out.seq = seq;
  out.payload = {raw_ + kHeaderBytes, len};
  ++stats_.frames_ok;
  return true;
}

}  // namespace bv::protocol
