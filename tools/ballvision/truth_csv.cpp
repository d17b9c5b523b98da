#include "tools/ballvision/truth_csv.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>

#include "hal/host/sequence.h"

namespace bv::cli {
namespace {

std::string Shown(const std::string& s) {
  return "'" + (s.size() > 40 ? s.substr(0, 37) + "..." : s) + "'";
}

}  // namespace

bool TruthCsv::Load(const std::string& path, const std::vector<std::string>& required,
                    std::string& error) {
  path_ = path;
  header_.clear();
  col_.clear();
  rows_.clear();
  line_.clear();
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    error = path + ": cannot open";
    return false;
  }
  std::string line;
  if (!std::getline(in, line)) {
    error = path + ":1: empty file, expected a header line";
    return false;
  }
  header_ = host::SplitCsvLine(line);
  const auto& header = header_;
  for (size_t i = 0; i < header.size(); ++i) col_[header[i]] = i;
  for (const std::string& need : required) {
    if (!col_.count(need)) {
      error = path + ":1: header lacks column '" + need + "' (got " + Shown(line) + ")";
      return false;
    }
  }
  for (int n = 2; std::getline(in, line); ++n) {
    if (line.empty() || line == "\r") continue;
    auto f = host::SplitCsvLine(line);
    if (f.size() != header.size()) {
      error = path + ":" + std::to_string(n) + ": has " + std::to_string(f.size()) +
              " fields, the header has " + std::to_string(header.size());
      return false;
    }
    rows_.push_back(std::move(f));
    line_.push_back(n);
  }
  if (rows_.empty()) {
    error = path + ": no data rows";
    return false;
  }
  return true;
}

const std::string& TruthCsv::Text(size_t row, const std::string& column) const {
  static const std::string kEmpty;
  const auto it = col_.find(column);
  return it == col_.end() ? kEmpty : rows_[row][it->second];
}

std::string TruthCsv::Where(size_t row) const { return path_ + ":" + std::to_string(line_[row]); }

bool TruthCsv::Number(size_t row, const std::string& column, double& v, bool allow_empty,
                      std::string& error) const {
  const std::string& s = Text(row, column);
  if (s.empty() && allow_empty) return true;
  char* end = nullptr;
  const double d = std::strtod(s.c_str(), &end);
  if (s.empty() || *end != '\0' || !std::isfinite(d)) {
    error = Where(row) + ": column " + column + ": got " + Shown(s) + ", expected a number" +
            (allow_empty ? " or nothing" : "");
    return false;
  }
  v = d;
  return true;
}

bool TruthCsv::Integer(size_t row, const std::string& column, int64_t lo, int64_t hi, int64_t& v,
                       std::string& error) const {
  const std::string& s = Text(row, column);
  errno = 0;
  char* end = nullptr;
  const long long i = std::strtoll(s.c_str(), &end, 10);
  if (s.empty() || *end != '\0' || errno == ERANGE || i < lo || i > hi) {
    error = Where(row) + ": column " + column + ": got " + Shown(s) + ", expected an integer in [" +
            std::to_string(lo) + ", " + std::to_string(hi) + "]";
    return false;
  }
  v = i;
  return true;
}

}  // namespace bv::cli
