#include "hal/common/frames_csv.h"

namespace bv::hal {
namespace {

std::string_view WithoutCr(std::string_view line) {
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  return line;
}

// Calls f(column, field) for each comma-separated field; returns the number of fields.
template <typename F>
int ForEachField(std::string_view line, F&& f) {
  int column = 0;
  for (;;) {
    const size_t comma = line.find(',');
    f(column++, line.substr(0, comma));
    if (comma == std::string_view::npos) return column;
    line.remove_prefix(comma + 1);
  }
}

bool ParseU64(std::string_view s, uint64_t& out) {
  if (s.empty() || s.size() > 20) return false;
  uint64_t v = 0;
  for (const char c : s) {
    if (c < '0' || c > '9') return false;
    const auto d = static_cast<uint64_t>(c - '0');
    if (v > (UINT64_MAX - d) / 10) return false;
    v = v * 10 + d;
  }
  out = v;
  return true;
}

bool ParseI64(std::string_view s, int64_t& out) {
  const bool negative = !s.empty() && s.front() == '-';
  if (negative) s.remove_prefix(1);
  uint64_t v = 0;
  if (!ParseU64(s, v) || v > (negative ? uint64_t{INT64_MAX} + 1 : uint64_t{INT64_MAX})) {
    return false;
  }
  out = negative ? static_cast<int64_t>(0 - v) : static_cast<int64_t>(v);
  return true;
}

}  // namespace

Status ParseFramesHeader(std::string_view line, FramesColumns& out) {
  FramesColumns c;
  c.count = ForEachField(WithoutCr(line), [&c](int column, std::string_view name) {
    if (name == "index") c.index = column;
    if (name == "t_us") c.t_us = column;
    if (name == "omni_file") c.omni_file = column;
    if (name == "persp_file") c.persp_file = column;
  });
  out = c;
  if (c.index < 0 || c.t_us < 0 || c.omni_file < 0 || c.persp_file < 0) {
    return Status(StatusCode::kInvalidArgument,
                  "header must have columns index,t_us,omni_file,persp_file");
  }
  return Status();
}

Status ParseFramesRow(std::string_view line, const FramesColumns& columns, FramesRow& out) {
  FramesRow row;
  std::string_view index, t_us;
  row.columns = ForEachField(WithoutCr(line), [&](int column, std::string_view field) {
    if (column == columns.index) index = field;
    if (column == columns.t_us) t_us = field;
    if (column == columns.omni_file) row.omni_file = field;
    if (column == columns.persp_file) row.persp_file = field;
  });
  if (row.columns != columns.count) {
    row.problem = FramesRowProblem::kColumnCount;
  } else if (!ParseI64(index, row.index)) {
    row.problem = FramesRowProblem::kIndex;
    row.bad_field = index;
  } else if (!ParseU64(t_us, row.t_us)) {
    row.problem = FramesRowProblem::kTimestamp;
    row.bad_field = t_us;
  }
  out = row;
  switch (row.problem) {
    case FramesRowProblem::kNone:
      return Status();
    case FramesRowProblem::kColumnCount:
      return Status(StatusCode::kInvalidArgument, "not as many columns as the header");
    case FramesRowProblem::kIndex:
      return Status(StatusCode::kInvalidArgument, "column index is not an integer");
    case FramesRowProblem::kTimestamp:
      break;
  }
  return Status(StatusCode::kInvalidArgument, "column t_us is not a non-negative integer");
}

}  // namespace bv::hal
