#pragma once
// The main computer's side of the read-back (docs/protocol.md, "Read-back"): asks for a blob in
// use chunk by chunk, one request outstanding, and accepts it only whole, from one snapshot,
// with its CRC and content checked. A busy device is asked again; a lost snapshot (an upload or
// a teach reused its buffer) or one replaced mid-way starts the read again from offset 0.
#include <cstdint>
#include <string>
#include <vector>

#include "core/protocol/commands.h"
#include "core/protocol/link.h"
#include "core/protocol/protocol.h"

namespace bv::cli {

class BlobReader {
 public:
  static constexpr int kMaxRestarts = 3;

  explicit BlobReader(protocol::UploadTarget target) : target_(target) {}

  /// The request to send now (at most one is outstanding): false while one waits, or when done.
  bool NextRequest(protocol::ReadBlobRequest& out, uint32_t& cmd_seq);
  /// The answer was not heard (a timeout): the outstanding request may be sent again.
  void Resend() { waiting_ = false; }
  /// A decoded frame from the link; other traffic (ball states, status) is ignored.
  void OnFrame(const protocol::FrameView& frame);

  bool done() const { return done_; }
  bool failed() const { return !error_.empty(); }
  const std::string& error() const { return error_; }
  /// The whole blob, once done().
  const std::vector<uint8_t>& blob() const { return blob_; }
  uint32_t total_len() const { return total_; }
  /// The snapshot's CRC-32 the device announced (the blob's own, once done()).
  uint32_t blob_crc32() const { return crc_; }
  int busy_answers() const { return busy_; }
  int restarts() const { return restarts_; }

 private:
  void Restart(const char* why);
  void Finish();

  protocol::UploadTarget target_;
  std::vector<uint8_t> blob_;
  uint32_t total_ = 0, crc_ = 0, seq_ = 1, outstanding_seq_ = 0;
  bool waiting_ = false, done_ = false;
  int busy_ = 0, restarts_ = 0;
  std::string error_;
};

}  // namespace bv::cli
