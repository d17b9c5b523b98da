#include "tools/ballvision/strict_json.h"

#include <cmath>
#include <limits>

namespace bv::cli {

using nlohmann::json;

namespace {

const char* TypeName(const json& v) {
  if (v.is_boolean()) return "boolean";
  if (v.is_number_integer()) return "integer";
  if (v.is_number_float()) return "number";
  return v.type_name();  // null, string, array, object
}

std::string FormatRange(double lo, double hi) {
  json a = lo, b = hi;
  return "a number in [" + a.dump() + ", " + b.dump() + "]";
}

}  // namespace

std::string DescribeJson(const json& v) {
  std::string text = v.dump();
  if (text.size() > 40) text = text.substr(0, 37) + "...";
  return text + " (" + TypeName(v) + ")";
}

StrictObject::StrictObject(const json& j, std::string file, std::string where)
    : j_(j), file_(std::move(file)), where_(std::move(where)) {}

std::string StrictObject::Name(const std::string& key) const {
  std::string n = file_.empty() ? "" : file_ + ": ";
  if (where_.empty()) return n + key;
  return n + where_ + (key.empty() || key[0] == '[' ? "" : ".") + key;
}

bool StrictObject::Fail(const std::string& key, const json& value, const std::string& expected) {
  if (error_.empty()) {
    error_ = Name(key) + ": got " + DescribeJson(value) + ", expected " + expected;
  }
  return false;
}

bool StrictObject::Adopt(const StrictObject& inner) {
  if (error_.empty()) error_ = inner.error_;
  return false;
}

bool StrictObject::IsObject() {
  if (j_.is_object()) return true;
  if (error_.empty()) {
    error_ = Name("") + ": got " + DescribeJson(j_) + ", expected a JSON object";
  }
  return false;
}

bool StrictObject::Has(const char* key) const { return j_.is_object() && j_.contains(key); }

const json* StrictObject::Get(const char* key, bool required) {
  read_.insert(key);
  if (Has(key)) return &j_[key];
  if (required && error_.empty()) error_ = Name(key) + ": missing";
  return nullptr;
}

const json* StrictObject::Child(const char* key, bool required) { return Get(key, required); }

bool StrictObject::Bool(const char* key, bool& out, bool required) {
  const json* v = Get(key, required);
  if (!v) return !required;
  if (!v->is_boolean()) return Fail(key, *v, "true or false");
  out = v->get<bool>();
  return true;
}

bool StrictObject::Int(const char* key, int64_t& out, int64_t lo, int64_t hi, bool required) {
  const json* v = Get(key, required);
  if (!v) return !required;
  const std::string expected =
      lo == hi ? "exactly " + std::to_string(lo)
               : "an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
  if (v->is_number_unsigned()) {
    const uint64_t u = v->get<uint64_t>();
    if (u > static_cast<uint64_t>(std::numeric_limits<int64_t>::max()) ||
        static_cast<int64_t>(u) > hi || static_cast<int64_t>(u) < lo) {
      return Fail(key, *v, expected);
    }
    out = static_cast<int64_t>(u);
    return true;
  }
  if (!v->is_number_integer()) return Fail(key, *v, expected);
  const int64_t i = v->get<int64_t>();
  if (i < lo || i > hi) return Fail(key, *v, expected);
  out = i;
  return true;
}

bool StrictObject::U32(const char* key, uint32_t& out, bool required) {
  int64_t v = out;
  if (!Int(key, v, 0, 0xFFFFFFFFll, required)) return false;
  out = static_cast<uint32_t>(v);
  return true;
}

bool StrictObject::Number(const char* key, double& out, double lo, double hi, bool required) {
  const json* v = Get(key, required);
  if (!v) return !required;
  if (!v->is_number()) return Fail(key, *v, FormatRange(lo, hi));
  const double d = v->get<double>();
  if (!std::isfinite(d) || d < lo || d > hi) return Fail(key, *v, FormatRange(lo, hi));
  out = d;
  return true;
}

bool StrictObject::Float(const char* key, float& out, double lo, double hi, bool required) {
  constexpr double kFloatMax = std::numeric_limits<float>::max();
  double d = out;
  if (!Number(key, d, std::max(lo, -kFloatMax), std::min(hi, kFloatMax), required)) return false;
  out = static_cast<float>(d);
  return true;
}

bool StrictObject::String(const char* key, std::string& out,
                          std::initializer_list<const char*> allowed, bool required) {
  const json* v = Get(key, required);
  if (!v) return !required;
  std::string expected = allowed.size() ? "one of" : "a string";
  for (const char* a : allowed) expected += std::string(" \"") + a + "\"";
  if (!v->is_string()) return Fail(key, *v, expected);
  const std::string s = v->get<std::string>();
  bool ok = allowed.size() == 0;
  for (const char* a : allowed) ok = ok || s == a;
  if (!ok) return Fail(key, *v, expected);
  out = s;
  return true;
}

bool StrictObject::ArrayElements(const char* key, const json& a, double lo, double hi,
                                 std::vector<double>& out) {
  out.clear();
  for (size_t i = 0; i < a.size(); ++i) {
    const json& e = a[i];
    const double d = e.is_number() ? e.get<double>() : NAN;
    if (!std::isfinite(d) || d < lo || d > hi) {
      return Fail(std::string(key) + "[" + std::to_string(i) + "]", e, FormatRange(lo, hi));
    }
    out.push_back(d);
  }
  return true;
}

bool StrictObject::NumberArray(const char* key, std::vector<double>& out, double lo, double hi,
                               bool required) {
  const json* v = Get(key, required);
  if (!v) return !required;
  if (!v->is_array()) return Fail(key, *v, "an array of numbers");
  return ArrayElements(key, *v, lo, hi, out);
}

bool StrictObject::FloatArray(const char* key, float* dst, size_t n, double lo, double hi,
                              bool required) {
  const json* v = Get(key, required);
  if (!v) return !required;
  if (!v->is_array() || v->size() != n) {
    return Fail(key, *v, "an array of " + std::to_string(n) + " numbers");
  }
  constexpr double kFloatMax = std::numeric_limits<float>::max();
  std::vector<double> d;
  if (!ArrayElements(key, *v, std::max(lo, -kFloatMax), std::min(hi, kFloatMax), d)) return false;
  for (size_t i = 0; i < n; ++i) dst[i] = static_cast<float>(d[i]);
  return true;
}

void StrictObject::Allow(std::initializer_list<const char*> keys) {
  for (const char* k : keys) read_.insert(k);
}

std::vector<std::string> StrictObject::UnknownKeys() const {
  std::vector<std::string> out;
  if (!j_.is_object()) return out;
  for (const auto& [k, v] : j_.items()) {
    if (!read_.count(k) && (k.empty() || k[0] != '_')) out.push_back(Name(k));
  }
  return out;
}

}  // namespace bv::cli
