#pragma once
// Strict reader of a sequence's truth.csv (rendered ground truth). Every row must have the
// header's number of fields; numeric columns must hold a finite number or be empty where the
// column allows it ("no ball in this camera"). Errors name the file, the line, the column, the
// value and what was expected. A file with no data rows is refused.
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace bv::cli {

class TruthCsv {
 public:
  /// Reads `path`; `required` columns must all be in the header.
  bool Load(const std::string& path, const std::vector<std::string>& required, std::string& error);
  size_t rows() const { return rows_.size(); }
  bool Has(const std::string& column) const { return col_.count(column) != 0; }
  /// The header's columns in file order.
  const std::vector<std::string>& header() const { return header_; }
  /// Raw text of a field ("" for a column the file does not have).
  const std::string& Text(size_t row, const std::string& column) const;
  bool Empty(size_t row, const std::string& column) const { return Text(row, column).empty(); }
  /// A finite number; `allow_empty` leaves `v` unchanged for an empty field.
  bool Number(size_t row, const std::string& column, double& v, bool allow_empty,
              std::string& error) const;
  /// A whole number in [lo, hi] (no fraction, no exponent).
  bool Integer(size_t row, const std::string& column, int64_t lo, int64_t hi, int64_t& v,
               std::string& error) const;
  /// "FILE:LINE" of a data row.
  std::string Where(size_t row) const;

 private:
  std::string path_;
  std::vector<std::string> header_;
  std::map<std::string, size_t> col_;
  std::vector<std::vector<std::string>> rows_;
  std::vector<int> line_;
};

}  // namespace bv::cli
