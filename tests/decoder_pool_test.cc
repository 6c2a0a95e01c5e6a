// The books of a video's decoders: readers in order each keep their own decoder and
// never seek; a far jump takes a decoder never used, then the one used longest ago; a
// reader waits while every decoder is busy.
#include "devices/decoder_pool.h"

#include <atomic>
#include <chrono>
#include <thread>

#include <gtest/gtest.h>

namespace autocal {
namespace {

// Reads frame `index` through the pool as a decoder would: true when it had to seek
// (it stood neither there nor a few frames before).
bool Read(DecoderPool& pool, size_t index, size_t* slot = nullptr) {
  const DecoderPool::Lease lease = pool.Acquire(index);
  const bool seek = lease.next == DecoderPool::kUnknown || lease.next > index ||
                    index - lease.next > pool.max_frames_read_on();
  pool.Release(lease.slot, index + 1);
  if (slot) *slot = lease.slot;
  return seek;
}

TEST(DecoderPoolTest, ReadersInOrderKeepTheirOwnDecoder) {
  DecoderPool pool(3, 30);
  // The pipeline from the start, the display from frame 200, interleaved as their threads
  // would be: after each one's first read neither seeks.
  size_t pipeline_slot = 0, display_slot = 0;
  EXPECT_TRUE(Read(pool, 0, &pipeline_slot));
  EXPECT_TRUE(Read(pool, 200, &display_slot));
  EXPECT_NE(pipeline_slot, display_slot);
  int seeks = 0;
  for (size_t i = 1; i < 150; ++i) {
    size_t slot = 0;
    seeks += Read(pool, i, &slot);
    EXPECT_EQ(slot, pipeline_slot) << i;
    if (i % 3 == 0) {  // The display slower, and skipping frames.
      seeks += Read(pool, 200 + i, &slot);
      EXPECT_EQ(slot, display_slot) << i;
    }
  }
  EXPECT_EQ(seeks, 0);
}

TEST(DecoderPoolTest, AJumpTakesAnUnusedDecoderThenTheOldest) {
  DecoderPool pool(2, 30);
  size_t first = 0, second = 0, third = 0;
  Read(pool, 0, &first);
  Read(pool, 500, &second);
  EXPECT_NE(first, second);
  Read(pool, 1, &first);    // Slot `first` now the more recently used.
  Read(pool, 900, &third);  // Neither near: the one used longest ago.
  EXPECT_EQ(third, second);
  // Reading on a few frames rather than seeking, within the limit only.
  EXPECT_FALSE(Read(pool, 930, &third));
  EXPECT_EQ(third, second);
  EXPECT_TRUE(Read(pool, 962, &third));
}

TEST(DecoderPoolTest, AFailedDecoderSeeksNextTime) {
  DecoderPool pool(1, 30);
  const DecoderPool::Lease lease = pool.Acquire(5);
  pool.Release(lease.slot, DecoderPool::kUnknown);
  EXPECT_EQ(pool.Acquire(6).next, DecoderPool::kUnknown);
}

TEST(DecoderPoolTest, WaitsWhileEveryDecoderIsBusy) {
  DecoderPool pool(1, 30);
  const DecoderPool::Lease held = pool.Acquire(0);
  std::atomic<bool> got{false};
  std::thread other([&] {
    const DecoderPool::Lease lease = pool.Acquire(1);
    got = true;
    EXPECT_EQ(lease.next, 1u);  // Where the holder left it.
    pool.Release(lease.slot, 2);
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_FALSE(got);
  pool.Release(held.slot, 1);
  other.join();
  EXPECT_TRUE(got);
}

}  // namespace
}  // namespace autocal
