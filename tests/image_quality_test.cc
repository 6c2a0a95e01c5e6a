#include "pipeline/image_quality.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "devices/sim/simulator.h"
#include "pipeline/flow.h"
#include "tests/test_util.h"

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

// The measures as OpenCV's own filters give them, on a float copy of the image.
ImageQuality ReferenceQuality(const cv::Mat& image) {
  cv::Mat grey8, grey;
  cv::cvtColor(image, grey8, cv::COLOR_BGR2GRAY);
  grey8.convertTo(grey, CV_32F);
  const cv::Mat mask = (cv::Mat_<float>(3, 3) << 1, -2, 1, -2, 4, -2, 1, -2, 1);
  cv::Mat response;
  cv::filter2D(grey, response, CV_32F, mask);
  const cv::Rect inner(1, 1, grey.cols - 2, grey.rows - 2);
  ImageQuality quality;
  quality.noise_grey = std::sqrt(M_PI / 2.0) * cv::norm(response(inner), cv::NORM_L1) /
                       (6.0 * inner.area());
  for (int axis = 0; axis < 2; ++axis) {
    cv::Mat blurred;
    cv::blur(grey, blurred, axis == 0 ? cv::Size(9, 1) : cv::Size(1, 9));
    const cv::Rect later = axis == 0 ? cv::Rect(1, 0, grey.cols - 1, grey.rows)
                                     : cv::Rect(0, 1, grey.cols, grey.rows - 1);
    const cv::Rect earlier = axis == 0 ? cv::Rect(0, 0, grey.cols - 1, grey.rows)
                                       : cv::Rect(0, 0, grey.cols, grey.rows - 1);
    const cv::Mat sharp_step = cv::abs(grey(later) - grey(earlier));
    const cv::Mat blurred_step = cv::abs(blurred(later) - blurred(earlier));
    const double total = cv::sum(sharp_step)[0];
    const double lost = cv::sum(cv::max(sharp_step - blurred_step, 0.0))[0];
    quality.blur = std::max(quality.blur, total > 0 ? (total - lost) / total : 1.0);
  }
  std::vector<uint8_t> levels(grey8.begin<uint8_t>(), grey8.end<uint8_t>());
  std::sort(levels.begin(), levels.end());
  // The first level with at least 5% (95%) of the pixels at or below it.
  const auto percentile = [&](double p) {
    return levels[size_t(std::ceil(p * double(levels.size()))) - 1];
  };
  quality.contrast_grey = double(percentile(0.95) - percentile(0.05));
  return quality;
}

// The one-pass integer measures agree with OpenCV's filters: on simulated frames, on
// random colour images, and on images smaller than the blur's 9-pixel box (where its
// border reflects more than once).
TEST(ImageQuality, AgreesWithOpenCvFilters) {
  std::vector<cv::Mat> images;
  const auto sequence = MakeSimulatedSequence(ParseScenarioSpec("transient,seconds=12"));
  for (size_t i : {0, 250, 340}) images.push_back(sequence->LoadFrame(i));  // Clear, fog, noise.
  cv::RNG rng(7);
  for (const cv::Size size : {cv::Size(97, 61), cv::Size(7, 5), cv::Size(3, 12)}) {
    cv::Mat random(size, CV_8UC3);
    rng.fill(random, cv::RNG::UNIFORM, 0, 256);
    images.push_back(random);
  }
  for (const cv::Mat& image : images) {
    SCOPED_TRACE(std::to_string(image.cols) + "x" + std::to_string(image.rows));
    const ImageQuality fast = MeasureImageQuality(image);
    const ImageQuality reference = ReferenceQuality(image);
    EXPECT_NEAR(fast.noise_grey, reference.noise_grey, 1e-9 * reference.noise_grey);
    EXPECT_NEAR(fast.blur, reference.blur, 1e-5);
    EXPECT_EQ(fast.contrast_grey, reference.contrast_grey);
  }
}

// Whether one of the scenario's disturbances (fog, a noise burst) is on at `t_ns`.
bool Disturbed(const Scenario& scenario, int64_t t_ns) {
  const double t = scenario.SecondsAt(t_ns);
  for (const Disturbance& disturbance : scenario.disturbances) {
    if (t >= disturbance.start.Seconds(scenario.seconds) &&
        t < disturbance.end.Seconds(scenario.seconds)) {
      return true;
    }
  }
  return false;
}

// How a gate judged a walk with the simulator's disturbances.
struct GateCounts {
  int in_burst = 0, caught = 0, outside = 0, false_alarms = 0;
  // Where the image moved slower than the gate takes for moving (motion_blur_speed_px).
  int in_burst_slow = 0, caught_slow = 0;
};

// Judges every frame of a walk twice: as at rest (no image speed given) and as the pipeline
// does, with the image's speed from tracks followed over the frames.
std::pair<GateCounts, GateCounts> JudgeWalk(const Scenario& scenario) {
  const std::unique_ptr<Sequence> sequence = MakeSimulatedSequence(scenario);
  ImageQualityGate at_rest, moving;
  GateCounts rest_counts, moving_counts;
  FlowTracker tracker;
  cv::Mat grey;
  for (size_t i = 0; i < sequence->frame_count(); ++i) {
    const int64_t t_ns = sequence->frame_time_ns(i);
    const bool disturbed = Disturbed(scenario, t_ns);
    const cv::Mat frame = sequence->LoadFrame(i);
    cv::cvtColor(frame, grey, cv::COLOR_BGR2GRAY);
    tracker.Update(t_ns, grey);
    const std::optional<double> speed = ImageSpeedPx(tracker.tracks());
    const ImageQuality quality = MeasureImageQuality(frame);
    for (auto [gate, counts] : {std::pair{&at_rest, &rest_counts}, {&moving, &moving_counts}}) {
      const std::optional<std::string> degraded =
          gate == &at_rest ? gate->Judge(t_ns, quality) : gate->Judge(t_ns, quality, speed);
      if (i % 15 == 0 || bool(degraded) != disturbed) {
        std::printf("%s %5.2f s speed %5.2f px noise %5.2f blur %.3f contrast %5.1f %s%s\n",
                    gate == &at_rest ? "at rest" : "moving ", scenario.SecondsAt(t_ns),
                    speed.value_or(-1.0), quality.noise_grey, quality.blur, quality.contrast_grey,
                    disturbed ? "[burst] " : "", degraded ? degraded->c_str() : "");
      }
      (disturbed ? counts->in_burst : counts->outside) += 1;
      if (disturbed && degraded) ++counts->caught;
      if (disturbed && speed.value_or(0.0) < ImageQualityOptions{}.motion_blur_speed_px) {
        ++counts->in_burst_slow;
        counts->caught_slow += bool(degraded);
      }
      if (!disturbed && degraded) ++counts->false_alarms;
    }
  }
  return {rest_counts, moving_counts};
}

// The simulator's transient walk: fog over 8-11 s, a noise burst over 11-12 s. Every
// frame in them is found degraded, and no frame outside them, whether the gate is told
// how fast the image moves or not. At 640x480 the fog's blur moves the blur measure less
// than at 320x240 (0.05 against 0.09 on its first frame).
void ExpectFindsTheBurst(const std::string& lens, const std::string& resolution) {
  const auto [at_rest, moving] = JudgeWalk(
      ParseScenarioSpec("transient,seconds=14,lens=" + lens + ",resolution=" + resolution));
  for (const GateCounts& counts : {at_rest, moving}) {
    ASSERT_GT(counts.in_burst, 0);
    EXPECT_EQ(counts.caught, counts.in_burst) << "every degraded frame caught";
    EXPECT_EQ(counts.false_alarms, 0) << "of " << counts.outside << " frames outside the burst";
  }
}

TEST(ImageQuality, GateFindsFogAndNoiseOnTessar640x480) { ExpectFindsTheBurst("tessar", "640x480"); }
TEST(ImageQuality, GateFindsFogAndNoiseOnSonnar320x240) { ExpectFindsTheBurst("sonnar", "320x240"); }

// A 20 ms exposure smears the office walk's turns by up to 9 px at 320x240: blurrier and
// less noisy, as fog is, but no fault of the camera. Told how fast the image moves, the
// gate takes it for what it is (no frame of the walk called degraded), and still finds fog
// coming as the next turn starts and a noise burst after it; as at rest it would call the
// turns fogged or blurred. Fog in the turn itself (3.8-7.7 px a frame) shows only as lost
// contrast, which alone is no fog: those frames pass.
TEST(ImageQuality, MotionBlurIsNotFog) {
  Scenario scenario = ParseScenarioSpec("transient,seconds=9,resolution=320x240,exposure_ms=20");
  ASSERT_EQ(scenario.disturbances.size(), 2u);
  scenario.disturbances[0].start.value = 6.5;
  scenario.disturbances[0].end.value = 8.0;
  scenario.disturbances[1].start.value = 8.0;
  scenario.disturbances[1].end.value = 8.5;
  const auto [at_rest, moving] = JudgeWalk(scenario);
  EXPECT_EQ(moving.false_alarms, 0) << "of " << moving.outside << " frames outside the burst";
  ASSERT_GT(moving.in_burst_slow, 8);
  EXPECT_EQ(moving.caught_slow, moving.in_burst_slow) << "fog and noise where the image is slow";
  EXPECT_GT(at_rest.false_alarms, 10) << "of " << at_rest.outside;
}

// The gate over a walk after H.264 (libx264's defaults, as a camera's recording would be):
// frames marked degraded, and those marked among the disturbed ones.
struct Marked {
  int frames = 0, degraded = 0, disturbed = 0, degraded_disturbed = 0;
};
Marked JudgeCompressed(const std::string& spec) {
  const Scenario scenario = ParseScenarioSpec(spec);
  const std::unique_ptr<Sequence> sequence = MakeSimulatedSequence(scenario);
  test::TempDir tmp;
  const std::string path = (tmp.path() / "walk.mp4").string();
  {
    const cv::Mat first = sequence->LoadFrame(0);
    cv::VideoWriter writer(path, cv::VideoWriter::fourcc('a', 'v', 'c', '1'),
                           scenario.fps, first.size());
    EXPECT_TRUE(writer.isOpened()) << "no H.264 encoder in OpenCV's FFmpeg";
    for (size_t i = 0; i < sequence->frame_count(); ++i) writer.write(sequence->LoadFrame(i));
  }
  cv::VideoCapture capture(path);
  ImageQualityGate gate;
  Marked marked;
  cv::Mat frame;
  for (size_t i = 0; i < sequence->frame_count() && capture.read(frame); ++i) {
    const int64_t t_ns = sequence->frame_time_ns(i);
    const bool disturbed = Disturbed(scenario, t_ns);
    const bool degraded = gate.Judge(t_ns, MeasureImageQuality(frame)).has_value();
    ++marked.frames;
    marked.degraded += degraded;
    marked.disturbed += disturbed;
    marked.degraded_disturbed += degraded && disturbed;
  }
  return marked;
}

// The encoder quantizes harder while the camera turns fast: the image blurs a little and
// the measured noise halves (office walk at 640x480, 3.5-4.5 s in). That is no fog.
TEST(ImageQuality, VideoCompressionIsNotFog) {
  const Marked marked = JudgeCompressed("office,seconds=5,resolution=640x480");
  EXPECT_EQ(marked.frames, 150);
  EXPECT_EQ(marked.degraded, 0);
}

// Fog and the noise burst are still caught through the encoder, every frame.
TEST(ImageQuality, GateFindsFogAndNoiseThroughVideoCompression) {
  const Marked marked = JudgeCompressed("transient,seconds=14,lens=sonnar,resolution=320x240");
  EXPECT_EQ(marked.frames, 420);
  EXPECT_GT(marked.disturbed, 100);
  EXPECT_EQ(marked.degraded_disturbed, marked.disturbed);
  EXPECT_EQ(marked.degraded, marked.disturbed);
}

// Worked by hand: a frame is judged against the good frames that moved about as fast as it.
TEST(ImageQuality, MovingFramesAreJudgedAgainstFramesMovingAsFast) {
  ImageQualityGate gate;
  const ImageQuality still{2.0, 0.20, 120.0}, smeared{1.4, 0.35, 118.0};
  int64_t t = 0;
  const int64_t frame = 33'333'333;
  for (int i = 0; i < 20; ++i, t += frame) EXPECT_FALSE(gate.Judge(t, still, 0.5));
  // No frame has moved as fast yet: smeared is not blurred alone (0.15 over the usual).
  EXPECT_FALSE(gate.Judge(t, smeared, 8.0));
  for (int i = 0; i < 10; ++i) EXPECT_FALSE(gate.Judge(t += frame, smeared, 8.0 + 0.1 * i));
  // Now there are: 0.15 over them is blurred, and says how fast the image moved.
  const std::optional<std::string> blurrier = gate.Judge(t += frame, {1.4, 0.50, 118.0}, 6.0);
  ASSERT_TRUE(blurrier);
  EXPECT_EQ(*blurrier,
            "image degraded: blurred (0.50, usually 0.35, the image moving 6.00 px a frame)");
  // Fog while moving: faded and blurred beyond the frames moving as fast.
  const std::optional<std::string> fogged = gate.Judge(t += frame, {1.3, 0.42, 70.0}, 8.0);
  ASSERT_TRUE(fogged);
  EXPECT_EQ(fogged->rfind("image degraded: fogged", 0), 0u) << *fogged;
  // A still frame as smeared is compared with the still ones: blurrier and smoother.
  const std::optional<std::string> defocused = gate.Judge(t += frame, smeared, 0.5);
  ASSERT_TRUE(defocused);
  EXPECT_EQ(*defocused,
            "image degraded: fogged (blur 0.35, usually 0.20; contrast 118.00 grey "
            "levels, usually 120.00; noise 1.40, usually 2.00)");
  // And with no speed given, the smeared frame is judged as at rest.
  EXPECT_TRUE(gate.Judge(t += frame, smeared));
  EXPECT_FALSE(gate.Judge(t += frame, smeared, 8.0));
}

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
