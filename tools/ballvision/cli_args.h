#pragma once
// Typed, range-checked command-line values. The whole text must be the value ("12x" is not a
// number), nothing is clamped or rounded, and the message names the option, the text and what
// was expected. Callers exit 2 (usage) on failure.
#include <cstdint>
#include <string>

namespace bv::cli {

bool ArgInt(const std::string& option, const std::string& text, int64_t lo, int64_t hi,
            int64_t& out, std::string& error);
bool ArgNumber(const std::string& option, const std::string& text, double lo, double hi,
               double& out, std::string& error);
/// "A<sep>B", e.g. "0.1,0.9" or "9x6"; each part checked like ArgNumber / ArgInt.
bool ArgNumberPair(const std::string& option, const std::string& text, char sep, double lo,
                   double hi, double& a, double& b, std::string& error);
bool ArgIntPair(const std::string& option, const std::string& text, char sep, int64_t lo,
                int64_t hi, int64_t& a, int64_t& b, std::string& error);

template <typename T>
bool ArgIntAs(const std::string& option, const std::string& text, int64_t lo, int64_t hi, T& out,
              std::string& error) {
  int64_t v = 0;
  if (!ArgInt(option, text, lo, hi, v, error)) return false;
  out = static_cast<T>(v);
  return true;
}
template <typename T>
bool ArgNumberAs(const std::string& option, const std::string& text, double lo, double hi, T& out,
                 std::string& error) {
  double v = 0;
  if (!ArgNumber(option, text, lo, hi, v, error)) return false;
  out = static_cast<T>(v);
  return true;
}

}  // namespace bv::cli
