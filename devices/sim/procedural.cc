#include "devices/sim/procedural.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

namespace autocal {
namespace {

// Value noise of `size` with cells of `cell_px` texels, in [-1, 1]. Seamless noise wraps
// the random grid before interpolating, so the left edge continues the right one.
cv::Mat ValueNoise(cv::Size size, double cell_px, cv::RNG& rng, bool seamless) {
  const int gw = std::max(1, static_cast<int>(std::lround(size.width / cell_px)));
  const int gh = std::max(1, static_cast<int>(std::lround(size.height / cell_px)));
  cv::Mat grid(gh, gw, CV_32F);
  rng.fill(grid, cv::RNG::UNIFORM, -1.0, 1.0);
  constexpr int kPad = 2;
  cv::Mat padded;
  cv::copyMakeBorder(grid, padded, kPad, kPad, kPad, kPad,
                     seamless ? cv::BORDER_WRAP : cv::BORDER_REFLECT_101);
  const double sx = static_cast<double>(size.width) / gw;
  const double sy = static_cast<double>(size.height) / gh;
  cv::Mat big;
  cv::resize(padded, big,
             cv::Size(static_cast<int>(std::lround(padded.cols * sx)),
                      static_cast<int>(std::lround(padded.rows * sy))),
             0, 0, cv::INTER_CUBIC);
  const cv::Rect roi(static_cast<int>(std::lround(kPad * sx)),
                     static_cast<int>(std::lround(kPad * sy)), size.width, size.height);
  return big(roi & cv::Rect(0, 0, big.cols, big.rows)).clone();
}

cv::Scalar Shade(const cv::Scalar& colour, double factor) {
  return cv::Scalar(colour[0] * factor, colour[1] * factor, colour[2] * factor);
}

}  // namespace

Canvas::Canvas(double width_m, double height_m, double texel_m, const cv::Scalar& base_bgr)
    : texel_m_(texel_m) {
  image_.create(std::max(1, static_cast<int>(std::lround(height_m / texel_m))),
                std::max(1, static_cast<int>(std::lround(width_m / texel_m))), CV_8UC3);
  image_.setTo(base_bgr);
}

int Canvas::Px(double metres) const { return static_cast<int>(std::lround(metres / texel_m_)); }

cv::Point Canvas::P(double a, double b) const { return {Px(a), Px(b)}; }

cv::Rect Canvas::R(double a, double b, double w, double h) const {
  const cv::Point p0 = P(a, b), p1 = P(a + w, b + h);
  return {p0, p1};
}

void Canvas::Paste(const Canvas& other, double a, double b) {
  const cv::Point origin = P(a, b);
  const cv::Rect target =
      cv::Rect(origin, other.image_.size()) & cv::Rect(0, 0, image_.cols, image_.rows);
  if (target.empty()) return;
  other.image_(cv::Rect(target.tl() - origin, target.size())).copyTo(image_(target));
}

void Canvas::Fill(double a, double b, double w, double h, const cv::Scalar& colour) {
  cv::rectangle(image_, R(a, b, w, h), colour, cv::FILLED);
}

void Canvas::Outline(double a, double b, double w, double h, double thickness_m,
                     const cv::Scalar& colour) {
  Fill(a, b, w, thickness_m, colour);
  Fill(a, b + h - thickness_m, w, thickness_m, colour);
  Fill(a, b, thickness_m, h, colour);
  Fill(a + w - thickness_m, b, thickness_m, h, colour);
}

void Canvas::Line(double a0, double b0, double a1, double b1, double thickness_m,
                  const cv::Scalar& colour) {
  cv::line(image_, P(a0, b0), P(a1, b1), colour, std::max(1, Px(thickness_m)), cv::LINE_AA);
}

void Canvas::Disc(double a, double b, double radius_m, const cv::Scalar& colour) {
  cv::circle(image_, P(a, b), std::max(1, Px(radius_m)), colour, cv::FILLED, cv::LINE_AA);
}

void Canvas::Ring(double a, double b, double radius_m, double thickness_m,
                  const cv::Scalar& colour) {
  cv::circle(image_, P(a, b), std::max(1, Px(radius_m)), colour, std::max(1, Px(thickness_m)),
             cv::LINE_AA);
}

void Canvas::Text(const std::string& text, double a, double b, double height_m,
                  const cv::Scalar& colour) {
  constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
  int baseline = 0;
  const cv::Size unit = cv::getTextSize("H", kFont, 1.0, 1, &baseline);
  const double scale = Px(height_m) / static_cast<double>(unit.height);
  const int thickness = std::max(1, static_cast<int>(std::lround(scale * 2.0)));
  cv::putText(image_, text, P(a, b), kFont, scale, colour, thickness, cv::LINE_AA);
}

void Canvas::Mottle(double cell_m, double amplitude, cv::RNG& rng, bool seamless,
                    const cv::Vec3f& tint) {
  const double cell_px = cell_m / texel_m_;
  cv::Mat noise = cv::Mat::zeros(image_.size(), CV_32F);
  double octave_amplitude = 1.0, total = 0.0;
  for (double cell = cell_px; cell >= 2.0 && octave_amplitude > 0.1; cell /= 2.0) {
    noise += octave_amplitude * ValueNoise(image_.size(), cell, rng, seamless);
    total += octave_amplitude;
    octave_amplitude *= 0.5;
  }
  if (total == 0.0) return;
  noise *= amplitude / total;
  cv::Mat noise3;
  cv::merge(std::vector<cv::Mat>{noise * tint[0], noise * tint[1], noise * tint[2]}, noise3);
  cv::Mat image_f;
  image_.convertTo(image_f, CV_32FC3);
  image_f += noise3;
  image_f.convertTo(image_, CV_8UC3);
}

void Canvas::Grain(double amplitude, cv::RNG& rng) {
  cv::Mat noise(image_.size(), CV_32F);
  rng.fill(noise, cv::RNG::UNIFORM, -amplitude, amplitude);
  cv::Mat noise3, image_f;
  cv::merge(std::vector<cv::Mat>{noise, noise, noise}, noise3);
  image_.convertTo(image_f, CV_32FC3);
  image_f += noise3;
  image_f.convertTo(image_, CV_8UC3);
}

void Canvas::Flecks(double size_m, double fraction, const cv::Scalar& colour, cv::RNG& rng,
                    double opacity) {
  const double fleck_area = size_m * size_m;
  const int count = static_cast<int>(width_m() * height_m() * fraction / fleck_area);
  const int radius = std::max(1, Px(0.5 * size_m));
  cv::Mat flecked = opacity < 1.0 ? image_.clone() : image_;
  for (int i = 0; i < count; ++i) {
    const cv::Point p(rng.uniform(0, image_.cols), rng.uniform(0, image_.rows));
    const double k = rng.uniform(0.7, 1.3);
    cv::circle(flecked, p, radius, Shade(colour, k), cv::FILLED, cv::LINE_AA);
  }
  if (opacity < 1.0) cv::addWeighted(flecked, opacity, image_, 1.0 - opacity, 0.0, image_);
}

std::string RandomWord(cv::RNG& rng, int length) {
  static const char kConsonants[] = "BCDFGHKLMNPRSTVWZ";
  static const char kVowels[] = "AEIOU";
  std::string word;
  for (int i = 0; i < length; ++i) {
    word += (i % 2 == 0) ? kConsonants[rng.uniform(0, 17)] : kVowels[rng.uniform(0, 5)];
  }
  return word;
}

cv::Scalar RandomColour(cv::RNG& rng, int min_value, int max_value) {
  return cv::Scalar(rng.uniform(min_value, max_value), rng.uniform(min_value, max_value),
                    rng.uniform(min_value, max_value));
}

void DrawPoster(Canvas* c, double a, double b, double w, double h, cv::RNG& rng) {
  const cv::Scalar background = RandomColour(rng, 60, 250);
  c->Fill(a, b, w, h, background);
  // A title, some bold shapes and lines of small print: edges and corners at every scale.
  const double margin = 0.06 * w;
  const double title_h = 0.08 * h;
  const cv::Scalar ink = (background[0] + background[1] + background[2] > 400)
                             ? cv::Scalar(30, 30, 30)
                             : cv::Scalar(245, 245, 245);
  c->Text(RandomWord(rng, rng.uniform(4, 7)), a + margin, b + margin + title_h, title_h, ink);
  const int shapes = rng.uniform(2, 6);
  for (int i = 0; i < shapes; ++i) {
    const double sw = rng.uniform(0.15, 0.45) * w;
    const double sh = rng.uniform(0.1, 0.3) * h;
    const double sa = a + margin + rng.uniform(0.0, w - 2 * margin - sw);
    const double sb = b + 0.2 * h + rng.uniform(0.0, 0.45 * h);
    const cv::Scalar colour = RandomColour(rng, 0, 255);
    if (rng.uniform(0, 3) == 0) {
      c->Disc(sa + 0.5 * sw, sb + 0.5 * sh, 0.5 * std::min(sw, sh), colour);
    } else {
      c->Fill(sa, sb, sw, sh, colour);
    }
  }
  const double line_h = 0.025 * h;
  for (double lb = b + 0.72 * h; lb < b + h - margin; lb += 2.2 * line_h) {
    double la = a + margin;
    while (true) {
      const std::string word = RandomWord(rng, rng.uniform(2, 8));
      const double word_w = 0.75 * line_h * word.size();
      if (la + word_w > a + w - margin) break;
      c->Text(word, la, lb, line_h, ink);
      la += word_w + line_h;
    }
  }
  c->Outline(a, b, w, h, 0.008, Shade(background, 0.5));
}

void DrawPicture(Canvas* c, double a, double b, double w, double h, cv::RNG& rng) {
  const double frame = 0.035;
  c->Fill(a, b, w, h, cv::Scalar(40, 60, 90));
  const double ia = a + frame, ib = b + frame, iw = w - 2 * frame, ih = h - 2 * frame;
  // A landscape: sky, hills, a sun.
  c->Fill(ia, ib, iw, ih, cv::Scalar(rng.uniform(180, 240), rng.uniform(150, 200), 120));
  c->Fill(ia, ib + 0.55 * ih, iw, 0.45 * ih, cv::Scalar(60, rng.uniform(110, 160), 70));
  c->Disc(ia + rng.uniform(0.2, 0.8) * iw, ib + 0.25 * ih, 0.08 * ih, cv::Scalar(80, 220, 250));
  for (int i = 0; i < 3; ++i) {
    const double x = ia + rng.uniform(0.1, 0.9) * iw;
    c->Fill(x, ib + 0.4 * ih, 0.03 * iw, 0.2 * ih, cv::Scalar(40, 70, 100));
    c->Disc(x + 0.015 * iw, ib + 0.4 * ih, 0.07 * ih, cv::Scalar(40, 110, 50));
  }
}

void DrawDoor(Canvas* c, double a, double b, double w, double h, bool vision_panel, cv::RNG& rng) {
  const double frame = 0.06;
  const cv::Scalar frame_colour(60, 60, 66);
  const cv::Scalar leaf(rng.uniform(60, 110), rng.uniform(100, 150), rng.uniform(150, 200));
  c->Fill(a, b, w, h, frame_colour);
  Canvas grain(w - 2 * frame, h - frame, c->texel_m(), leaf);
  grain.Mottle(0.03, 14.0, rng, false, {0.8f, 1.0f, 1.2f});
  c->Paste(grain, a + frame, b + frame);
  const double la = a + frame, lb = b + frame, lw = w - 2 * frame;
  // Recessed panels, handle and kick plate.
  c->Outline(la + 0.1 * lw, lb + 0.08, 0.8 * lw, 0.7, 0.012, Shade(leaf, 0.7));
  c->Outline(la + 0.1 * lw, lb + 1.0, 0.8 * lw, 0.75, 0.012, Shade(leaf, 0.7));
  c->Fill(la + 0.82 * lw, lb + 1.0 - 0.04, 0.12, 0.025, cv::Scalar(170, 170, 175));
  c->Disc(la + 0.85 * lw, lb + 1.0, 0.025, cv::Scalar(140, 140, 145));
  c->Fill(la, b + h - 0.2, lw, 0.2, cv::Scalar(150, 150, 155));
  if (vision_panel) {
    c->Fill(la + 0.3 * lw, lb + 0.15, 0.4 * lw, 0.5, cv::Scalar(70, 60, 50));
    c->Outline(la + 0.3 * lw, lb + 0.15, 0.4 * lw, 0.5, 0.015, cv::Scalar(200, 200, 200));
  }
}

void DrawWindow(Canvas* c, double a, double b, double w, double h, int panes_x, int panes_y,
                cv::RNG& rng) {
  // The view: bright sky over a row of distant buildings.
  c->Fill(a, b, w, h, cv::Scalar(245, 225, 200));
  double x = a;
  while (x < a + w) {
    const double bw = rng.uniform(0.15, 0.5);
    const double bh = rng.uniform(0.2, 0.6) * h;
    c->Fill(x, b + h - bh, std::min(bw, a + w - x), bh, RandomColour(rng, 120, 200));
    x += bw;
  }
  const double frame = 0.06, mullion = 0.04;
  const cv::Scalar white(235, 235, 232);
  c->Outline(a, b, w, h, frame, white);
  for (int i = 1; i < panes_x; ++i) {
    c->Fill(a + i * w / panes_x - 0.5 * mullion, b, mullion, h, white);
  }
  for (int j = 1; j < panes_y; ++j) {
    c->Fill(a, b + j * h / panes_y - 0.5 * mullion, w, mullion, white);
  }
  c->Fill(a - 0.05, b + h, w + 0.1, 0.04, cv::Scalar(210, 210, 210));  // Sill.
}

void DrawWhiteboard(Canvas* c, double a, double b, double w, double h, cv::RNG& rng) {
  c->Fill(a, b, w, h, cv::Scalar(248, 248, 246));
  c->Outline(a, b, w, h, 0.025, cv::Scalar(175, 178, 180));
  const cv::Scalar inks[] = {{160, 40, 20}, {30, 30, 200}, {30, 30, 30}, {40, 140, 40}};
  for (int i = 0; i < 6; ++i) {
    const cv::Scalar ink = inks[rng.uniform(0, 4)];
    double pa = a + rng.uniform(0.1, 0.8) * w, pb = b + rng.uniform(0.15, 0.85) * h;
    for (int k = 0; k < 6; ++k) {
      const double na = std::clamp(pa + rng.uniform(-0.25, 0.25), a + 0.05, a + w - 0.05);
      const double nb = std::clamp(pb + rng.uniform(-0.15, 0.15), b + 0.05, b + h - 0.05);
      c->Line(pa, pb, na, nb, 0.006, ink);
      pa = na;
      pb = nb;
    }
  }
  for (int i = 0; i < 5; ++i) {
    c->Text(RandomWord(rng, rng.uniform(3, 8)), a + rng.uniform(0.05, 0.6) * w,
            b + (0.15 + 0.15 * i) * h, 0.05, inks[rng.uniform(0, 4)]);
  }
  // Boxes and arrows of a diagram.
  const double da = a + 0.6 * w, db = b + 0.2 * h;
  c->Outline(da, db, 0.25, 0.15, 0.006, inks[0]);
  c->Outline(da, db + 0.35, 0.25, 0.15, 0.006, inks[0]);
  c->Line(da + 0.125, db + 0.15, da + 0.125, db + 0.35, 0.006, inks[0]);
  c->Fill(a + 0.1 * w, b + h, 0.8 * w, 0.04, cv::Scalar(160, 160, 165));  // Tray.
}

void DrawNoticeBoard(Canvas* c, double a, double b, double w, double h, cv::RNG& rng) {
  Canvas cork(w, h, c->texel_m(), cv::Scalar(90, 140, 190));
  cork.Mottle(0.02, 18.0, rng);
  cork.Flecks(0.004, 0.15, cv::Scalar(50, 90, 130), rng);
  c->Paste(cork, a, b);
  c->Outline(a, b, w, h, 0.03, cv::Scalar(60, 90, 120));
  const int notes = rng.uniform(6, 12);
  for (int i = 0; i < notes; ++i) {
    const double nw = rng.uniform(0.1, 0.25), nh = rng.uniform(0.08, 0.3);
    const double na = a + 0.04 + rng.uniform(0.0, std::max(0.01, w - 0.08 - nw));
    const double nb = b + 0.04 + rng.uniform(0.0, std::max(0.01, h - 0.08 - nh));
    DrawPaper(c, na, nb, nw, nh, rng);
    c->Disc(na + 0.5 * nw, nb + 0.015, 0.007, RandomColour(rng, 0, 255));
  }
}

void DrawPaper(Canvas* c, double a, double b, double w, double h, cv::RNG& rng) {
  const bool tinted = rng.uniform(0, 3) == 0;
  const cv::Scalar paper = tinted ? cv::Scalar(120, 230, 250) : cv::Scalar(240, 242, 242);
  c->Fill(a, b, w, h, paper);
  const double line_h = std::max(0.006, 0.045 * h);
  for (double lb = b + 2.5 * line_h; lb < b + h - line_h; lb += 2.0 * line_h) {
    const double lw = rng.uniform(0.4, 0.9) * (w - 2 * line_h);
    c->Fill(a + line_h, lb - 0.5 * line_h, lw, 0.5 * line_h, cv::Scalar(80, 80, 80));
  }
}

void DrawBookshelf(Canvas* c, double a, double b, double w, double h, cv::RNG& rng) {
  const cv::Scalar wood(70, 110, 150);
  c->Fill(a, b, w, h, Shade(wood, 0.55));
  const int shelves = std::max(2, static_cast<int>(h / 0.38));
  const double board = 0.025, side = 0.03;
  const double pitch = (h - board) / shelves;
  for (int s = 0; s < shelves; ++s) {
    const double shelf_top = b + board + s * pitch;
    double x = a + side;
    while (x < a + w - side - 0.02) {
      const double bw = std::min(rng.uniform(0.02, 0.06), a + w - side - x);
      const double bh = rng.uniform(0.6, 0.92) * (pitch - board);
      const cv::Scalar colour = RandomColour(rng, 20, 220);
      c->Fill(x, shelf_top + pitch - board - bh, bw, bh, colour);
      c->Fill(x, shelf_top + pitch - board - 0.8 * bh, bw, 0.012, Shade(colour, 0.5));
      x += bw + (rng.uniform(0, 8) == 0 ? rng.uniform(0.02, 0.1) : 0.002);
    }
    c->Fill(a, shelf_top + pitch - board, w, board, wood);
  }
  c->Fill(a, b, w, board, wood);
  c->Fill(a, b, side, h, wood);
  c->Fill(a + w - side, b, side, h, wood);
}

void DrawClock(Canvas* c, double a, double b, double radius_m, cv::RNG& rng) {
  c->Disc(a, b, radius_m, cv::Scalar(245, 245, 245));
  c->Ring(a, b, radius_m, 0.012, cv::Scalar(30, 30, 30));
  for (int i = 0; i < 12; ++i) {
    const double angle = i * M_PI / 6.0;
    c->Line(a + 0.8 * radius_m * std::cos(angle), b + 0.8 * radius_m * std::sin(angle),
            a + 0.92 * radius_m * std::cos(angle), b + 0.92 * radius_m * std::sin(angle), 0.006,
            cv::Scalar(20, 20, 20));
  }
  const double hour = rng.uniform(0.0, 2.0 * M_PI), minute = rng.uniform(0.0, 2.0 * M_PI);
  c->Line(a, b, a + 0.5 * radius_m * std::sin(hour), b - 0.5 * radius_m * std::cos(hour), 0.01,
          cv::Scalar(20, 20, 20));
  c->Line(a, b, a + 0.8 * radius_m * std::sin(minute), b - 0.8 * radius_m * std::cos(minute), 0.006,
          cv::Scalar(20, 20, 20));
}

void DrawRadiator(Canvas* c, double a, double b, double w, double h) {
  c->Fill(a, b, w, h, cv::Scalar(225, 228, 228));
  for (double x = a + 0.03; x < a + w - 0.02; x += 0.05) {
    c->Fill(x, b + 0.03, 0.012, h - 0.06, cv::Scalar(175, 178, 180));
  }
}

void DrawSocket(Canvas* c, double a, double b) {
  c->Fill(a, b, 0.08, 0.08, cv::Scalar(235, 235, 235));
  c->Outline(a, b, 0.08, 0.08, 0.004, cv::Scalar(150, 150, 150));
  c->Disc(a + 0.028, b + 0.04, 0.006, cv::Scalar(40, 40, 40));
  c->Disc(a + 0.052, b + 0.04, 0.006, cv::Scalar(40, 40, 40));
}

void DrawBarcodeLabel(Canvas* c, double a, double b, double w, double h, cv::RNG& rng) {
  c->Fill(a, b, w, h, cv::Scalar(245, 245, 245));
  double x = a + 0.08 * w;
  while (x < a + 0.92 * w) {
    const double bar = rng.uniform(1, 4) * 0.0025;
    c->Fill(x, b + 0.15 * h, bar, 0.5 * h, cv::Scalar(20, 20, 20));
    x += bar + rng.uniform(1, 3) * 0.0025;
  }
  c->Text(RandomWord(rng, 6), a + 0.1 * w, b + 0.9 * h, 0.15 * h, cv::Scalar(20, 20, 20));
}

void DrawKeyboard(Canvas* c, double a, double b, double w, double h) {
  c->Fill(a, b, w, h, cv::Scalar(50, 50, 52));
  const int cols = 15, rows = 5;
  const double kw = w / cols, kh = h / rows;
  for (int j = 0; j < rows; ++j) {
    for (int i = 0; i < cols; ++i) {
      c->Fill(a + i * kw + 0.15 * kw, b + j * kh + 0.15 * kh, 0.7 * kw, 0.7 * kh,
              cv::Scalar(205, 205, 208));
    }
  }
}

}  // namespace autocal
