#include "tools/ballvision/cli_args.h"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
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

ArgParser::ArgParser(std::string command, std::string usage)
    : command_(std::move(command)), usage_(std::move(usage)) {}

ArgParser& ArgParser::Flag(const std::string& name, bool& out) {
  return FlagAction(name, [&out] { out = true; });
}

ArgParser& ArgParser::FlagAction(const std::string& name, std::function<void()> action) {
  Option o;
  o.name = name;
  o.takes_value = false;
  o.action = std::move(action);
  options_.push_back(std::move(o));
  return *this;
}

ArgParser& ArgParser::Text(const std::string& name, std::string& out) {
  return Custom(name, [&out](const std::string& v, std::string&) {
    out = v;
    return true;
  });
}

ArgParser& ArgParser::Custom(const std::string& name, Handler handler) {
  Option o;
  o.name = name;
  o.handler = std::move(handler);
  options_.push_back(std::move(o));
  return *this;
}

ArgParser& ArgParser::Positional(const std::string& name, std::string& out, bool required) {
  positionals_.push_back({name, &out, required});
  return *this;
}

ArgParser& ArgParser::Rest(const std::string& name, std::vector<std::string>& out) {
  rest_name_ = name;
  rest_ = &out;
  return *this;
}

ArgParser& ArgParser::Required(const std::string& name) {
  if (Option* o = Find(name)) o->required = true;
  return *this;
}

ArgParser::Option* ArgParser::Find(const std::string& name) {
  for (Option& o : options_) {
    if (o.name == name) return &o;
  }
  return nullptr;
}

namespace {

bool IsHelp(const std::string& a) { return a == "--help" || a == "-h"; }

// "-" (standard input/output) and "-5", "-.5" (numbers) are values; "--x" and "-x" options.
bool LooksLikeOption(const std::string& a) {
  return a.size() > 1 && a[0] == '-' && !std::isdigit(static_cast<unsigned char>(a[1])) &&
         a[1] != '.';
}

}  // namespace

int ArgParser::Parse(int argc, char** argv, int first) {
  for (int i = first; i < argc; ++i) {
    if (IsHelp(argv[i])) return Help();
  }
  size_t next_positional = 0;
  for (int i = first; i < argc; ++i) {
    const std::string a = argv[i];
    if (!LooksLikeOption(a)) {
      if (next_positional >= positionals_.size()) {
        if (rest_ != nullptr) {
          rest_->push_back(a);
          continue;
        }
        return UsageError("unexpected argument '" + a + "'");
      }
      *positionals_[next_positional++].out = a;
      continue;
    }
    Option* o = Find(a);
    if (!o) return UsageError("unknown option " + a);
    o->seen = true;
    if (!o->takes_value) {
      o->action();
      continue;
    }
    if (i + 1 >= argc) return UsageError(a + " needs a value");
    const std::string v = argv[++i];
    if (LooksLikeOption(v)) return UsageError(a + " needs a value, got the option " + v);
    std::string error;
    if (!o->handler(v, error)) return UsageError(error);
  }
  for (size_t p = next_positional; p < positionals_.size(); ++p) {
    if (positionals_[p].required) return UsageError("missing " + positionals_[p].name);
  }
  for (const Option& o : options_) {
    if (o.required && !o.seen) return UsageError("missing " + o.name);
  }
  return -1;
}

int ArgParser::UsageError(const std::string& error) const {
  std::fprintf(stderr, "%s: %s\n\n%s", command_.c_str(), error.c_str(), usage_.c_str());
  return 2;
}

int ArgParser::Help() const {
  std::fputs(usage_.c_str(), stdout);
  return 0;
}

int RunSubCommand(const std::string& command, const std::string& usage, int argc, char** argv,
                  const std::vector<SubCommand>& subs) {
  ArgParser p(command, usage);
  if (argc < 2) return p.UsageError("missing sub-command");
  const std::string sub = argv[1];
  if (IsHelp(sub)) return p.Help();
  for (const SubCommand& s : subs) {
    if (sub == s.name) return s.run(argc - 1, argv + 1);
  }
  return p.UsageError("unknown sub-command '" + sub + "'");
}

}  // namespace bv::cli
