#include "tools/ballvision/signals.h"

#include <signal.h>

#include <csignal>
#include <cstdio>

namespace bv::cli {
namespace {

volatile std::sig_atomic_t g_signal = 0;

void OnSignal(int sig) {
  if (g_signal != 0) {  // second signal: the user means it
    std::signal(sig, SIG_DFL);
    std::raise(sig);
    return;
  }
  g_signal = sig;
}

}  // namespace

void InstallInterruptHandlers() {
  struct sigaction sa {};
  sa.sa_handler = OnSignal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = 0;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
}

int InterruptSignal() { return g_signal; }

int InterruptExitCode() { return 128 + g_signal; }

void ReportInterrupt(const char* command) {
  std::fprintf(stderr, "%s: interrupted by %s; finishing with what was processed\n", command,
               g_signal == SIGINT    ? "SIGINT"
               : g_signal == SIGTERM ? "SIGTERM"
                                     : "a signal");
}

}  // namespace bv::cli
