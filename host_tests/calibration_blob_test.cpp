// Calibration blob (core) and the JSON file + `ballvision calib` conversions (tools).
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "host_tests/test_util.h"

#include "core/calibration/calibration.h"
#include "core/common/blob.h"
#include "core/common/crc32.h"
#include "tools/ballvision/calib_io.h"
#include "tools/ballvision/commands.h"

namespace bv {
namespace {

namespace fs = std::filesystem;

RigCalibration Example() {
  RigCalibration c;
  c.calibration_id = 0x12345678u;
  c.lut_id = 0xCAFEF00Du;
  c.persp.valid = true;
  c.persp.fx = 377.6f;
  c.persp.fy = 377.7f;
  c.persp.cx = 318.2f;
  c.persp.cy = 242.6f;
  c.persp.k1 = -0.28f;
  c.persp.k2 = 0.09f;
  c.persp.rms_px = 0.1f;
  c.persp.t_robot_cam = Eigen::Vector3f(0, 0.15f, 0.45f);
  c.persp.R_robot_cam << 1, 0, 0, 0, 0, 1, 0, -1, 0;
  c.omni.valid = true;
  c.omni.center_u = 314.1f;
  c.omni.center_v = 245.1f;
  c.omni.viewpoint_z_m = 0.776f;
  c.omni.image_angle_sign = 1;
  c.omni.image_angle_offset_rad = -3.1f;
  for (int k = 0; k < OmniCalibration::kEdges; ++k) c.omni.edge_ground_m[k] = 0.8f + 0.5f * k;
  for (int s = 0; s < OmniCalibration::kDirections; ++s) {
    for (int k = 0; k < OmniCalibration::kEdges; ++k) {
      c.omni.support_px[s][k] = 80.0f + 9.0f * k + 0.1f * s;
    }
  }
  c.omni.sector_flags[1] = kOmniSectorInterpolated;
  return c;
}

std::vector<uint8_t> Serialize(const RigCalibration& c) {
  std::vector<uint8_t> b(kCalibrationBlobMaxBytes);
  const Result<size_t> n = SerializeCalibration(c, b);
  EXPECT_TRUE(n.ok()) << n.status().message();
  b.resize(n.ok() ? *n : 0);
  return b;
}

// The self-mask section (version 4) of a calibration without one: tag, flag, two radii, no
// sectors, the 64-entry outline.
constexpr size_t kSelfSectionBytes = 4 + 1 + 4 + 4 + 1 + 64;

bool Equal(const RigCalibration& a, const RigCalibration& b) {
  std::vector<uint8_t> x = Serialize(a), y = Serialize(b);
  return x == y;
}

TEST(CalibrationBlob, RoundTrip) {
  const RigCalibration c = Example();
  const std::vector<uint8_t> b = Serialize(c);
  ASSERT_LE(b.size(), kCalibrationBlobMaxBytes);
  RigCalibration back;
  ASSERT_TRUE(ParseCalibration(b, back).ok());
  EXPECT_EQ(back.calibration_id, c.calibration_id);
  EXPECT_EQ(back.lut_id, c.lut_id);
  EXPECT_EQ(back.persp.fx, c.persp.fx);
  EXPECT_EQ(back.persp.R_robot_cam, c.persp.R_robot_cam);
  EXPECT_EQ(back.omni.support_px[44][11], c.omni.support_px[44][11]);
  EXPECT_EQ(back.omni.sector_flags[1], kOmniSectorInterpolated);
  EXPECT_EQ(back.omni.image_angle_sign, 1);
  EXPECT_TRUE(Equal(back, c));
  // A standard BVB1 blob of kind calibration.
  EXPECT_TRUE(ReadBlob(b, BlobKind::kCalibration, kCalibrationBlobVersion).ok());
}

TEST(CalibrationBlob, EveryCorruptionIsRejectedAndOutUntouched) {
  const std::vector<uint8_t> good = Serialize(Example());
  RigCalibration sentinel;
  sentinel.calibration_id = 77;
  for (size_t i = 0; i < good.size(); ++i) {
    std::vector<uint8_t> bad = good;
    bad[i] ^= 0x10;
    RigCalibration out = sentinel;
    EXPECT_FALSE(ParseCalibration(bad, out).ok()) << "byte " << i;
    EXPECT_TRUE(Equal(out, sentinel)) << "byte " << i;
  }
  for (size_t n = 0; n < good.size(); n += 13) {  // truncations
    RigCalibration out = sentinel;
    EXPECT_FALSE(ParseCalibration(std::span<const uint8_t>(good.data(), n), out).ok());
    EXPECT_TRUE(Equal(out, sentinel));
  }
}

// Re-wraps a modified payload with a correct CRC: the field checks themselves must catch it.
Status ParseWithPayloadEdit(size_t payload_offset, float value) {
  std::vector<uint8_t> b = Serialize(Example());
  std::memcpy(b.data() + kBlobHeaderBytes + payload_offset, &value, 4);
  const uint32_t crc =
      Crc32(std::span<const uint8_t>(b.data() + kBlobHeaderBytes, b.size() - kBlobHeaderBytes));
  std::memcpy(b.data() + 12, &crc, 4);
  RigCalibration out;
  return ParseCalibration(b, out);
}

TEST(CalibrationBlob, FieldsAreValidated) {
  // payload: id u32, lut u32, ball f32, persp tag u32, valid u8, w u16, h u16, fx f32 ...
  constexpr size_t kFx = 4 + 4 + 4 + 4 + 1 + 2 + 2;
  EXPECT_TRUE(ParseWithPayloadEdit(kFx, 400.0f).ok());
  const Status nan = ParseWithPayloadEdit(kFx, NAN);
  EXPECT_EQ(nan.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(std::strstr(nan.message(), "fx"), nullptr) << nan.message();
  EXPECT_EQ(ParseWithPayloadEdit(kFx, -5.0f).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(ParseWithPayloadEdit(8, 5.0f).code(), StatusCode::kInvalidArgument);  // ball radius
  // A rotation that is not one.
  constexpr size_t kR00 = kFx + 8 * 4;
  EXPECT_EQ(ParseWithPayloadEdit(kR00, 0.5f).code(), StatusCode::kInvalidArgument);
  // Serialisation refuses what parsing would refuse.
  RigCalibration c = Example();
  c.omni.support_px[3][4] = c.omni.support_px[3][3] - 1;  // not increasing
  std::vector<uint8_t> b(kCalibrationBlobMaxBytes);
  EXPECT_EQ(SerializeCalibration(c, b).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(SerializeCalibration(Example(), std::span<uint8_t>(b.data(), 100)).status().code(),
            StatusCode::kResourceExhausted);
}

// The field section (blob version 2): a venue other than the MSL one survives the round trip.
TEST(CalibrationBlob, FieldRoundTrip) {
  RigCalibration c = Example();
  c.field.length_m = 12.0f;
  c.field.width_m = 8.0f;
  c.field.center_circle_radius_m = 1.5f;
  c.field.penalty_area_width_m = 5.0f;
  c.field.goal_width_m = 1.6f;
  c.field.goal_depth_m = 0.45f;
  c.field.border_m = 1.0f;
  c.field.margin_m = 0.2f;
  RigCalibration back;
  ASSERT_TRUE(ParseCalibration(Serialize(c), back).ok());
  EXPECT_EQ(back.field.length_m, 12.0f);
  EXPECT_EQ(back.field.width_m, 8.0f);
  EXPECT_EQ(back.field.center_circle_radius_m, 1.5f);
  EXPECT_EQ(back.field.penalty_area_width_m, 5.0f);
  EXPECT_EQ(back.field.goal_width_m, 1.6f);
  EXPECT_EQ(back.field.goal_depth_m, 0.45f);
  EXPECT_EQ(back.field.border_m, 1.0f);
  EXPECT_EQ(back.field.margin_m, 0.2f);
  EXPECT_TRUE(Equal(back, c));
}

// An older blob: the newer sections cut off the payload, the header relabelled and re-checksummed.
void TruncateAndLabel(std::vector<uint8_t>& b, size_t cut_bytes, uint16_t version) {
  b.resize(b.size() - cut_bytes);
  const uint32_t len = static_cast<uint32_t>(b.size() - kBlobHeaderBytes);
  const uint32_t crc = Crc32(std::span<const uint8_t>(b.data() + kBlobHeaderBytes, len));
  std::memcpy(b.data() + 6, &version, 2);
  std::memcpy(b.data() + 8, &len, 4);
  std::memcpy(b.data() + 12, &crc, 4);
}

// A version-1 blob (no field section, as stored by older firmware and tools) still loads, with
// the MSL field.
TEST(CalibrationBlob, Version1BlobLoadsWithTheMslField) {
  RigCalibration c = Example();
  c.omni.azimuth_harmonics_rad[1] = 0.004f;
  std::vector<uint8_t> b = Serialize(c);
  constexpr size_t kFieldSectionBytes = 4 + 15 * 4, kAzimuthSectionBytes = 4 + 4 * 4;
  TruncateAndLabel(b, kFieldSectionBytes + kAzimuthSectionBytes + kSelfSectionBytes, 1);
  RigCalibration back;
  back.field.length_m = 1.0f;  // overwritten with the default
  const Status st = ParseCalibration(b, back);
  ASSERT_TRUE(st.ok()) << st.message();
  EXPECT_EQ(back.omni.support_px[44][11], c.omni.support_px[44][11]);
  EXPECT_EQ(back.field.length_m, FieldConfig{}.length_m);
  EXPECT_EQ(back.field.goal_width_m, FieldConfig{}.goal_width_m);
  EXPECT_EQ(back.omni.azimuth_harmonics_rad[1], 0.0f);
  // The same payload labelled version 2 lacks its field section.
  const uint16_t v2 = 2;
  std::memcpy(b.data() + 6, &v2, 2);
  EXPECT_EQ(ParseCalibration(b, back).code(), StatusCode::kDataLoss);
  // A newer version than this build knows is refused.
  const uint16_t v3 = kCalibrationBlobVersion + 1;
  std::memcpy(b.data() + 6, &v3, 2);
  EXPECT_EQ(ParseCalibration(b, back).code(), StatusCode::kUnimplemented);
}

// A version-2 blob (no azimuth harmonics) loads with none; the harmonics round-trip in version 3
// and are refused by name when out of range.
TEST(CalibrationBlob, AzimuthHarmonicsVersion2AndRange) {
  RigCalibration c = Example();
  const float h[4] = {-0.0047f, -0.0052f, 0.0001f, 0.0002f};
  for (int k = 0; k < 4; ++k) c.omni.azimuth_harmonics_rad[k] = h[k];
  std::vector<uint8_t> b = Serialize(c);
  RigCalibration back;
  ASSERT_TRUE(ParseCalibration(b, back).ok());
  for (int k = 0; k < 4; ++k) EXPECT_EQ(back.omni.azimuth_harmonics_rad[k], h[k]);
  EXPECT_TRUE(Equal(back, c));

  TruncateAndLabel(b, 4 + 4 * 4 + kSelfSectionBytes, 2);
  ASSERT_TRUE(ParseCalibration(b, back).ok());
  for (float x : back.omni.azimuth_harmonics_rad) EXPECT_EQ(x, 0.0f);
  EXPECT_EQ(back.field.length_m, c.field.length_m);

  const size_t payload = Serialize(Example()).size() - kBlobHeaderBytes;
  const size_t azim = payload - kSelfSectionBytes - 4 * 4;
  EXPECT_TRUE(ParseWithPayloadEdit(azim, 0.05f).ok());
  for (float bad : {0.2f, -0.11f, NAN}) {
    const Status st = ParseWithPayloadEdit(azim + 8, bad);
    EXPECT_EQ(st.code(), StatusCode::kInvalidArgument) << bad;
    EXPECT_NE(std::strstr(st.message(), "azimuth harmonic"), nullptr) << st.message();
  }
  const Status tag = ParseWithPayloadEdit(azim - 4, 1.0f);
  EXPECT_EQ(tag.code(), StatusCode::kDataLoss);
  EXPECT_NE(std::strstr(tag.message(), "azimuth tag"), nullptr) << tag.message();
  c.omni.azimuth_harmonics_rad[2] = 0.3f;
  std::vector<uint8_t> out(kCalibrationBlobMaxBytes);
  EXPECT_EQ(SerializeCalibration(c, out).status().code(), StatusCode::kInvalidArgument);
}

OmniSelfMask ExampleMask() {
  OmniSelfMask m;
  m.known = true;
  m.inner_radius_px = 54.0f;
  m.outer_radius_px = 219.0f;
  m.sector_count = 4;
  const float angles[] = {20.0f, 110.5f, 200.0f, 359.5f};
  for (int i = 0; i < 4; ++i) m.sectors[i] = {angles[i], 2.5f};
  for (int i = 0; i < OmniSelfMask::kOutlineDirections; ++i) m.body_px[i] = 48 + i % 5;
  return m;
}

// The self-mask (version 4) round-trips; a version-3 blob loads without one; a mask that is
// inconsistent or covers most of the image is refused by name, in the blob as at serialising.
TEST(CalibrationBlob, SelfMaskRoundTripsAndBadMasksAreRefused) {
  RigCalibration c = Example();
  c.omni.self_mask = ExampleMask();
  std::vector<uint8_t> b = Serialize(c);
  RigCalibration back;
  ASSERT_TRUE(ParseCalibration(b, back).ok());
  const OmniSelfMask& m = back.omni.self_mask;
  ASSERT_TRUE(m.known);
  EXPECT_EQ(m.inner_radius_px, 54.0f);
  EXPECT_EQ(m.outer_radius_px, 219.0f);
  ASSERT_EQ(m.sector_count, 4);
  EXPECT_EQ(m.sectors[3].angle_deg, 359.5f);
  EXPECT_EQ(m.body_px[7], 50);
  EXPECT_TRUE(Equal(back, c));

  TruncateAndLabel(b, 4 + 1 + 4 + 4 + 1 + 4 * 8 + 64, 3);
  back.omni.self_mask = ExampleMask();
  ASSERT_TRUE(ParseCalibration(b, back).ok());
  EXPECT_FALSE(back.omni.self_mask.known);
  EXPECT_EQ(back.omni.self_mask.sector_count, 0);

  const auto refused = [&](OmniSelfMask bad, const char* what) {
    RigCalibration r = Example();
    r.omni.self_mask = bad;
    std::vector<uint8_t> out(kCalibrationBlobMaxBytes);
    const Status st = SerializeCalibration(r, out).status();
    EXPECT_EQ(st.code(), StatusCode::kInvalidArgument) << what;
    EXPECT_NE(std::strstr(st.message(), what), nullptr) << st.message();
  };
  OmniSelfMask bad = ExampleMask();
  bad.inner_radius_px = 215.0f;
  refused(bad, "radii");
  bad = ExampleMask();
  for (int i = 0; i < 4; ++i) bad.sectors[i].half_width_deg = 16.0f;  // 128 deg in all
  refused(bad, "120 deg");
  bad = ExampleMask();
  bad.sectors[1].angle_deg = 360.0f;
  refused(bad, "sector angle");
  bad = ExampleMask();
  bad.body_px[3] = 230;
  refused(bad, "body outline");
  bad = OmniSelfMask{};
  bad.sector_count = 1;
  refused(bad, "unknown");
  // In a stored blob too: a sector's half width edited to 70 deg.
  c.omni.self_mask = ExampleMask();
  b = Serialize(c);
  const size_t half0 = b.size() - 64 - 4 * 8 + 4;
  const float wide = 70.0f;
  std::memcpy(b.data() + half0, &wide, 4);
  const uint32_t crc =
      Crc32(std::span<const uint8_t>(b.data() + kBlobHeaderBytes, b.size() - kBlobHeaderBytes));
  std::memcpy(b.data() + 12, &crc, 4);
  back = RigCalibration{};
  const Status st = ParseCalibration(b, back);
  EXPECT_EQ(st.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(std::strstr(st.message(), "half width"), nullptr) << st.message();
  EXPECT_FALSE(back.omni.self_mask.known);  // untouched
}

// The JSON form: written when known, read strictly, absent = none learned.
TEST(CalibrationFile, SelfMaskSectionRoundTrips) {
  const std::string dir = test::TempDir("bv_calib_blob_mask");
  std::string error;
  RigCalibration c = Example();
  c.omni.self_mask = ExampleMask();
  ASSERT_TRUE(cli::SaveCalibrationJson(dir + "/m.json", c, error)) << error;
  RigCalibration back;
  ASSERT_TRUE(cli::LoadCalibrationFile(dir + "/m.json", back, error)) << error;
  EXPECT_TRUE(Equal(back, c));
  std::ifstream in(dir + "/m.json");
  nlohmann::json j = nlohmann::json::parse(in);
  j["omni"]["self_mask"]["sectors"].push_back({100.0, 50.0});
  std::ofstream(dir + "/bad.json") << j.dump();
  EXPECT_FALSE(cli::LoadCalibrationFile(dir + "/bad.json", back, error));
  EXPECT_NE(error.find("self_mask"), std::string::npos) << error;
  j["omni"].erase("self_mask");
  std::ofstream(dir + "/none.json") << j.dump();
  ASSERT_TRUE(cli::LoadCalibrationFile(dir + "/none.json", back, error)) << error;
  EXPECT_FALSE(back.omni.self_mask.known);
}

TEST(CalibrationBlob, CorruptFieldValuesAreRefusedByName) {
  const size_t payload = Serialize(Example()).size() - kBlobHeaderBytes;
  const size_t field =
      payload - kSelfSectionBytes - (4 + 4 * 4) - 15 * 4;  // length_m, width_m, line_width_m, ...
  EXPECT_TRUE(ParseWithPayloadEdit(field, 16.0f).ok());
  const Status nan = ParseWithPayloadEdit(field, NAN);
  EXPECT_EQ(nan.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(std::strstr(nan.message(), "field"), nullptr) << nan.message();
  const Status narrow = ParseWithPayloadEdit(field + 4, 5.0f);  // narrower than the penalty area
  EXPECT_EQ(narrow.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(std::strstr(narrow.message(), "penalty_area_width"), nullptr) << narrow.message();
  EXPECT_EQ(ParseWithPayloadEdit(field + 2 * 4, -0.1f).code(), StatusCode::kInvalidArgument);
  const Status tag = ParseWithPayloadEdit(field - 4, 1.0f);
  EXPECT_EQ(tag.code(), StatusCode::kDataLoss);
  EXPECT_NE(std::strstr(tag.message(), "field tag"), nullptr) << tag.message();
  // Serialisation refuses a field that parsing would refuse.
  RigCalibration c = Example();
  c.field.goal_area_width_m = 7.0f;  // wider than the penalty area
  std::vector<uint8_t> b(kCalibrationBlobMaxBytes);
  const Status st = SerializeCalibration(c, b).status();
  EXPECT_EQ(st.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(std::strstr(st.message(), "goal_area_width"), nullptr) << st.message();
}

std::string TempDir() { return test::TempDir("bv_calib_blob"); }

// The JSON `field` section: rig.json's names, each optional; refusals name the field.
TEST(CalibrationFile, FieldSectionIsReadStrictly) {
  const std::string dir = TempDir();
  std::string error;
  RigCalibration c = Example();
  c.field.length_m = 14.0f;
  ASSERT_TRUE(cli::SaveCalibrationJson(dir + "/f.json", c, error)) << error;
  nlohmann::json j;
  ASSERT_TRUE(cli::ReadJsonFile(dir + "/f.json", j, error)) << error;
  EXPECT_EQ(j["version"], kCalibrationBlobVersion);
  EXPECT_FLOAT_EQ(j["field"]["length"].get<float>(), 14.0f);
  RigCalibration r;
  ASSERT_TRUE(cli::CalibrationFromJson(j, r, error, "f.json")) << error;
  EXPECT_EQ(r.field.length_m, 14.0f);
  // Missing section or keys: the MSL defaults; version 1 files (no field) still load.
  nlohmann::json v1 = j;
  v1.erase("field");
  v1["version"] = 1;
  ASSERT_TRUE(cli::CalibrationFromJson(v1, r, error, "f.json")) << error;
  EXPECT_EQ(r.field.length_m, FieldConfig{}.length_m);
  nlohmann::json part = j;
  part["field"] = {{"goal_width", 2.4}};
  ASSERT_TRUE(cli::CalibrationFromJson(part, r, error, "f.json")) << error;
  EXPECT_FLOAT_EQ(r.field.goal_width_m, 2.4f);
  EXPECT_EQ(r.field.length_m, FieldConfig{}.length_m);
  // Refusals name file, field, value and expectation.
  const auto refused = [&](nlohmann::json field, const std::string& expect) {
    nlohmann::json bad = j;
    bad["field"] = std::move(field);
    std::string e;
    RigCalibration out;
    EXPECT_FALSE(cli::CalibrationFromJson(bad, out, e, "f.json"));
    EXPECT_NE(e.find(expect), std::string::npos) << e;
  };
  refused({{"length", "18"}}, "f.json: field.length: got \"18\" (string)");
  refused({{"width", -3}}, "f.json: field.width: got -3");
  refused({{"border", nullptr}}, "field.border");
  refused({{"goal_area_width", 7.0}}, "f.json: field.goal_area_width: not positive or wider");
  refused({{"length", 3.0}}, "f.json: field.center_circle_radius: negative or the circle leaves");
  refused(nlohmann::json::array(), "f.json: field");
  // Unknown keys are reported (a typo must not pass silently).
  nlohmann::json typo = j;
  typo["field"]["lenght"] = 18;
  std::vector<std::string> unknown;
  ASSERT_TRUE(cli::CalibrationFromJson(typo, r, error, "f.json", &unknown)) << error;
  ASSERT_EQ(unknown.size(), 1u);
  EXPECT_EQ(unknown[0], "f.json: field.lenght");
}

int Calib(std::vector<std::string> args) {
  return test::RunCommand(cli::CmdCalib, std::move(args));
}

TEST(CalibrationFile, JsonBlobJsonThroughTheCli) {
  const std::string dir = TempDir();
  std::string error;
  RigCalibration c = Example();
  ASSERT_TRUE(cli::SaveCalibrationJson(dir + "/a.json", c, error)) << error;
  ASSERT_EQ(Calib({"calib", "to-blob", dir + "/a.json", dir + "/a.bin"}), 0);
  ASSERT_EQ(Calib({"calib", "to-json", dir + "/a.bin", dir + "/b.json"}), 0);
  ASSERT_EQ(Calib({"calib", "show", dir + "/b.json"}), 0);
  RigCalibration from_blob, from_json;
  ASSERT_TRUE(cli::LoadCalibrationFile(dir + "/a.bin", from_blob, error)) << error;
  ASSERT_TRUE(cli::LoadCalibrationFile(dir + "/b.json", from_json, error)) << error;
  EXPECT_TRUE(Equal(from_blob, c));
  EXPECT_TRUE(Equal(from_json, c));
  // A corrupt blob: clear error, no output.
  std::vector<uint8_t> bytes;
  ASSERT_TRUE(cli::ReadFileBytes(dir + "/a.bin", bytes, error));
  bytes[40] ^= 1;
  ASSERT_TRUE(cli::WriteFileBytes(dir + "/bad.bin", bytes, error));
  fs::remove(dir + "/c.json");
  EXPECT_EQ(Calib({"calib", "to-json", dir + "/bad.bin", dir + "/c.json"}), 1);
  EXPECT_FALSE(fs::exists(dir + "/c.json"));
  EXPECT_FALSE(cli::LoadCalibrationFile(dir + "/bad.bin", from_blob, error));
  EXPECT_NE(error.find("CRC"), std::string::npos) << error;
}

TEST(CalibrationFile, SectionUpdateKeepsTheOtherSection) {
  const std::string dir = TempDir();
  const std::string path = dir + "/rig.json";
  fs::remove(path);
  std::string error;
  const RigCalibration c = Example();
  ASSERT_TRUE(cli::UpdateCalibrationSection(path, "persp", cli::PerspToJson(c.persp), error));
  RigCalibration r;
  ASSERT_TRUE(cli::LoadCalibrationFile(path, r, error)) << error;
  EXPECT_TRUE(r.persp.valid);
  EXPECT_FALSE(r.omni.valid);
  const uint32_t id1 = r.calibration_id;
  ASSERT_TRUE(cli::UpdateCalibrationSection(path, "omni", cli::OmniToJson(c.omni), error));
  ASSERT_TRUE(cli::LoadCalibrationFile(path, r, error)) << error;
  EXPECT_TRUE(r.persp.valid);
  EXPECT_TRUE(r.omni.valid);
  EXPECT_EQ(r.persp.fx, c.persp.fx);
  EXPECT_NE(r.calibration_id, id1);  // the id follows the content
  // An invalid section is refused and the file is unchanged.
  nlohmann::json bad = cli::PerspToJson(c.persp);
  bad["fx"] = -1;
  std::vector<uint8_t> before, after;
  ASSERT_TRUE(cli::ReadFileBytes(path, before, error));
  EXPECT_FALSE(cli::UpdateCalibrationSection(path, "persp", bad, error));
  EXPECT_NE(error.find("fx"), std::string::npos) << error;
  ASSERT_TRUE(cli::ReadFileBytes(path, after, error));
  EXPECT_EQ(before, after);
}

TEST(CalibrationFile, ReferenceRigCalibrationLoads) {
  RigCalibration r;
  std::string error;
  ASSERT_TRUE(cli::LoadCalibrationFile(std::string(BV_TEST_DATA_DIR) + "/reference_rig_calib.json",
                                       r, error))
      << error;
  EXPECT_TRUE(r.persp.valid);
  EXPECT_TRUE(r.omni.valid);
  EXPECT_NEAR(r.omni.viewpoint_z_m, 0.776f, 1e-4f);
  EXPECT_EQ(r.calibration_id, cli::ComputeCalibrationId(r));
}

}  // namespace
}  // namespace bv
