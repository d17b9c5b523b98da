// frames.csv of a captured sequence.
#include <cstddef>
#include <cstdint>
#include <string>

#include "hal/host/sequence.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  bv::host::Sequence seq;
  std::string error;
  const std::string text(reinterpret_cast<const char*>(data), size);
  if (!bv::host::ParseSequenceIndex(text, "/seq", /*check_files=*/false, seq, error)) {
    if (error.empty()) __builtin_trap();  // every refusal names its reason
  }
  return 0;
}
