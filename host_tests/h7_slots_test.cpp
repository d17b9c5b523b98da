// The STM32H7 camera's slot bookkeeping (hal/stm32h7/slot_book.h) against the DMA's schedule:
// the next frame's slot is chosen two chunks (of five) before the current frame ends, frames
// complete into the pairer, and the main loop holds up to two pairs (a capture streaming one
// from its slot for many frames while the pipeline takes and releases the next). The DMA must
// never write into a slot that is held or waiting to be acquired.
#include <gtest/gtest.h>

#include <random>

#include "hal/common/frame_pairer.h"
#include "hal/stm32h7/slot_book.h"

namespace bv::h7 {
namespace {

struct Outcome {
  int writes_into_held = 0;     // a chunk written into a slot the loop holds
  int writes_into_pending = 0;  // ... or into the pairer's unserved frame
  int pairs_served = 0;
  int max_held = 0;
  int refused_holds = 0;
};

// camera.cpp's schedule on a model: per chunk the DMA writes `writing`; after the frame's 3rd
// chunk it picks the next slot (FreeSlot); after the 5th the frame completes into the pairer.
// Between chunks the loop may acquire (TakePair + Hold, as DoAcquirePair) or release.
template <int kSlots, int kMaxHeld>
Outcome Simulate(uint32_t seed, int frames) {
  SlotBook<kSlots, kMaxHeld> book;
  hal::FramePairer pairer;
  std::mt19937 rng(seed);
  Outcome o;
  int writing = 0, next = -1;
  int pipeline_slot = -1, capture_slot = -1, capture_left = 0;
  uint64_t t = 1000;
  for (int f = 0; f < frames; ++f) {
    for (int chunk = 0; chunk < 5; ++chunk) {
      if (book.IsHeld(writing)) ++o.writes_into_held;
      if (writing == pairer.pending_slot(hal::CameraId::kOmni)) ++o.writes_into_pending;
      if (chunk == 2) next = book.Free(pairer.pending_slot(hal::CameraId::kOmni), writing);
      if (chunk == 4) {
        pairer.OnFrameComplete(hal::CameraId::kOmni, t, static_cast<uint32_t>(f),
                               static_cast<uint32_t>(writing));
        pairer.OnFrameComplete(hal::CameraId::kPersp, t, static_cast<uint32_t>(f),
                               static_cast<uint32_t>(writing));
        writing = next;
        t += 33333;
      }
      // The loop between chunks: the pipeline takes a pair and gives it back a little later;
      // a capture keeps the pair it took for a long time (tens of frames).
      const int r = static_cast<int>(rng() % 8);
      if (pipeline_slot >= 0 && r < 3) {
        book.Release(pipeline_slot);
        if (pipeline_slot == capture_slot) capture_slot = -1;
        pipeline_slot = -1;
      } else if (r < 6) {
        if (book.held_count() >= kMaxHeld) {
          ++o.refused_holds;
          continue;
        }
        hal::PairDecision d;
        if (!pairer.TakePair(t, d)) continue;
        ++o.pairs_served;
        const int slot = static_cast<int>(d.slot[0]);
        EXPECT_TRUE(book.Hold(slot));
        if (capture_slot < 0 && kMaxHeld > 1 && pipeline_slot < 0 && rng() % 4 == 0) {
          capture_slot = slot;  // the capture keeps it
          capture_left = 20 + static_cast<int>(rng() % 400);
        } else if (pipeline_slot < 0) {
          pipeline_slot = slot;
        } else {
          book.Release(slot);  // cannot happen in the loop; keep the model honest
        }
      }
      o.max_held = std::max(o.max_held, book.held_count());
    }
    if (capture_slot >= 0 && --capture_left == 0) {
      book.Release(capture_slot);
      capture_slot = -1;
    }
  }
  return o;
}

TEST(H7Slots, FiveSlotsKeepTwoHeldPairsFromTheDma) {
  for (uint32_t seed = 1; seed <= 20; ++seed) {
    const Outcome o = Simulate<5, 2>(seed, 3000);
    EXPECT_EQ(o.writes_into_held, 0) << "seed " << seed;
    EXPECT_EQ(o.writes_into_pending, 0) << "seed " << seed;
    EXPECT_EQ(o.max_held, 2) << "the model must reach two held pairs, seed " << seed;
    EXPECT_GT(o.pairs_served, 1000) << "seed " << seed;
  }
}

TEST(H7Slots, TheOldFourSlotsWereSafeForOneHeldPair) {
  const Outcome o = Simulate<4, 1>(7, 3000);
  EXPECT_EQ(o.writes_into_held, 0);
  EXPECT_EQ(o.writes_into_pending, 0);
  EXPECT_EQ(o.max_held, 1);
}

// Why four slots cannot hold two pairs: two held, the pending frame and the one being written
// leave nothing for the next frame (Free falls back to the slot being written).
TEST(H7Slots, FreeNeverReturnsAHeldOrPendingSlot) {
  SlotBook<5, 2> book;
  EXPECT_TRUE(book.Hold(0));
  EXPECT_TRUE(book.Hold(3));
  EXPECT_FALSE(book.Hold(1)) << "a third pair is refused";
  EXPECT_EQ(book.held_count(), 2);
  EXPECT_EQ(book.Free(/*pending=*/1, /*writing=*/2), 4);
  EXPECT_EQ(book.Free(/*pending=*/-1, /*writing=*/2), 1);
  book.Release(3);
  EXPECT_FALSE(book.IsHeld(3));
  EXPECT_EQ(book.Free(1, 2), 3);
  book.Release(9);  // not held: nothing changes
  EXPECT_EQ(book.held_count(), 1);
}

}  // namespace
}  // namespace bv::h7
