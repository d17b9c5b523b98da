#include "tools/ballvision/cli_args.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <sstream>

namespace bv::cli {
namespace {

std::string Quote(const std::string& s) { return "'" + s + "'"; }

std::string NumberText(double v) {
  std::ostringstream o;
  o << v;
  return o.str();
}

}  // namespace

bool ArgInt(const std::string& option, const std::string& text, int64_t lo, int64_t hi,
            int64_t& out, std::string& error) {
  const std::string expected =
      "an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
  errno = 0;
  char* end = nullptr;
  const long long v = std::strtoll(text.c_str(), &end, 10);
  const bool whole = !text.empty() && !std::isspace(static_cast<unsigned char>(text[0])) &&
                     end != text.c_str() && *end == '\0';
  if (!whole || errno == ERANGE || v < lo || v > hi) {
    error = option + ": got " + Quote(text) + ", expected " + expected;
    return false;
  }
  out = v;
  return true;
}

bool ArgNumber(const std::string& option, const std::string& text, double lo, double hi,
               double& out, std::string& error) {
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  const bool whole = !text.empty() && !std::isspace(static_cast<unsigned char>(text[0])) &&
                     end != text.c_str() && *end == '\0';
  if (!whole || errno == ERANGE || !std::isfinite(v) || v < lo || v > hi) {
    error = option + ": got " + Quote(text) + ", expected a number in [" + NumberText(lo) + ", " +
            NumberText(hi) + "]";
    return false;
  }
  out = v;
  return true;
}

bool ArgNumberPair(const std::string& option, const std::string& text, char sep, double lo,
                   double hi, double& a, double& b, std::string& error) {
  const size_t p = text.find(sep);
  if (p == std::string::npos) {
    error = option + ": got " + Quote(text) + ", expected two numbers as A" + sep + "B";
    return false;
  }
  return ArgNumber(option, text.substr(0, p), lo, hi, a, error) &&
         ArgNumber(option, text.substr(p + 1), lo, hi, b, error);
}

bool ArgIntPair(const std::string& option, const std::string& text, char sep, int64_t lo,
                int64_t hi, int64_t& a, int64_t& b, std::string& error) {
  const size_t p = text.find(sep);
  if (p == std::string::npos) {
    error = option + ": got " + Quote(text) + ", expected two integers as A" + sep + "B";
    return false;
  }
  return ArgInt(option, text.substr(0, p), lo, hi, a, error) &&
         ArgInt(option, text.substr(p + 1), lo, hi, b, error);
}

}  // namespace bv::cli
