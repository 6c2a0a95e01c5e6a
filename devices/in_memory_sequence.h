// A sequence with every frame read once and kept in memory: LoadFrame then costs nothing,
// for runs that go over the same recording again and again (`autocal bench`, `autocal
// readout`).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "devices/sequence.h"

namespace autocal {

class InMemorySequence : public Sequence {
 public:
  // Reads every frame of `source` now. Throws Error as its LoadFrame does.
  explicit InMemorySequence(std::unique_ptr<Sequence> source);

  // What the frames of `sequence` take in memory, read as 8-bit BGR.
  static double MegabytesOf(const Sequence& sequence);

  std::string Describe() const override { return source_->Describe(); }
  const SessionInfo& session() const override { return source_->session(); }
  size_t frame_count() const override { return frames_.size(); }
  int64_t frame_time_ns(size_t index) const override { return source_->frame_time_ns(index); }
  cv::Mat LoadFrame(size_t index) const override { return frames_.at(index); }
  const std::vector<AccelSample>& accel() const override { return source_->accel(); }
  const std::vector<std::string>& warnings() const override { return source_->warnings(); }
  const std::vector<GroundTruthFrame>* ground_truth() const override {
    return source_->ground_truth();
  }
  double megabytes() const;

 private:
  std::unique_ptr<Sequence> source_;
  std::vector<cv::Mat> frames_;
};

}  // namespace autocal
