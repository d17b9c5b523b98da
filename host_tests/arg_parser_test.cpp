// tools/ballvision/cli_args.h ArgParser and RunSubCommand: the one command-line parser of the
// ballvision commands (every command through the binary: hostile_cli_test.py).

#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tools/ballvision/cli_args.h"

namespace bv::cli {
namespace {

constexpr char kUsage[] = "usage: ballvision thing SEQ [--n N] [--x X] [--name S] [--flag]\n";

struct Parsed {
  std::string seq, name, order;
  int n = 7;
  double x = 0;
  bool flag = false;
};

// Parses `args` (argv[0] "thing"); returns Parse's result with stdout and stderr captured.
int Parse(std::vector<std::string> args, Parsed& p, std::string* out = nullptr,
          std::string* err = nullptr) {
  args.insert(args.begin(), "thing");
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  ArgParser parser("ballvision thing", kUsage);
  parser.Positional("SEQ", p.seq)
      .Int("--n", 1, 100, p.n)
      .Number("--x", -1, 1, p.x)
      .Text("--name", p.name)
      .Required("--name")
      .Flag("--flag", p.flag)
      .FlagAction("--a", [&p] { p.order += "a"; })
      .Custom("--b", [&p](const std::string& v, std::string&) {
        p.order += "b" + v;
        return true;
      });
  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  const int rc = parser.Parse(static_cast<int>(argv.size()), argv.data());
  const std::string o = testing::internal::GetCapturedStdout();
  const std::string e = testing::internal::GetCapturedStderr();
  if (out) *out = o;
  if (err) *err = e;
  return rc;
}

TEST(ArgParser, TypedValuesPositionalsAndOrder) {
  Parsed p;
  EXPECT_EQ(
      Parse({"--a", "s1", "--n", "12", "--x", "-0.5", "--name", "-", "--b", "2", "--a", "--flag"},
            p),
      -1);
  EXPECT_EQ(p.seq, "s1");
  EXPECT_EQ(p.n, 12);
  EXPECT_EQ(p.x, -0.5);  // a negative number is a value, not an option
  EXPECT_EQ(p.name, "-");
  EXPECT_TRUE(p.flag);
  EXPECT_EQ(p.order, "ab2a");  // handlers run in command-line order
}

TEST(ArgParser, HelpAnywhereGoesToStdout) {
  for (const char* help : {"--help", "-h"}) {
    Parsed p;
    std::string out, err;
    EXPECT_EQ(Parse({"s1", "--name", help}, p, &out, &err), 0);
    EXPECT_EQ(out, kUsage);
    EXPECT_EQ(err, "");
  }
}

TEST(ArgParser, UsageErrorsNameWhatWasWrong) {
  const std::pair<std::vector<std::string>, std::string> cases[] = {
      {{"s1", "--name", "a", "--n", "0"}, "--n: got '0', expected an integer in [1, 100]"},
      {{"s1", "--name", "a", "--n", "5.5"}, "--n: got '5.5', expected an integer in [1, 100]"},
      {{"s1", "--name", "a", "--x", "2"}, "--x: got '2', expected a number in [-1, 1]"},
      {{"s1", "--name", "--flag"}, "--name needs a value, got the option --flag"},
      {{"s1", "--name"}, "--name needs a value"},
      {{"s1", "--name", "a", "--bogus"}, "unknown option --bogus"},
      {{"s1", "s2", "--name", "a"}, "unexpected argument 's2'"},
      {{"--name", "a"}, "missing SEQ"},
      {{"s1"}, "missing --name"},
  };
  for (const auto& [args, message] : cases) {
    Parsed p;
    std::string out, err;
    EXPECT_EQ(Parse(args, p, &out, &err), 2) << message;
    EXPECT_EQ(out, "");
    EXPECT_EQ(err, "ballvision thing: " + message + "\n\n" + kUsage);
  }
}

TEST(ArgParser, SubCommands) {
  int ran = 0;
  std::string seen;
  const std::vector<SubCommand> subs = {{"go", [&](int argc, char** argv) {
                                           ++ran;
                                           seen = std::string(argv[0]) + std::to_string(argc);
                                           return 5;
                                         }}};
  const auto run = [&](std::vector<std::string> args, std::string* out, std::string* err) {
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    testing::internal::CaptureStdout();
    testing::internal::CaptureStderr();
    const int rc = RunSubCommand("ballvision grp", "usage: ballvision grp go\n",
                                 static_cast<int>(argv.size()), argv.data(), subs);
    *out = testing::internal::GetCapturedStdout();
    *err = testing::internal::GetCapturedStderr();
    return rc;
  };
  std::string out, err;
  EXPECT_EQ(run({"grp", "go", "x"}, &out, &err), 5);
  EXPECT_EQ(seen, "go2");
  EXPECT_EQ(run({"grp", "--help"}, &out, &err), 0);
  EXPECT_EQ(out, "usage: ballvision grp go\n");
  EXPECT_EQ(run({"grp", "stop"}, &out, &err), 2);
  EXPECT_EQ(err, "ballvision grp: unknown sub-command 'stop'\n\nusage: ballvision grp go\n");
  EXPECT_EQ(run({"grp"}, &out, &err), 2);
  EXPECT_EQ(err, "ballvision grp: missing sub-command\n\nusage: ballvision grp go\n");
  EXPECT_EQ(ran, 1);
}

}  // namespace
}  // namespace bv::cli
