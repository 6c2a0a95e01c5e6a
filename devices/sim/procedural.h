// Drawing helpers for the procedural textures of the simulated scenes. A Canvas is a
// texture under construction addressed in metres of the plane (a to the right, b down),
// so that scene code reads like a floor plan. Everything is drawn from a cv::RNG, so the
// same seed gives the same texture.
#pragma once

#include <string>

#include <opencv2/core.hpp>

namespace autocal {

class Canvas {
 public:
  Canvas(double width_m, double height_m, double texel_m, const cv::Scalar& base_bgr);

  cv::Mat& image() { return image_; }
  const cv::Mat& image() const { return image_; }
  double texel_m() const { return texel_m_; }
  double width_m() const { return image_.cols * texel_m_; }
  double height_m() const { return image_.rows * texel_m_; }

  int Px(double metres) const;
  cv::Point P(double a, double b) const;
  cv::Rect R(double a, double b, double w, double h) const;

  // Copies `other` (same texel size) with its top-left corner at (a, b), clipped.
  void Paste(const Canvas& other, double a, double b);
  void Fill(double a, double b, double w, double h, const cv::Scalar& colour);
  void Outline(double a, double b, double w, double h, double thickness_m,
               const cv::Scalar& colour);
  void Line(double a0, double b0, double a1, double b1, double thickness_m,
            const cv::Scalar& colour);
  void Disc(double a, double b, double radius_m, const cv::Scalar& colour);
  void Ring(double a, double b, double radius_m, double thickness_m, const cv::Scalar& colour);
  // Text whose capital letters are `height_m` tall, starting at (a, b) = baseline left.
  void Text(const std::string& text, double a, double b, double height_m, const cv::Scalar& colour);

  // Smooth value noise (cells of `cell_m`, a few octaves) added to every channel with the
  // given amplitude in grey levels, optionally tinted. `seamless` makes it tile.
  void Mottle(double cell_m, double amplitude, cv::RNG& rng, bool seamless = false,
              const cv::Vec3f& tint = {1.f, 1.f, 1.f});
  // Independent per-texel grey noise of the given amplitude.
  void Grain(double amplitude, cv::RNG& rng);
  // Random small flecks of the given colour covering `fraction` of the area, blended over
  // the canvas with `opacity` (0: invisible; the generator is drawn from the same either way).
  void Flecks(double size_m, double fraction, const cv::Scalar& colour, cv::RNG& rng,
              double opacity = 1.0);

 private:
  cv::Mat image_;  // CV_8UC3.
  double texel_m_;
};

// Random pronounceable-looking word of `length` capital letters.
std::string RandomWord(cv::RNG& rng, int length);
// A random saturated or muted colour.
cv::Scalar RandomColour(cv::RNG& rng, int min_value = 40, int max_value = 230);

// Wall furniture, drawn at (a, b) top-left with size (w, h), metres.
void DrawPoster(Canvas* canvas, double a, double b, double w, double h, cv::RNG& rng);
void DrawPicture(Canvas* canvas, double a, double b, double w, double h, cv::RNG& rng);
void DrawDoor(Canvas* canvas, double a, double b, double w, double h, bool vision_panel,
              cv::RNG& rng);
void DrawWindow(Canvas* canvas, double a, double b, double w, double h, int panes_x, int panes_y,
                cv::RNG& rng);
void DrawWhiteboard(Canvas* canvas, double a, double b, double w, double h, cv::RNG& rng);
void DrawNoticeBoard(Canvas* canvas, double a, double b, double w, double h, cv::RNG& rng);
void DrawBookshelf(Canvas* canvas, double a, double b, double w, double h, cv::RNG& rng);
void DrawClock(Canvas* canvas, double a, double b, double radius_m, cv::RNG& rng);
void DrawRadiator(Canvas* canvas, double a, double b, double w, double h);
void DrawSocket(Canvas* canvas, double a, double b);
void DrawBarcodeLabel(Canvas* canvas, double a, double b, double w, double h, cv::RNG& rng);
void DrawKeyboard(Canvas* canvas, double a, double b, double w, double h);
void DrawPaper(Canvas* canvas, double a, double b, double w, double h, cv::RNG& rng);

}  // namespace autocal
