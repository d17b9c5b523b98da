// The shared conformance corpus (data/protocol_conformance.json, also run by
// tools/python/tests/test_conformance.py against the Python decoder): every case's accept and
// reject verdicts and counters, fed in several chunk sizes.
#include <gtest/gtest.h>

#include <fstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/protocol/protocol.h"

namespace bv::protocol {
namespace {

using nlohmann::json;

std::vector<uint8_t> FromHex(const std::string& hex) {
  std::vector<uint8_t> out;
  for (size_t i = 0; i + 1 < hex.size(); i += 2) {
    out.push_back(static_cast<uint8_t>(std::stoi(hex.substr(i, 2), nullptr, 16)));
  }
  return out;
}

json Corpus() {
  std::ifstream f(std::string(BV_TEST_DATA_DIR) + "/protocol_conformance.json");
  return json::parse(f);
}

struct Outcome {
  json messages = json::array();
  json counters;
};

Outcome Decode(const std::vector<uint8_t>& data) {
  Decoder d;
  FrameView f;
  Outcome o;
  uint32_t bad_payload = 0;
  for (uint8_t b : data) {
    if (!d.Push(b, f)) continue;
    BallState s;
    StatusReport st;
    const bool bad = (f.type == MsgType::kBallState && !ParseBallState(f.payload, s).ok()) ||
                     (f.type == MsgType::kStatus && !ParseStatus(f.payload, st).ok());
    if (bad) {
      ++bad_payload;
    } else {
      o.messages.push_back({static_cast<int>(f.type), f.seq});
    }
  }
  const DecoderStats& s = d.stats();
  o.counters = {{"frames_ok", s.frames_ok},  {"crc", s.crc_errors},
                {"cobs", s.cobs_errors},     {"oversize", s.oversize},
                {"short", s.short_frames},   {"version", s.version_errors},
                {"length", s.length_errors}, {"bytes_discarded", s.bytes_discarded},
                {"bad_payload", bad_payload}};
  return o;
}

TEST(ProtocolConformance, EveryCaseSameVerdictsAndCounters) {
  const json corpus = Corpus();
  ASSERT_GE(corpus["cases"].size(), 20u);
  for (const json& c : corpus["cases"]) {
    SCOPED_TRACE(c["name"].get<std::string>());
    const Outcome o = Decode(FromHex(c["hex"].get<std::string>()));
    EXPECT_EQ(o.messages, c["messages"]);
    EXPECT_EQ(o.counters, c["expect"]);
  }
}

// The documented maximum is enforced whatever the CRC says (issue 15: Python took 1500).
TEST(ProtocolConformance, PayloadOverTheMaximumIsRefused) {
  const json corpus = Corpus();  // named: a temporary's member would dangle in the loop
  for (const json& c : corpus["cases"]) {
    if (c["name"].get<std::string>().rfind("over_payload", 0) != 0) continue;
    EXPECT_EQ(Decode(FromHex(c["hex"].get<std::string>())).counters["frames_ok"], 0);
  }
}

}  // namespace
}  // namespace bv::protocol
