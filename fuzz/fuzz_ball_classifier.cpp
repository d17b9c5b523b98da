// The ball classifier blob loader (device side).
#include <cmath>
#include <cstddef>
#include <cstdint>

#include <vector>

#include "core/ball_check/ball_check.h"
#include "core/common/blob.h"
#include "fuzz/blob_input.h"

// Input: fuzz/blob_input.h.
extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  std::vector<uint8_t> wrapped;
  const std::span<const uint8_t> blob = bv::fuzz::BlobFromInput(
      data, size, bv::BlobKind::kBallClassifier, bv::kBallClassifierBlobVersion, wrapped);
  bv::BallClassifier c;
  if (!c.Parse(bv::BuiltInBallClassifierBlob()).ok()) __builtin_trap();
  const uint32_t before = c.id();
  if (!c.Parse(blob).ok()) {
    if (c.id() != before) __builtin_trap();  // a refused blob must leave the weights untouched
    return 0;
  }
  // Accepted weights must give a finite logit on any finite features.
  bv::BallFeatures f;
  for (int i = 0; i < bv::kBallFeatureCount; ++i) f.f[i] = (i % 3) - 1.0f;
  if (!std::isfinite(c.Logit(f))) __builtin_trap();
  return 0;
}
