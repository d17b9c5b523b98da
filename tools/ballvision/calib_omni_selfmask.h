#pragma once
// The omni self-mask from the calibration run: the robot turns on the carpet, so every pixel of
// the world changes colour again and again (the carpet strip alone sweeps each ground direction
// twice a turn), while the robot's own body, mirror holder, struts and rim stay as they are.
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "core/calibration/calibration.h"
#include "tools/ballvision/calib_omni_steps.h"

namespace bv::cli::omni {

struct SelfMaskResult {
  OmniSelfMask mask;
  cv::Mat1b self;                 // 255 where the image shows the robot itself
  double unchanged_fraction = 0;  // of the mirror ring (0.3-0.95 of the rim radius)
};

/// Learns the mask from the run's frames and the rim circle (step 1). Fails, naming why, when
/// fewer than 8 frames are given, when most of the mirror ring never changed (the robot did not
/// turn), or when the mask would be refused (more than 8 sectors, more than 120 deg masked).
bool LearnSelfMask(const std::vector<Frame>& frames, const RimFit& rim, SelfMaskResult& out,
                   std::string& error);

}  // namespace bv::cli::omni
