#pragma once
// Ctrl-C / SIGTERM on long commands (listen, run, eval, lut, calibrate): the handler only
// records the signal; the command notices it at its next frame or read, writes what it has,
// prints its summary and exits with 128 + the signal number. A second signal kills at once.
namespace bv::cli {

/// Installs the handlers (without SA_RESTART, so a blocking read returns EINTR).
void InstallInterruptHandlers();
/// The signal received (SIGINT, SIGTERM) or 0.
int InterruptSignal();
/// 128 + InterruptSignal(), the shell's convention for "ended by a signal".
int InterruptExitCode();
/// Prints "interrupted by SIGINT" style line on stderr.
void ReportInterrupt(const char* command);

}  // namespace bv::cli
