#pragma once
// The main loop feeds the watchdog once per iteration, so only a loop that keeps iterating keeps
// it quiet; a driver or the pipeline stuck anywhere lets it bite (QEMU: exit 103, a board: reset).
namespace bv::hal {

class Watchdog {
 public:
  virtual ~Watchdog() = default;
  /// Restarts the timeout; cheap (a register write), safe to call at any rate.
  void Feed() { DoFeed(); }

 private:
  virtual void DoFeed() = 0;
};

}  // namespace bv::hal
