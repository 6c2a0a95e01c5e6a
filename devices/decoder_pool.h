// Which of a few decoders of one video reads a frame (devices/dataset_readers.cc). Each
// reader of a sequence (the pipeline in order, the workbench's display at its own place)
// should keep a decoder of its own: a seek decodes from the keyframe before, which in a
// camera's H.264 can be seconds of frames, while a decoder already there or a few frames
// before reads on. The pool only keeps the books; the caller owns the decoders.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <mutex>
#include <vector>

namespace autocal {

class DecoderPool {
 public:
  // Where a decoder stands: the frame its next read gives.
  static constexpr size_t kUnknown = std::numeric_limits<size_t>::max();  // New, or failed.

  struct Lease {
    size_t slot = 0;         // Which decoder, in [0, max_decoders).
    size_t next = kUnknown;  // The frame its next read gives.
  };

  // `max_frames_read_on`: a decoder at most this many frames before the one asked for
  // reads on to it rather than seeking.
  DecoderPool(size_t max_decoders, size_t max_frames_read_on);

  // An idle decoder for frame `index`: the one nearest before it within
  // max_frames_read_on, else a decoder never used while there are some, else the one
  // used longest ago. Waits while every decoder is busy.
  Lease Acquire(size_t index);
  // The decoder is idle again (or, for one never acquired, opened by the caller) and its
  // next read gives frame `next` (kUnknown after a failure).
  void Release(size_t slot, size_t next);

  size_t max_frames_read_on() const { return max_frames_read_on_; }

 private:
  struct Slot {
    size_t next = kUnknown;
    bool busy = false;
    bool used = false;
    uint64_t last_used = 0;
  };

  const size_t max_frames_read_on_;
  std::mutex mutex_;
  std::condition_variable freed_;
  std::vector<Slot> slots_;
  uint64_t uses_ = 0;
};

}  // namespace autocal
