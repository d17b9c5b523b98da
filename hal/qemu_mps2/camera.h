#pragma once
// Replays a captured sequence (frames.csv + raw 640x480 .yuyv files) through semihosting: each
// frame is read into one of two DMA slots per camera in PSRAM, as the capture DMA would write
// it, and the shared FramePairer forms the pairs. One pair per frames.csv row, in file order.
#include <cstdint>

#include "core/common/image.h"
#include "hal/camera.h"
#include "hal/clock.h"
#include "hal/common/frame_pairer.h"
#include "hal/common/frames_csv.h"
#include "hal/qemu_mps2/line_reader.h"

namespace bv::qemu {

inline constexpr int kSlotsPerCamera = 2;
using FrameSlots = uint8_t[hal::kCameraCount][kSlotsPerCamera][kFrameBytes];

/// Camera faults a file cannot express (board argument inject=, see
/// firmware/boards/qemu_mps2/board.cpp). Indices count pairs handed out, from 0; kNever: off.
struct CameraFaults {
  static constexpr uint32_t kNever = UINT32_MAX;
  uint32_t torn_at = kNever;  // pair N's omni slot is handed out while its DMA write is half done
  uint32_t drop_at = kNever;  // the frames of pair N and N+1 complete before the loop polls
  uint32_t hang_at = kNever;  // releasing pair N never returns: a hung loop (watchdog test)
};

class SemihostingCamera : public hal::Camera {
 public:
  static constexpr size_t kMaxPath = 240;      // the sequence directory
  static constexpr size_t kMaxFileName = 120;  // a frame file named in frames.csv

  /// `slots` are the DMA frame buffers; `dir` is the sequence directory (copied).
  SemihostingCamera(FrameSlots& slots, const char* dir, const hal::PairerConfig& pairer,
                    uint32_t max_pairs);
  /// Rows rejected (malformed, overlong) and frame files that could not be loaded (missing,
  /// wrong size, not raw .yuyv); each is reported once on the debug channel.
  uint32_t bad_rows() const { return bad_rows_; }
  uint32_t bad_frames() const { return bad_frames_; }
  /// Test aid: the replay reports Finished() only once *counter >= target (e.g. received UART
  /// bytes), so commands fed through QEMU's chardev are all served before the final status.
  void HoldOpenUntil(const uint32_t* counter, uint32_t target) {
    hold_counter_ = counter;
    hold_target_ = target;
  }
  void InjectFaults(const CameraFaults& faults) { faults_ = faults; }
  /// Optional: measures the time each pair is held (AcquirePair -> Release).
  void SetClock(const hal::Clock* clock) { clock_ = clock; }
  /// Pairs handed out so far (the fault schedule of other peripherals keys on it).
  const uint32_t* pairs_served_counter() const { return &pairs_served_; }
  uint32_t pairs_torn() const { return pairs_torn_; }
  uint32_t frames_dropped() const { return frames_dropped_; }
  uint64_t max_hold_us() const { return max_hold_us_; }

 private:
  Status DoStart() override;
  Status DoAcquirePair(hal::FramePair& out) override;
  void DoRelease(const hal::FramePair& pair) override;
  // One pair held by a capture, the other slot for the loop's next pair.
  int DoMaxHeldPairs() const override { return kSlotsPerCamera; }
  uint32_t DoBadInputCount() const override { return bad_rows_ + bad_frames_; }
  bool DoFinished() const override {
    return finished_ && (hold_counter_ == nullptr || *hold_counter_ >= hold_target_);
  }

  bool LoadFrame(hal::CameraId id, std::string_view file, uint32_t line, uint32_t& slot, bool tear);
  /// Next parseable frames.csv row; false at the end of the sequence (then finished_).
  bool NextRow(hal::FramesRow& row, uint32_t& line);
  /// "DMA" of the row's frames into free slots, reported to the pairer.
  void CaptureRow(const hal::FramesRow& row, uint32_t line, bool tear_omni);
  void Report(const char* what, uint32_t line, const char* detail);

  FrameSlots& slots_;
  char dir_[kMaxPath + 1] = {};
  hal::PairerConfig pairer_config_;
  hal::FramePairer pairer_;
  int csv_fd_ = -1;
  LineReader reader_;
  hal::FramesColumns columns_;
  uint32_t held_mask_[hal::kCameraCount] = {};  // slots handed out and not yet released
  uint32_t max_pairs_ = 0;                      // 0: all rows
  uint32_t pairs_served_ = 0;
  uint32_t bad_rows_ = 0;
  uint32_t bad_frames_ = 0;
  bool finished_ = false;
  const uint32_t* hold_counter_ = nullptr;
  uint32_t hold_target_ = 0;
  CameraFaults faults_;
  // Per-slot DMA write sequence, odd while a write is in progress (a seqlock): a slot handed out
  // with an odd number is torn. See DoAcquirePair.
  uint32_t slot_seq_[hal::kCameraCount][kSlotsPerCamera] = {};
  uint32_t pairs_torn_ = 0;
  uint32_t frames_dropped_ = 0;
  const hal::Clock* clock_ = nullptr;
  uint64_t handout_us_ = 0;
  uint64_t max_hold_us_ = 0;
};

}  // namespace bv::qemu
