#pragma once
// Typed, range-checked command-line values. The whole text must be the value ("12x" is not a
// number), nothing is clamped or rounded, and the message names the option, the text and what
// was expected. Callers exit 2 (usage) on failure. ArgParser puts them together for a command.
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

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

/// One argument parser for every command. Options are declared with their type and range and
/// handled in command-line order (so an option may apply to the ones after it). `--help` or
/// `-h` anywhere prints the usage to stdout (exit 0); a usage error prints "CMD: what was
/// wrong" and the usage to stderr (exit 2). An option's value is never another option
/// (`--out --help` is help, `--out --lut` an error), and nothing is clamped.
class ArgParser {
 public:
  using Handler = std::function<bool(const std::string& value, std::string& error)>;

  /// `command` prefixes the messages ("ballvision run"); `usage` is printed as it is.
  ArgParser(std::string command, std::string usage);

  ArgParser& Flag(const std::string& name, bool& out);
  /// A flag with an action, run in command-line order.
  ArgParser& FlagAction(const std::string& name, std::function<void()> action);
  ArgParser& Text(const std::string& name, std::string& out);
  template <typename T>
  ArgParser& Number(const std::string& name, double lo, double hi, T& out) {
    return Custom(name, [name, lo, hi, &out](const std::string& v, std::string& error) {
      return ArgNumberAs(name, v, lo, hi, out, error);
    });
  }
  template <typename T>
  ArgParser& Int(const std::string& name, int64_t lo, int64_t hi, T& out) {
    return Custom(name, [name, lo, hi, &out](const std::string& v, std::string& error) {
      return ArgIntAs(name, v, lo, hi, out, error);
    });
  }
  /// Any other value: `handler` checks and stores it, or sets the error.
  ArgParser& Custom(const std::string& name, Handler handler);
  /// Positional arguments in order; optional ones after the required ones.
  ArgParser& Positional(const std::string& name, std::string& out, bool required = true);
  /// Every positional argument after the declared ones goes to `out` (a list of files).
  ArgParser& Rest(const std::string& name, std::vector<std::string>& out);
  /// Marks an option declared before as one that must be given.
  ArgParser& Required(const std::string& name);

  /// Parses argv[first..argc). Returns -1 to go on, else the exit code (0 after --help, 2
  /// after a usage error; both printed).
  int Parse(int argc, char** argv, int first = 1);
  /// For checks after Parse: prints `error` and the usage to stderr; returns 2.
  int UsageError(const std::string& error) const;
  /// Prints the usage to stdout; returns 0.
  int Help() const;

 private:
  struct Option {
    std::string name;
    bool takes_value = true;
    Handler handler;
    std::function<void()> action;
    bool required = false, seen = false;
  };
  struct Pos {
    std::string name;
    std::string* out;
    bool required;
  };
  Option* Find(const std::string& name);

  std::string command_, usage_;
  std::vector<Option> options_;
  std::vector<Pos> positionals_;
  std::string rest_name_;
  std::vector<std::string>* rest_ = nullptr;
};

struct SubCommand {
  const char* name;
  std::function<int(int argc, char** argv)> run;  // argv[0] is the sub-command
};
/// `ballvision GROUP SUB ...` (argv[0] is GROUP): runs SUB with argv from SUB on. `--help` or
/// `-h` as SUB prints `usage` to stdout (exit 0); no SUB or an unknown one is a usage error.
int RunSubCommand(const std::string& command, const std::string& usage, int argc, char** argv,
                  const std::vector<SubCommand>& subs);

}  // namespace bv::cli
