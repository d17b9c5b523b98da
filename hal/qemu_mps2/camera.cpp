#include "hal/qemu_mps2/camera.h"

#include <cstring>

#include "hal/qemu_mps2/semihosting.h"

namespace bv::qemu {

SemihostingCamera::SemihostingCamera(FrameSlots& slots, const char* dir,
                                     const hal::PairerConfig& pairer, uint32_t max_pairs)
    : slots_(slots), pairer_config_(pairer), pairer_(pairer), max_pairs_(max_pairs) {
  const size_t n = std::strlen(dir);
  if (n <= kMaxPath) std::memcpy(dir_, dir, n + 1);  // else dir_ stays empty: Start() fails
}

void SemihostingCamera::Report(const char* what, uint32_t line, const char* detail) {
  SemiWrite0("camera: ");
  SemiWrite0(dir_);
  SemiWrite0("/frames.csv: ");
  SemiWrite0(what);
  SemiWrite0(": ");
  SemiWrite0(detail);
  SemiWriteDec(" at line", line);
}

Status SemihostingCamera::DoStart() {
  finished_ = true;  // until the sequence is open: a replay without a source has ended
  if (dir_[0] == '\0') {
    return Status(StatusCode::kInvalidArgument, "camera: sequence directory missing or too long");
  }
  char path[kMaxPath + 16];
  const size_t n = std::strlen(dir_);
  std::memcpy(path, dir_, n);
  std::memcpy(path + n, "/frames.csv", sizeof("/frames.csv"));
  csv_fd_ = SemiOpenRead(path);
  if (csv_fd_ < 0) {
    SemiWrite0("camera: cannot open ");
    SemiWrite0(path);
    SemiWrite0("\n");
    return Status(StatusCode::kUnavailable, "camera: cannot open frames.csv");
  }
  reader_.Reset(csv_fd_);
  const LineReader::Result r = reader_.Next();
  if (r != LineReader::Result::kLine ||
      !hal::ParseFramesHeader({reader_.line(), reader_.length()}, columns_).ok()) {
    Report("bad header", reader_.line_number(), "expected index,t_us,omni_file,persp_file");
    return Status(StatusCode::kInvalidArgument, "camera: frames.csv has no valid header");
  }
  finished_ = false;
  return Status();
}

bool SemihostingCamera::LoadFrame(hal::CameraId id, std::string_view name, uint32_t line,
                                  uint32_t& slot, bool tear) {
  const int c = static_cast<int>(id);
  // dir/name, the file name also on its own for the reports.
  char path[kMaxPath + kMaxFileName + 2];
  const size_t dn = std::strlen(dir_);
  if (name.size() > kMaxFileName) {
    Report("frame file name too long", line, "row's frame skipped");
    return false;
  }
  std::memcpy(path, dir_, dn);
  path[dn] = '/';
  std::memcpy(path + dn + 1, name.data(), name.size());
  path[dn + 1 + name.size()] = '\0';
  const char* file = path + dn + 1;
  if (!name.ends_with(".yuyv")) {
    Report("frame file is not raw .yuyv (convert with `ballvision seq to-raw`)", line, file);
    return false;
  }
  // The DMA never writes the slot the main loop holds nor one with an unserved frame.
  const int pending = pairer_.pending_slot(id);
  int target = -1;
  for (int s = 0; s < kSlotsPerCamera; ++s) {
    if (((held_mask_[c] >> s) & 1u) == 0 && s != pending) {
      target = s;
      break;
    }
  }
  if (target < 0) {
    Report("no free DMA slot", line, file);
    return false;
  }
  const int fd = SemiOpenRead(path);
  if (fd < 0) {
    Report("cannot open frame file", line, file);
    return false;
  }
  const long len = SemiFileLength(fd);
  bool ok = false;
  uint32_t& seq = slot_seq_[c][target];
  if ((seq & 1u) == 0) ++seq;  // write started (stays odd if an earlier write never ended)
  // Injected tear: the frame-complete event fires while the DMA has written only the top half;
  // the bottom half still holds the slot's previous frame (half new, half old).
  const size_t bytes = tear ? kFrameBytes / 2 : kFrameBytes;
  if (len != static_cast<long>(kFrameBytes)) {
    Report("frame file is not 640x480x2 bytes", line, file);
  } else if (SemiRead(fd, slots_[c][target], bytes) != static_cast<int>(bytes)) {
    Report("short read of frame file", line, file);
  } else {
    ok = true;
  }
  if (!tear) ++seq;  // write complete
  SemiClose(fd);
  slot = static_cast<uint32_t>(target);
  return ok;
}

bool SemihostingCamera::NextRow(hal::FramesRow& row, uint32_t& line) {
  if (finished_ || csv_fd_ < 0) return false;
  for (;;) {
    const LineReader::Result r = reader_.Next();
    line = reader_.line_number();
    if (r == LineReader::Result::kEof || r == LineReader::Result::kIoError) {
      if (r == LineReader::Result::kIoError) Report("read error", line, "end of replay");
      finished_ = true;
      SemiClose(csv_fd_);
      csv_fd_ = -1;
      return false;
    }
    if (r == LineReader::Result::kTooLong) {
      Report("line too long", line, "row skipped");
    } else if (reader_.length() == 0) {
      continue;  // blank line
    } else {
      const Status st = hal::ParseFramesRow({reader_.line(), reader_.length()}, columns_, row);
      if (st.ok()) return true;
      Report("malformed row", line, st.message());
    }
    ++bad_rows_;
  }
}

void SemihostingCamera::CaptureRow(const hal::FramesRow& row, uint32_t line, bool tear_omni) {
  const std::string_view files[hal::kCameraCount] = {row.omni_file, row.persp_file};
  for (int c = 0; c < hal::kCameraCount; ++c) {
    if (files[c].empty()) continue;
    uint32_t slot = 0;
    const auto id = static_cast<hal::CameraId>(c);
    if (LoadFrame(id, files[c], line, slot, tear_omni && c == 0)) {
      pairer_.OnFrameComplete(id, row.t_us, static_cast<uint32_t>(row.index), slot);
    } else {
      ++bad_frames_;
    }
  }
}

Status SemihostingCamera::DoAcquirePair(hal::FramePair& out) {
  if (finished_ || csv_fd_ < 0) {
    return Status(StatusCode::kUnavailable, "camera: no frame");
  }
  if (max_pairs_ != 0 && pairs_served_ >= max_pairs_) {
    finished_ = true;
    return Status(StatusCode::kUnavailable, "camera: frame limit reached");
  }
  hal::FramesRow row;  // its file names are views into the reader's line
  uint32_t line = 0;
  if (!NextRow(row, line)) return Status(StatusCode::kUnavailable, "camera: end of sequence");
  CaptureRow(row, line, pairs_served_ == faults_.torn_at);
  if (pairs_served_ == faults_.drop_at) {
    // Injected overrun: the next row's frames also complete before the loop polls, so the
    // pairer replaces (and counts as dropped) the unserved frames of this row.
    hal::FramesRow next;
    if (NextRow(next, line)) {
      CaptureRow(next, line, false);
      row = next;
    }
  }
  // A replay has no partner arriving later: decide at once.
  hal::PairDecision d;
  if (!pairer_.TakePair(row.t_us + pairer_config_.missing_timeout_us, d)) {
    return Status(StatusCode::kUnavailable, "camera: row without a usable frame");
  }
  out = hal::FramePair{};
  hal::Frame* frames[hal::kCameraCount] = {&out.omni, &out.persp};
  for (int c = 0; c < hal::kCameraCount; ++c) {
    if (!d.has[c]) continue;
    hal::Frame& f = *frames[c];
    f.data = slots_[c][d.slot[c]];
    f.size_bytes = kFrameBytes;
    f.exposure_us = d.exposure_us[c];
    f.sequence = d.sequence[c];
    f.present = true;
    held_mask_[c] |= 1u << d.slot[c];
    // Tear detection: a slot whose write sequence is odd is still being written by the DMA.
    // On hardware the same check reads the DMA's per-slot transfer state (remaining count /
    // frame counter) at handout; here only the injected tear leaves a write unfinished.
    if ((slot_seq_[c][d.slot[c]] & 1u) != 0) out.flags |= hal::kPairTorn;
  }
  out.exposure_us = d.exposure_us_pair;
  out.skew_us = d.skew_us;
  out.flags |= d.flags;
  out.dropped = d.dropped;
  out.slot = (d.slot[0] & 0xFFu) | ((d.slot[1] & 0xFFu) << 8);
  if ((out.flags & hal::kPairTorn) != 0) ++pairs_torn_;
  frames_dropped_ += d.dropped;
  if (clock_ != nullptr) handout_us_ = clock_->NowUs();
  ++pairs_served_;
  return Status();
}

void SemihostingCamera::DoRelease(const hal::FramePair& pair) {
  if (pair.omni.present) held_mask_[0] &= ~(1u << (pair.slot & 0xFFu));
  if (pair.persp.present) held_mask_[1] &= ~(1u << ((pair.slot >> 8) & 0xFFu));
  if (pairs_served_ == faults_.hang_at + 1) {
    SemiWrite0("camera: inject hang: the loop never returns from this release\n");
    for (;;) asm volatile("" ::: "memory");
  }
  if (clock_ != nullptr) {
    const uint64_t held_us = clock_->NowUs() - handout_us_;
    if (held_us > max_hold_us_) max_hold_us_ = held_us;
  }
}

}  // namespace bv::qemu
