#include "devices/in_memory_sequence.h"

#include <utility>

namespace autocal {

InMemorySequence::InMemorySequence(std::unique_ptr<Sequence> source) : source_(std::move(source)) {
  frames_.resize(source_->frame_count());
  // The renderer and the decoders already spread each frame over every core.
  for (size_t i = 0; i < frames_.size(); ++i) frames_[i] = source_->LoadFrame(i);
}

double InMemorySequence::MegabytesOf(const Sequence& sequence) {
  return double(sequence.frame_count()) * sequence.session().width * sequence.session().height * 3 /
         (1024.0 * 1024.0);
}

double InMemorySequence::megabytes() const {
  double bytes = 0.0;
  for (const cv::Mat& frame : frames_) bytes += double(frame.total() * frame.elemSize());
  return bytes / (1024.0 * 1024.0);
}

}  // namespace autocal
