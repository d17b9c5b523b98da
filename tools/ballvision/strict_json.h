#pragma once
// Typed, range-checked access to one JSON object. Every refusal names the file, the field, the
// value found and what was expected; nothing is converted silently (1.5 is not an integer,
// 1 is not a boolean, 2^64 is not a 32-bit id). Keys that no getter read and that were not
// declared with Allow() are reported by UnknownKeys().
#include <cstdint>
#include <initializer_list>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace bv::cli {

class StrictObject {
 public:
  /// `file` and `where` ("persp", "" for the top level) prefix every message.
  StrictObject(const nlohmann::json& j, std::string file, std::string where);

  /// False (with the error set) when the value is not a JSON object.
  bool IsObject();
  bool Has(const char* key) const;

  // Getters: with `required` false a missing key leaves `out` unchanged and succeeds.
  bool Bool(const char* key, bool& out, bool required = true);
  bool Int(const char* key, int64_t& out, int64_t lo, int64_t hi, bool required = true);
  bool U32(const char* key, uint32_t& out, bool required = true);
  bool Number(const char* key, double& out, double lo, double hi, bool required = true);
  bool Float(const char* key, float& out, double lo, double hi, bool required = true);
  bool String(const char* key, std::string& out, std::initializer_list<const char*> allowed,
              bool required = true);
  /// Exactly `n` numbers in [lo, hi].
  bool FloatArray(const char* key, float* dst, size_t n, double lo, double hi,
                  bool required = true);
  bool NumberArray(const char* key, std::vector<double>& out, double lo, double hi,
                   bool required = true);
  /// The member `key` (marked as read), or nullptr with the error set when missing and required.
  const nlohmann::json* Child(const char* key, bool required = true);

  /// Keys that are known but not read here (report values, comments).
  void Allow(std::initializer_list<const char*> keys);
  /// Keys neither read nor allowed, as "FILE: where.key" (keys starting with '_' are comments).
  std::vector<std::string> UnknownKeys() const;

  /// "FILE: where.key" for messages about cross-field checks done by the caller.
  std::string Name(const std::string& key) const;
  /// Sets the error (first one wins) and returns false.
  bool Fail(const std::string& key, const nlohmann::json& value, const std::string& expected);
  /// Takes over the error of a reader of a nested value; returns false.
  bool Adopt(const StrictObject& inner);
  const std::string& error() const { return error_; }

 private:
  const nlohmann::json* Get(const char* key, bool required);
  bool ArrayElements(const char* key, const nlohmann::json& a, double lo, double hi,
                     std::vector<double>& out);

  const nlohmann::json& j_;
  std::string file_, where_, error_;
  std::set<std::string> read_;
};

/// A short rendering of a JSON value for messages: type and (truncated) text.
std::string DescribeJson(const nlohmann::json& v);

}  // namespace bv::cli
