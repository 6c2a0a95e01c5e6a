// Box 4: corners spread over the image by grid cells, strongest first, around the points
// already tracked; scale-invariant keypoints that match across a known warp.
#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>

#include <gtest/gtest.h>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "devices/sim/simulator.h"
#include "pipeline/error.h"
#include "pipeline/features.h"

namespace autocal {
namespace {

// The green channel of a simulated office frame (textured floor, walls, posters).
cv::Mat OfficeFrame(const std::string& resolution = "320x240") {
  Scenario scenario = LoadScenario("office");
  ApplyScenarioOverride(&scenario, "resolution", resolution);
  ApplyScenarioOverride(&scenario, "seconds", "0.1");
  cv::Mat green;
  cv::extractChannel(MakeSimulatedSequence(scenario)->LoadFrame(0), green, 1);
  return green;
}

TEST(FeatureOptions, DefaultsAreValidAndFaultsAreNamed) {
  std::string error;
  EXPECT_TRUE(FeatureOptions().Check(&error)) << error;
  auto fails_on = [](auto change, const std::string& field) {
    FeatureOptions options;
    change(&options);
    std::string message;
    EXPECT_FALSE(options.Check(&message)) << field;
    EXPECT_NE(message.find(field), std::string::npos) << message;
  };
  fails_on([](FeatureOptions* o) { o->grid_columns = 0; }, "grid_columns");
  fails_on([](FeatureOptions* o) { o->grid_rows = 100; }, "grid_rows");
  fails_on([](FeatureOptions* o) { o->max_per_cell = 0; }, "max_per_cell");
  fails_on([](FeatureOptions* o) { o->fast_threshold = 0; }, "fast_threshold");
  fails_on([](FeatureOptions* o) { o->min_fast_threshold = 13; }, "min_fast_threshold");
  fails_on([](FeatureOptions* o) { o->min_distance_px = -1; }, "min_distance_px");
  fails_on([](FeatureOptions* o) { o->border_px = -1; }, "border_px");
  fails_on([](FeatureOptions* o) { o->max_keypoints = 0; }, "max_keypoints");
  fails_on([](FeatureOptions* o) { o->match_ratio = 1.5; }, "match_ratio");
}

TEST(DetectCorners, EveryCellGetsCornersAndNoneMoreThanItsShare) {
  const cv::Mat gray = OfficeFrame();
  const FeatureOptions options;
  const std::vector<cv::Point2f> corners = DetectCorners(gray, options);
  std::map<int, int> per_cell;
  for (const cv::Point2f& p : corners) {
    ++per_cell[GridCell(p, gray.size(), options)];
    EXPECT_GE(std::min(p.x, p.y), options.border_px);
    EXPECT_LT(p.x, gray.cols - options.border_px);
    EXPECT_LT(p.y, gray.rows - options.border_px);
  }
  EXPECT_EQ(int(per_cell.size()), options.grid_columns * options.grid_rows)
      << "cells without a corner";
  for (const auto& [cell, count] : per_cell) EXPECT_LE(count, options.max_per_cell) << cell;
  // Kept apart.
  for (size_t a = 0; a < corners.size(); ++a) {
    for (size_t b = a + 1; b < corners.size(); ++b) {
      ASSERT_GT(cv::norm(corners[a] - corners[b]), options.min_distance_px);
    }
  }
}

TEST(DetectCorners, StrongestFirstInEachCell) {
  const cv::Mat gray = OfficeFrame();
  FeatureOptions options;
  options.min_distance_px = 0.0;                        // Strength alone decides...
  options.min_fast_threshold = options.fast_threshold;  // ...at one threshold.
  options.max_per_cell = 3;
  const std::vector<cv::Point2f> corners = DetectCorners(gray, options);
  // Every FAST corner inside the border, by cell, strongest first.
  std::vector<cv::KeyPoint> all;
  cv::FAST(gray, all, options.fast_threshold, true);
  std::map<int, std::vector<float>> responses;
  for (const cv::KeyPoint& k : all) {
    if (std::min(k.pt.x, k.pt.y) < options.border_px || k.pt.x >= gray.cols - options.border_px ||
        k.pt.y >= gray.rows - options.border_px) {
      continue;
    }
    responses[GridCell(k.pt, gray.size(), options)].push_back(k.response);
  }
  std::map<int, std::vector<float>> chosen;
  for (const cv::Point2f& p : corners) {
    const auto k =
        std::find_if(all.begin(), all.end(), [&](const cv::KeyPoint& c) { return c.pt == p; });
    ASSERT_NE(k, all.end());
    chosen[GridCell(p, gray.size(), options)].push_back(k->response);
  }
  for (auto& [cell, r] : responses) {
    std::sort(r.rbegin(), r.rend());
    r.resize(std::min<size_t>(r.size(), 3));
    std::vector<float>& c = chosen[cell];
    std::sort(c.rbegin(), c.rend());
    EXPECT_EQ(c, r) << "cell " << cell;
  }
}

TEST(DetectCorners, AFaintCellIsSearchedAgainAtALowerThreshold) {
  cv::Mat gray = OfficeFrame().clone();
  FeatureOptions options;
  // Cell 9 (second row, second column) and a margin round it (the edge of the faint
  // patch has corners of its own) at a twelfth of its contrast.
  const cv::Rect cell(gray.cols / 8 - 8, gray.rows / 6 - 8, gray.cols / 8 + 16, gray.rows / 6 + 16);
  cv::Mat area = gray(cell);
  area.convertTo(area, CV_8U, 0.08, 0.92 * cv::mean(area)[0]);
  auto count_in_cell = [&](const FeatureOptions& o) {
    const std::vector<cv::Point2f> corners = DetectCorners(gray, o);
    return std::count_if(corners.begin(), corners.end(),
                         [&](const cv::Point2f& p) { return GridCell(p, gray.size(), o) == 9; });
  };
  EXPECT_GT(count_in_cell(options), 0);
  options.min_fast_threshold = options.fast_threshold;
  EXPECT_EQ(count_in_cell(options), 0) << "the cell must be too faint for fast_threshold";
}

TEST(DetectCorners, FillsOnlyWhereTracksAreMissing) {
  const cv::Mat gray = OfficeFrame();
  const FeatureOptions options;
  const std::vector<cv::Point2f> first = DetectCorners(gray, options);
  // Keep every corner except those of three cells, as if their tracks had died.
  const std::vector<int> emptied = {0, 13, 47};
  std::vector<cv::Point2f> kept;
  for (const cv::Point2f& p : first) {
    const int cell = GridCell(p, gray.size(), options);
    if (std::find(emptied.begin(), emptied.end(), cell) == emptied.end()) kept.push_back(p);
  }
  // Cells full of tracks take nothing new; new corners keep away from the tracks.
  const std::vector<cv::Point2f> refill = DetectCorners(gray, options, kept);
  ASSERT_FALSE(refill.empty());
  std::map<int, int> per_cell;
  for (const cv::Point2f& p : refill) {
    ++per_cell[GridCell(p, gray.size(), options)];
    for (const cv::Point2f& q : kept) ASSERT_GT(cv::norm(p - q), options.min_distance_px);
  }
  for (const auto& [cell, count] : per_cell) {
    const int held = int(std::count_if(kept.begin(), kept.end(), [&](const cv::Point2f& q) {
      return GridCell(q, gray.size(), options) == cell;
    }));
    EXPECT_LE(held + count, options.max_per_cell) << "cell " << cell;
  }
  for (int cell : emptied) EXPECT_GT(per_cell[cell], 0) << "emptied cell " << cell;
  // Asked for a few, the emptiest cells come first.
  const std::vector<cv::Point2f> three = DetectCorners(gray, options, kept, 3);
  ASSERT_EQ(three.size(), 3u);
  std::vector<int> cells;
  for (const cv::Point2f& p : three) cells.push_back(GridCell(p, gray.size(), options));
  std::sort(cells.begin(), cells.end());
  EXPECT_EQ(cells, emptied);
}

// Keypoints of an image and of its known warp match where the warp says.
void ExpectMatchesFollowTheWarp(DescriptorType type) {
  const cv::Mat gray = OfficeFrame("640x480");
  const cv::Mat warp = cv::getRotationMatrix2D({320, 240}, 12.0, 0.8);
  cv::Mat warped;
  cv::warpAffine(gray, warped, warp, gray.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
  FeatureOptions options;
  options.descriptor = type;
  const KeypointSet a = DetectKeypoints(gray, options);
  const KeypointSet b = DetectKeypoints(warped, options);
  EXPECT_LE(int(a.keypoints.size()), options.max_keypoints);
  EXPECT_EQ(a.descriptors.rows, int(a.keypoints.size()));
  const std::vector<cv::DMatch> matches = MatchKeypoints(a, b, options);
  int right = 0;
  for (const cv::DMatch& m : matches) {
    const cv::Point2f p = a.keypoints[m.queryIdx].pt;
    const cv::Point2f expected(
        float(warp.at<double>(0, 0) * p.x + warp.at<double>(0, 1) * p.y + warp.at<double>(0, 2)),
        float(warp.at<double>(1, 0) * p.x + warp.at<double>(1, 1) * p.y + warp.at<double>(1, 2)));
    right += cv::norm(b.keypoints[m.trainIdx].pt - expected) < 3.0;
  }
  EXPECT_GT(matches.size(), 100u);
  EXPECT_GT(right, 0.9 * matches.size()) << right << " of " << matches.size();
}

// The matches cv::BFMatcher gives: the two nearest forward, Lowe's ratio, the nearest
// backward for the cross-check.
std::vector<cv::DMatch> BruteForceMatches(const KeypointSet& a, const KeypointSet& b,
                                          const FeatureOptions& options) {
  cv::BFMatcher matcher(a.descriptors.depth() == CV_8U ? cv::NORM_HAMMING : cv::NORM_L2);
  std::vector<std::vector<cv::DMatch>> forward;
  std::vector<cv::DMatch> backward;
  matcher.knnMatch(a.descriptors, b.descriptors, forward, 2);
  matcher.match(b.descriptors, a.descriptors, backward);
  std::vector<cv::DMatch> matches;
  for (const std::vector<cv::DMatch>& candidates : forward) {
    const cv::DMatch& best = candidates[0];
    if (candidates.size() > 1 && best.distance >= options.match_ratio * candidates[1].distance) {
      continue;
    }
    if (backward[best.trainIdx].trainIdx == best.queryIdx) matches.push_back(best);
  }
  return matches;
}

void ExpectSameMatches(const KeypointSet& a, const KeypointSet& b, const FeatureOptions& options,
                       size_t at_least) {
  const std::vector<cv::DMatch> ours = MatchKeypoints(a, b, options);
  const std::vector<cv::DMatch> opencv = BruteForceMatches(a, b, options);
  ASSERT_EQ(ours.size(), opencv.size());
  for (size_t k = 0; k < ours.size(); ++k) {
    EXPECT_EQ(ours[k].queryIdx, opencv[k].queryIdx) << k;
    EXPECT_EQ(ours[k].trainIdx, opencv[k].trainIdx) << k;
    EXPECT_EQ(ours[k].distance, opencv[k].distance) << k;
  }
  EXPECT_GE(ours.size(), at_least);
}

TEST(Keypoints, MatchesAreBruteForceMatchersToTheLastTie) {
  const cv::Mat gray = OfficeFrame("640x480");
  const cv::Mat warp = cv::getRotationMatrix2D({320, 240}, 7.0, 0.9);
  cv::Mat warped;
  cv::warpAffine(gray, warped, warp, gray.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
  for (const DescriptorType type : {DescriptorType::kOrb, DescriptorType::kSift}) {
    FeatureOptions options;
    options.descriptor = type;
    ExpectSameMatches(DetectKeypoints(gray, options), DetectKeypoints(warped, options), options,
                      50);
  }
  // Short binary descriptors, 1 to 13 bytes (a tail beyond whole 64-bit words), and ORB's
  // 32 bytes with rows past a multiple of four (the wide path's last rows): half of b's
  // rows are a's with a bit flipped, two from each (ties), the rest random; one candidate
  // alone.
  cv::RNG rng(7);
  for (const auto& [rows_a, rows_b, bytes] : {std::tuple{300, 200, 3},
                                              {40, 1, 5},
                                              {64, 48, 8},
                                              {120, 90, 13},
                                              {50, 60, 1},
                                              {70, 35, 32},
                                              {9, 3, 32}}) {
    KeypointSet a, b;
    a.descriptors.create(rows_a, bytes, CV_8U);
    b.descriptors.create(rows_b, bytes, CV_8U);
    rng.fill(a.descriptors, cv::RNG::UNIFORM, 0, 256);
    rng.fill(b.descriptors, cv::RNG::UNIFORM, 0, 256);
    for (int j = 0; j < rows_b / 2; ++j) {
      a.descriptors.row((7 * (j / 2)) % rows_a).copyTo(b.descriptors.row(j));
      b.descriptors.at<uchar>(j, rng.uniform(0, bytes)) ^= uchar(1 << rng.uniform(0, 8));
    }
    ExpectSameMatches(a, b, FeatureOptions(), 1);
  }
  KeypointSet same;
  same.descriptors = cv::Mat(20, 32, CV_8U, cv::Scalar(0x5a));
  EXPECT_TRUE(MatchKeypoints(same, same, FeatureOptions()).empty());
}

TEST(Keypoints, OrbMatchesFollowARotationAndScale) {
  ExpectMatchesFollowTheWarp(DescriptorType::kOrb);
}

TEST(Keypoints, SiftMatchesFollowARotationAndScale) {
  ExpectMatchesFollowTheWarp(DescriptorType::kSift);
}

TEST(Keypoints, DifferentDescriptorsDoNotMatch) {
  const cv::Mat gray = OfficeFrame();
  FeatureOptions orb, sift;
  orb.descriptor = DescriptorType::kOrb;
  sift.descriptor = DescriptorType::kSift;
  EXPECT_THROW(MatchKeypoints(DetectKeypoints(gray, orb), DetectKeypoints(gray, sift), orb), Error);
  EXPECT_TRUE(MatchKeypoints(KeypointSet(), DetectKeypoints(gray, orb), orb).empty());
}

}  // namespace
}  // namespace autocal
