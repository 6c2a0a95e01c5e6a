#include "pipeline/image_quality.h"

#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "devices/sim/simulator.h"

namespace autocal {
namespace {

// A smooth ramp: no texture for the noise estimator to mistake for noise.
cv::Mat Ramp() {
  cv::Mat image(240, 320, CV_8UC1);
  for (int y = 0; y < image.rows; ++y) {
    for (int x = 0; x < image.cols; ++x) image.at<uint8_t>(y, x) = uint8_t(40 + x / 2 + y / 4);
  }
  return image;
}

TEST(ImageQuality, EstimatesTheNoiseOfASmoothImage) {
  cv::Mat noisy = Ramp();
  cv::Mat noise(noisy.size(), CV_16SC1);
  cv::randn(noise, 0, 8.0);
  cv::Mat sum;
  cv::add(noisy, noise, sum, cv::noArray(), CV_8UC1);
  EXPECT_LT(MeasureImageQuality(Ramp()).noise_grey, 0.5);
  EXPECT_NEAR(MeasureImageQuality(sum).noise_grey, 8.0, 0.8);
}

TEST(ImageQuality, BlurAndContrastFollowTheImage) {
  cv::Mat cells(60, 80, CV_8UC1);
  cv::randu(cells, 0, 256);
  cv::Mat texture;  // Squares of 4 pixels: sharp steps between random levels.
  cv::resize(cells, texture, cv::Size(320, 240), 0, 0, cv::INTER_NEAREST);
  cv::Mat blurred;
  cv::GaussianBlur(texture, blurred, cv::Size(), 2.5);
  const ImageQuality sharp = MeasureImageQuality(texture);
  const ImageQuality soft = MeasureImageQuality(blurred);
  EXPECT_GT(soft.blur, sharp.blur + 0.2);
  // Uniform levels 0-255: the 5th to 95th percentile span about 230.
  EXPECT_NEAR(sharp.contrast_grey, 230.0, 8.0);
  cv::Mat faded;
  texture.convertTo(faded, CV_8UC1, 0.5, 64);
  EXPECT_NEAR(MeasureImageQuality(faded).contrast_grey, 115.0, 5.0);
}

// The simulator's transient walk: fog over 8-11 s, a noise burst over 11-12 s. Every
// frame in them is found degraded, and no frame outside them. At 640x480 the fog's blur
// moves the blur measure less than at 320x240 (0.05 against 0.09 on its first frame).
void ExpectFindsTheBurst(const std::string& lens, const std::string& resolution) {
  const Scenario scenario =
      ParseScenarioSpec("transient,seconds=14,lens=" + lens + ",resolution=" + resolution);
  const std::unique_ptr<Sequence> sequence = MakeSimulatedSequence(scenario);
  ImageQualityGate gate;
  int in_burst = 0, caught = 0, outside = 0, false_alarms = 0;
  for (size_t i = 0; i < sequence->frame_count(); ++i) {
    const int64_t t_ns = sequence->frame_time_ns(i);
    const double t = scenario.SecondsAt(t_ns);
    bool disturbed = false;
    for (const Disturbance& disturbance : scenario.disturbances) {
      disturbed |= t >= disturbance.start.Seconds(scenario.seconds) &&
                   t < disturbance.end.Seconds(scenario.seconds);
    }
    const ImageQuality quality = MeasureImageQuality(sequence->LoadFrame(i));
    const std::optional<std::string> degraded = gate.Judge(t_ns, quality);
    if (i % 15 == 0 || bool(degraded) != disturbed) {
      std::printf("%5.2f s noise %5.2f blur %.3f contrast %5.1f %s%s\n", t, quality.noise_grey,
                  quality.blur, quality.contrast_grey, disturbed ? "[burst] " : "",
                  degraded ? degraded->c_str() : "");
    }
    (disturbed ? in_burst : outside) += 1;
    if (disturbed && degraded) ++caught;
    if (!disturbed && degraded) ++false_alarms;
  }
  ASSERT_GT(in_burst, 0);
  EXPECT_EQ(caught, in_burst) << "every degraded frame caught";
  EXPECT_EQ(false_alarms, 0) << "of " << outside << " frames outside the burst";
}

TEST(ImageQuality, GateFindsFogAndNoiseOnTessar640x480) { ExpectFindsTheBurst("tessar", "640x480"); }
TEST(ImageQuality, GateFindsFogAndNoiseOnSonnar320x240) { ExpectFindsTheBurst("sonnar", "320x240"); }

TEST(ImageQuality, ALastingChangeBecomesTheUsual) {
  ImageQualityOptions options;
  options.accept_as_usual_s = 1.0;
  ImageQualityGate gate(options);
  ImageQuality usual{2.0, 0.3, 200.0}, dim{2.0, 0.3, 60.0};
  int64_t t = 0;
  const int64_t frame = 33'333'333;
  for (int i = 0; i < 30; ++i, t += frame) EXPECT_FALSE(gate.Judge(t, usual));
  const std::optional<std::string> first = gate.Judge(t, dim);
  ASSERT_TRUE(first);
  EXPECT_NE(first->find("low contrast"), std::string::npos) << *first;
  int degraded = 1;
  for (int i = 0; i < 60; ++i) {
    t += frame;
    degraded += gate.Judge(t, dim) ? 1 : 0;
  }
  EXPECT_EQ(degraded, 31) << "degraded for a second, then the usual";
}

}  // namespace
}  // namespace autocal
