#include "devices/decoder_pool.h"

namespace autocal {

DecoderPool::DecoderPool(size_t max_decoders, size_t max_frames_read_on)
    : max_frames_read_on_(max_frames_read_on), slots_(max_decoders) {}

DecoderPool::Lease DecoderPool::Acquire(size_t index) {
  std::unique_lock lock(mutex_);
  size_t chosen = kUnknown;
  freed_.wait(lock, [&] {
    size_t unused = kUnknown, oldest = kUnknown;
    for (size_t i = 0; i < slots_.size(); ++i) {
      const Slot& slot = slots_[i];
      if (slot.busy) continue;
      if (slot.next != kUnknown && slot.next <= index && index - slot.next <= max_frames_read_on_ &&
          (chosen == kUnknown || slot.next > slots_[chosen].next)) {
        chosen = i;
      }
      if (!slot.used && unused == kUnknown) unused = i;
      if (slot.used && (oldest == kUnknown || slot.last_used < slots_[oldest].last_used)) {
        oldest = i;
      }
    }
    if (chosen == kUnknown) chosen = unused != kUnknown ? unused : oldest;
    return chosen != kUnknown;
  });
  Slot& slot = slots_[chosen];
  slot.busy = true;
  slot.used = true;
  return {chosen, slot.next};
}

void DecoderPool::Release(size_t slot, size_t next) {
  {
    const std::lock_guard lock(mutex_);
    slots_[slot].next = next;
    slots_[slot].busy = false;
    slots_[slot].used = true;
    slots_[slot].last_used = ++uses_;
  }
  freed_.notify_one();
}

}  // namespace autocal
