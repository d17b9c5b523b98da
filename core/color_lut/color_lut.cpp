#include "core/color_lut/color_lut.h"

#include <cmath>
#include <cstring>

#include "core/common/blob.h"
#include "core/common/bytes.h"
#include "core/common/crc32.h"

namespace bv {

const char* ColorClassName(ColorClass c) {
  switch (c) {
    case ColorClass::kUnknown:
      return "unknown";
    case ColorClass::kBall:
      return "ball";
    case ColorClass::kField:
      return "field";
    case ColorClass::kLine:
      return "line";
    case ColorClass::kObstacle:
      return "obstacle";
  }
  return "invalid";
}

void ColorLut::Fill(ColorClass c) {
  const auto v = static_cast<uint8_t>(c);
  std::memset(packed_, v | (v << 4), sizeof packed_);
}

void ColorLut::CopyEntries(uint32_t first, std::span<uint8_t> out) const {
  for (size_t i = 0; i < out.size(); ++i) {
    out[i] = static_cast<uint8_t>(at(first + static_cast<uint32_t>(i)));
  }
}

namespace {

// CRC of the one-byte-per-cell table, unpacked in small chunks (no 64 KB copy).
uint32_t EntriesCrc(uint32_t crc, const ColorLut& lut) {
  uint8_t chunk[256];
  for (uint32_t i = 0; i < ColorLut::kEntries; i += sizeof chunk) {
    lut.CopyEntries(i, chunk);
    crc = Crc32Update(crc, chunk);
  }
  return crc;
}

}  // namespace

uint32_t ColorLut::Id() const { return EntriesCrc(0, *this); }

ChromaBox ColorLut::Bounds(ColorClass c, uint32_t u_first, uint32_t u_end) const {
  constexpr uint32_t kUCells = 1u << kUBits, kVCells = 1u << kVBits;
  uint32_t umin = kUCells, umax = 0, vmin = kVCells, vmax = 0;
  for (uint32_t i = 0; i < kEntries; ++i) {
    const uint32_t row = (i >> kVBits) & (kUCells - 1);
    if (row < u_first || row >= u_end) {
      i |= kVCells - 1;  // skip the rest of this U row
      continue;
    }
    if (at(i) != c) continue;
    const uint32_t uc = (i >> kVBits) & (kUCells - 1), vc = i & (kVCells - 1);
    umin = uc < umin ? uc : umin;
    umax = uc > umax ? uc : umax;
    vmin = vc < vmin ? vc : vmin;
    vmax = vc > vmax ? vc : vmax;
  }
  ChromaBox box;
  if (umin > umax) {
    box.empty = true;
    return box;
  }
  // A cell covers 2^(8 - bits) chroma values.
  box.u_min = static_cast<uint8_t>(umin << (8 - kUBits));
  box.u_max = static_cast<uint8_t>(((umax + 1) << (8 - kUBits)) - 1);
  box.v_min = static_cast<uint8_t>(vmin << (8 - kVBits));
  box.v_max = static_cast<uint8_t>(((vmax + 1) << (8 - kVBits)) - 1);
  return box;
}

ChromaBox Union(const ChromaBox& a, const ChromaBox& b) {
  if (a.empty) return b;
  if (b.empty) return a;
  ChromaBox out;
  out.u_min = a.u_min < b.u_min ? a.u_min : b.u_min;
  out.u_max = a.u_max > b.u_max ? a.u_max : b.u_max;
  out.v_min = a.v_min < b.v_min ? a.v_min : b.v_min;
  out.v_max = a.v_max > b.v_max ? a.v_max : b.v_max;
  return out;
}

bool FloorProfileSane(const FloorBallProfile& p) {
  if (!p.valid) return true;
  return std::isfinite(p.horizon_v_px) && p.slope > 0.0f && p.slope <= 10.0f &&
         std::isfinite(p.curve) && std::fabs(p.curve) < 1.0f && p.spread >= 0.0f &&
         std::isfinite(p.spread) && p.width_px >= 1 && p.width_px <= 4096 && p.height_px >= 1 &&
         p.height_px <= 4096;
}

namespace {
void WriteCameraSection(ByteWriter& w, const FloorBallProfile* profile) {
  const FloorBallProfile p = profile != nullptr ? *profile : FloorBallProfile{};
  w.U8(p.valid ? 1 : 0);
  for (int i = 0; i < 3; ++i) w.U8(0);
  w.U16(p.width_px);
  w.U16(p.height_px);
  w.F32(p.horizon_v_px);
  w.F32(p.slope);
  w.F32(p.curve);
  w.F32(p.spread);
  w.U16(p.samples);
  for (int i = 0; i < 6; ++i) w.U8(0);
}
}  // namespace

Result<size_t> SerializeLut(const ColorLut& lut, std::span<uint8_t> out,
                            const FloorBallProfile* profile) {
  if (out.size() < kColorLutBlobBytes) {
    return Status(StatusCode::kResourceExhausted,
                  "SerializeLut: output smaller than kColorLutBlobBytes");
  }
  if (profile != nullptr && !FloorProfileSane(*profile)) {
    return Status(StatusCode::kInvalidArgument, "SerializeLut: floor-ball profile out of range");
  }
  // Header written by hand (not WriteBlob) so the 64 KB payload needs no scratch copy.
  const uint8_t layout[4] = {ColorLut::kYBits, ColorLut::kUBits, ColorLut::kVBits,
                             kColorClassCount};
  uint8_t camera[kColorLutCameraBytes];
  ByteWriter cw(camera);
  WriteCameraSection(cw, profile);
  const uint32_t crc = Crc32Update(EntriesCrc(Crc32Update(0, layout), lut), camera);
  ByteWriter w(out);
  w.U32(kBlobMagic);
  w.U16(static_cast<uint16_t>(BlobKind::kColorLut));
  w.U16(kColorLutBlobVersion);
  w.U32(static_cast<uint32_t>(kColorLutPayloadBytes));
  w.U32(crc);
  w.Bytes(layout);
  uint8_t chunk[256];
  for (uint32_t i = 0; i < ColorLut::kEntries; i += sizeof chunk) {
    lut.CopyEntries(i, chunk);
    w.Bytes(chunk);
  }
  w.Bytes(camera);
  BV_TRY(w.status());
  return w.size();
}

Status ParseLut(std::span<const uint8_t> blob, ColorLut& out, FloorBallProfile* profile) {
  Result<BlobView> view = ReadBlob(blob, BlobKind::kColorLut, kColorLutBlobVersion);
  if (!view.ok()) return view.status();
  std::span<const uint8_t> p = view->payload;
  const size_t expected = view->version == 1 ? kColorLutPayloadBytesV1 : kColorLutPayloadBytes;
  if (p.size() != expected) {
    return Status(StatusCode::kInvalidArgument,
                  "ParseLut: payload size is not 4 + 65536 (+ 32 from version 2) bytes");
  }
  if (p[0] != ColorLut::kYBits || p[1] != ColorLut::kUBits || p[2] != ColorLut::kVBits) {
    return Status(StatusCode::kInvalidArgument, "ParseLut: bit layout is not Y4/U6/V6");
  }
  if (p[3] == 0 || p[3] > kColorClassCount) {
    return Status(StatusCode::kInvalidArgument, "ParseLut: class count out of range");
  }
  for (size_t i = 0; i < ColorLut::kEntries; ++i) {
    if (p[4 + i] >= p[3]) {
      return Status(StatusCode::kInvalidArgument, "ParseLut: table entry names an unknown class");
    }
  }
  FloorBallProfile fp;
  if (view->version >= 2) {
    ByteReader r(p.subspan(kColorLutPayloadBytesV1));
    const uint8_t valid = r.U8();
    for (int i = 0; i < 3; ++i) r.U8();
    fp.width_px = r.U16();
    fp.height_px = r.U16();
    fp.horizon_v_px = r.F32();
    fp.slope = r.F32();
    fp.curve = r.F32();
    fp.spread = r.F32();
    fp.samples = r.U16();
    if (valid > 1) {
      return Status(StatusCode::kInvalidArgument, "ParseLut: camera section flag is not 0 or 1");
    }
    fp.valid = valid == 1;
    if (!FloorProfileSane(fp)) {
      return Status(StatusCode::kInvalidArgument,
                    "ParseLut: camera section's floor-ball profile out of range");
    }
    if (!fp.valid) fp = FloorBallProfile{};
  }
  for (size_t i = 0; i < ColorLut::kEntries; ++i)
    out.Set(static_cast<uint32_t>(i), static_cast<ColorClass>(p[4 + i]));
  if (profile != nullptr) *profile = fp;
  return Status::Ok();
}

}  // namespace bv
