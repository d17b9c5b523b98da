#pragma once
// Which DMA slot the DCMI may write next, with up to kMaxHeld pairs held by the main loop (a
// capture streams one from its slot while the pipeline processes the next: Camera::MaxHeldPairs).
// The next frame's slot is chosen two chunks before the current frame ends, while the
// pairer's unserved (pending) frame still occupies its slot, so the slots in use at that moment
// are: up to kMaxHeld held, one pending, the one being written; kCaptureSlots = kMaxHeld + 3
// always leaves one free. Pure logic (no registers), host-tested (host_tests/h7_slots_test.cpp).
// The held entries are written by the main loop (Hold under the interrupt lock, Release as one
// aligned store) and read by the DMA interrupt: a stale read only keeps a just-released slot out.
namespace bv::h7 {

template <int kSlots, int kMaxHeld>
class SlotBook {
  static_assert(kSlots >= kMaxHeld + 3, "held + pending + being written + the next frame's");

 public:
  SlotBook() {
    for (volatile int& h : held_) h = -1;
  }
  /// A slot that is neither held, nor `pending` (the pairer's unserved frame, or -1), nor
  /// `writing` (the frame in progress).
  int Free(int pending, int writing) const {
    for (int s = 0; s < kSlots; ++s) {
      if (s != pending && s != writing && !IsHeld(s)) return s;
    }
    return writing;  // unreachable (static_assert); overwriting our own frame is the safe fallback
  }
  /// Records `slot` as handed out; false (nothing recorded) when kMaxHeld are held already.
  bool Hold(int slot) {
    for (volatile int& h : held_) {
      if (h < 0) {
        h = slot;
        return true;
      }
    }
    return false;
  }
  void Release(int slot) {
    for (volatile int& h : held_) {
      if (h == slot) {
        h = -1;
        return;
      }
    }
  }
  bool IsHeld(int slot) const {
    for (const volatile int& h : held_) {
      if (h == slot) return true;
    }
    return false;
  }
  int held_count() const {
    int n = 0;
    for (const volatile int& h : held_) n += h >= 0 ? 1 : 0;
    return n;
  }

 private:
  volatile int held_[kMaxHeld];
};

}  // namespace bv::h7
