#pragma once
// Replays a captured sequence (frames.csv + raw 640x480 .yuyv files) through semihosting: each
// frame is read into one of two DMA slots per camera in PSRAM, as the capture DMA would write
// it, and the shared FramePairer forms the pairs. One pair per frames.csv row, in file order.
#include <cstdint>

#include "core/common/image.h"
#include "hal/camera.h"
#include "hal/common/frame_pairer.h"
#include "hal/qemu_mps2/frames_csv.h"

namespace bv::qemu {

inline constexpr int kSlotsPerCamera = 2;
using FrameSlots = uint8_t[hal::kCameraCount][kSlotsPerCamera][kFrameBytes];

class SemihostingCamera : public hal::Camera {
 public:
  static constexpr size_t kMaxPath = 240;

  /// `slots` are the DMA frame buffers; `dir` is the sequence directory (copied).
  SemihostingCamera(FrameSlots& slots, const char* dir, const hal::PairerConfig& pairer,
                    uint32_t max_pairs);
  /// Rows rejected (malformed, overlong) and frame files that could not be loaded (missing,
  /// wrong size, not raw .yuyv); each is reported once on the debug channel.
  uint32_t bad_rows() const { return bad_rows_; }
  uint32_t bad_frames() const { return bad_frames_; }
  const uint32_t* bad_input_counter() const { return &bad_input_; }
  /// Test aid: the replay reports Finished() only once *counter >= target (e.g. received UART
  /// bytes), so commands fed through QEMU's chardev are all served before the final status.
  void HoldOpenUntil(const uint32_t* counter, uint32_t target) {
    hold_counter_ = counter;
    hold_target_ = target;
  }

 private:
  Status DoStart() override;
  Status DoAcquirePair(hal::FramePair& out) override;
  void DoRelease(const hal::FramePair& pair) override;
  bool DoFinished() const override {
    return finished_ && (hold_counter_ == nullptr || *hold_counter_ >= hold_target_);
  }

  bool LoadFrame(hal::CameraId id, const char* file, const FramesRow& row, uint32_t line,
                 uint32_t& slot);
  void Report(const char* what, uint32_t line, const char* detail);

  FrameSlots& slots_;
  char dir_[kMaxPath + 1] = {};
  hal::PairerConfig pairer_config_;
  hal::FramePairer pairer_;
  int csv_fd_ = -1;
  LineReader reader_;
  int held_[hal::kCameraCount] = {-1, -1};
  uint32_t max_pairs_ = 0;  // 0: all rows
  uint32_t pairs_served_ = 0;
  uint32_t bad_rows_ = 0;
  uint32_t bad_frames_ = 0;
  uint32_t bad_input_ = 0;
  bool finished_ = false;
  const uint32_t* hold_counter_ = nullptr;
  uint32_t hold_target_ = 0;
};

}  // namespace bv::qemu
