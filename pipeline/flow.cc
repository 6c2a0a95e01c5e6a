#include "pipeline/flow.h"

#include <algorithm>
#include <sstream>

#include <opencv2/video/tracking.hpp>

namespace autocal {

bool FlowOptions::Check(std::string* error) const {
  std::string nested;
  if (!features.Check(&nested)) {
    if (error) *error = "features." + nested;
    return false;
  }
  std::ostringstream why;
  if (window_px < 5 || window_px > 101 || window_px % 2 == 0) {
    why << "window_px must be odd and in [5, 101]";
  } else if (pyramid_levels < 0 || pyramid_levels > 8) {
    why << "pyramid_levels must be in [0, 8]";
  } else if (retry_levels < -1 || retry_levels > pyramid_levels) {
    why << "retry_levels must be in [-1, pyramid_levels]";
  } else if (max_iterations < 1) {
    why << "max_iterations must be at least 1";
  } else if (!(epsilon_px > 0)) {
    why << "epsilon_px must be positive";
  } else if (!(min_eigen >= 0)) {
    why << "min_eigen must not be negative";
  } else if (!(max_fb_error_px > 0)) {
    why << "max_fb_error_px must be positive";
  } else if (border_px < 0) {
    why << "border_px must not be negative";
  } else if (target_tracks < 1) {
    why << "target_tracks must be at least 1";
  } else if (history_frames < 2) {
    why << "history_frames must be at least 2";
  }
  if (why.str().empty()) return true;
  if (error) *error = why.str();
  return false;
}

const TrackPoint* Track::FramesAgo(int frames) const {
  if (frames < 0 || frames >= int(history.size())) return nullptr;
  return &history[history.size() - 1 - frames];
}

const TrackPoint* Track::At(int64_t t_ns) const {
  const auto it =
      std::lower_bound(history.begin(), history.end(), t_ns,
                       [](const TrackPoint& point, int64_t t) { return point.t_ns < t; });
  return it != history.end() && it->t_ns == t_ns ? &*it : nullptr;
}

FlowTracker::FlowTracker(const FlowOptions& options) : options_(options) {}

void FlowTracker::set_options(const FlowOptions& options) { options_ = options; }

void FlowTracker::ForwardBackward(const std::vector<cv::Mat>& pyramid,
                                  const std::vector<cv::Point2f>& start, int levels,
                                  std::vector<cv::Point2f>* end, std::vector<uchar>* found) const {
  found->assign(start.size(), 0);
  if (start.empty()) return;
  const cv::Size window(options_.window_px, options_.window_px);
  const cv::TermCriteria criteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS,
                                  options_.max_iterations, options_.epsilon_px);
  std::vector<uchar> status;
  // No matching errors: nothing uses them, and they cost a pass over each window.
  cv::calcOpticalFlowPyrLK(pyramid_, pyramid, start, *end, status, cv::noArray(), window, levels,
                           criteria, cv::OPTFLOW_USE_INITIAL_FLOW, options_.min_eigen);
  // Back from where the forward search ended, without a hint: a track that drifted onto
  // something else (an occluder, a repeated pattern) does not find its way home. Only the
  // tracks found forward: each search is independent of the others.
  std::vector<size_t> forward;
  std::vector<cv::Point2f> there;
  for (size_t i = 0; i < start.size(); ++i) {
    if (!status[i]) continue;
    forward.push_back(i);
    there.push_back((*end)[i]);
  }
  if (forward.empty()) return;
  std::vector<cv::Point2f> back;
  std::vector<uchar> back_status;
  cv::calcOpticalFlowPyrLK(pyramid, pyramid_, there, back, back_status, cv::noArray(), window,
                           levels, criteria, 0, options_.min_eigen);
  const double max_miss2 = options_.max_fb_error_px * options_.max_fb_error_px;
  for (size_t k = 0; k < forward.size(); ++k) {
    const cv::Point2f miss = back[k] - start[forward[k]];
    (*found)[forward[k]] = back_status[k] && miss.dot(miss) <= max_miss2;
  }
}

void FlowTracker::Advance(int64_t t_ns, const cv::Mat& gray) {
  CV_Assert(gray.type() == CV_8UC1);
  const cv::Size window(options_.window_px, options_.window_px);
  std::vector<cv::Mat> pyramid;
  // A copy, not the caller's pixels: the base level is the frame new corners come from.
  cv::buildOpticalFlowPyramid(gray, pyramid, window, options_.pyramid_levels, true,
                              cv::BORDER_REFLECT_101, cv::BORDER_CONSTANT, true);
  died_ = 0;
  if (pyramid_.empty() || pyramid_[0].size() != gray.size()) {
    died_ = static_cast<int>(tracks_.size());
    tracks_.clear();
  }
  if (!tracks_.empty()) {
    std::vector<cv::Point2f> start, guess;
    start.reserve(tracks_.size());
    guess.reserve(tracks_.size());
    for (const Track& track : tracks_) {
      start.push_back(track.current());
      const TrackPoint* before = options_.predict ? track.FramesAgo(1) : nullptr;
      guess.push_back(before ? 2 * track.current() - before->pixel : track.current());
    }
    std::vector<uchar> found;
    std::vector<cv::Point2f> end = guess;
    ForwardBackward(pyramid, start, options_.pyramid_levels, &end, &found);
    // A region that changes (an occluder coming in) spoils the coarse levels for every
    // track around it: the lost ones are searched again near where they were heading.
    if (options_.retry_levels >= 0) {
      std::vector<int> lost;
      std::vector<cv::Point2f> lost_start, lost_end;
      for (size_t i = 0; i < start.size(); ++i) {
        if (found[i]) continue;
        lost.push_back(int(i));
        lost_start.push_back(start[i]);
        lost_end.push_back(guess[i]);
      }
      std::vector<uchar> refound;
      ForwardBackward(pyramid, lost_start, options_.retry_levels, &lost_end, &refound);
      for (size_t k = 0; k < lost.size(); ++k) {
        found[lost[k]] = refound[k];
        end[lost[k]] = lost_end[k];
      }
    }
    const float border = static_cast<float>(options_.border_px);
    const cv::Rect_<float> inside(border, border, gray.cols - 1 - 2 * border,
                                  gray.rows - 1 - 2 * border);
    std::vector<Track> kept;
    kept.reserve(tracks_.size());
    for (size_t i = 0; i < tracks_.size(); ++i) {
      if (!found[i] || !inside.contains(end[i])) continue;
      Track& track = tracks_[i];
      track.history.push_back({t_ns, end[i]});
      if (int(track.history.size()) > options_.history_frames) {
        track.history.erase(track.history.begin(), track.history.end() - options_.history_frames);
      }
      ++track.age;
      kept.push_back(std::move(track));
    }
    died_ = static_cast<int>(tracks_.size() - kept.size());
    tracks_ = std::move(kept);
  }
  pyramid_ = std::move(pyramid);
  t_ns_ = t_ns;
}

int FlowTracker::Replenish() {
  const int missing = options_.target_tracks - static_cast<int>(tracks_.size());
  if (pyramid_.empty() || missing <= 0) return 0;
  std::vector<cv::Point2f> existing;
  existing.reserve(tracks_.size());
  for (const Track& track : tracks_) existing.push_back(track.current());
  const std::vector<cv::Point2f> corners =
      DetectCorners(pyramid_[0], options_.features, existing, missing);
  for (const cv::Point2f& corner : corners) {
    Track track;
    track.id = next_id_++;
    track.history.push_back({t_ns_, corner});
    tracks_.push_back(std::move(track));
  }
  return static_cast<int>(corners.size());
}

void FlowTracker::Update(int64_t t_ns, const cv::Mat& gray) {
  Advance(t_ns, gray);
  Replenish();
}

}  // namespace autocal
