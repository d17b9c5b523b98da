#pragma once
// frames.csv (DESIGN.md §4): the index of a captured sequence, one row per frame pair. One parser
// for the host tools and the device: no allocation, fields are views into the caller's line.
#include <cstdint>
#include <string_view>

#include "core/common/status.h"

namespace bv::hal {

/// Where the four columns are in this file's header (any order; other columns are ignored).
struct FramesColumns {
  int index = -1, t_us = -1, omni_file = -1, persp_file = -1;
  int count = 0;  // columns in the header: every row must have as many
};

/// Reads the header line (a trailing '\r' is ignored). kInvalidArgument when one of index,
/// t_us, omni_file, persp_file is missing.
Status ParseFramesHeader(std::string_view line, FramesColumns& out);

/// What was wrong with a row, for callers that word their own message.
enum class FramesRowProblem : uint8_t { kNone, kColumnCount, kIndex, kTimestamp };

struct FramesRow {
  int64_t index = 0;
  uint64_t t_us = 0;
  // Views into the parsed line (valid while it is); empty: that camera has no frame this row.
  std::string_view omni_file, persp_file;
  // On error: what and, for kIndex / kTimestamp, the offending field; `columns` the row's count.
  FramesRowProblem problem = FramesRowProblem::kNone;
  std::string_view bad_field;
  int columns = 0;
};

/// Parses one data row (a trailing '\r' is ignored). kInvalidArgument names the problem:
/// wrong number of columns, an index that is not a 64-bit integer, a t_us that is not a
/// non-negative one. `out` is written in every case (problem, bad_field, columns).
Status ParseFramesRow(std::string_view line, const FramesColumns& columns, FramesRow& out);

}  // namespace bv::hal
