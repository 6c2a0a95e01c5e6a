#include "devices/sim/scene.h"

#include <map>
#include <mutex>
#include <sstream>

#include "devices/sim/procedural.h"
#include "devices/sim/random.h"
#include "devices/sim/trajectory.h"
#include "pipeline/error.h"

namespace autocal {
namespace {

const Eigen::Vector3d kUp = Eigen::Vector3d::UnitZ();

class SceneBuilder {
 public:
  SceneBuilder(const std::string& name, uint32_t seed) : seed_(seed) { scene_.name = name; }
  // Goes on adding planes to `scene`.
  SceneBuilder(Scene scene, uint32_t seed) : scene_(std::move(scene)), seed_(seed) {}

  // A generator for the texture of the next plane: each plane draws from its own stream.
  cv::RNG NextRng() const {
    return cv::RNG(MixSeed(seed_, kTextureStream, scene_.planes.size() + 1));
  }

  void Add(const std::string& name, const Eigen::Vector3d& origin, const Eigen::Vector3d& u,
           const Eigen::Vector3d& v, const Canvas& canvas, bool repeat, float shade,
           double width_m = 0.0, double height_m = 0.0) {
    Plane plane;
    plane.id = static_cast<int>(scene_.planes.size()) + 1;
    plane.name = name;
    plane.origin = origin;
    plane.axis_u = u;
    plane.axis_v = v;
    plane.width_m = width_m > 0.0 ? width_m : canvas.width_m();
    plane.height_m = height_m > 0.0 ? height_m : canvas.height_m();
    plane.texture = static_cast<int>(scene_.textures.size());
    plane.shade = shade;
    scene_.textures.emplace_back(canvas.image(), canvas.texel_m(), repeat);
    scene_.planes.push_back(plane);
  }

  // A vertical rectangle seen from the side `normal` (horizontal) points to; `top_left` is
  // its upper left corner as seen from there.
  void AddVertical(const std::string& name, const Eigen::Vector3d& normal,
                   const Eigen::Vector3d& top_left, const Canvas& canvas, float shade) {
    Add(name, top_left, (-normal).cross(kUp), -kUp, canvas, false, shade);
  }
  // A horizontal rectangle seen from above; u runs along +x, v along -y.
  void AddUpFacing(const std::string& name, double x0, double y1, double z, const Canvas& canvas,
                   float shade, bool repeat = false, double width_m = 0.0, double height_m = 0.0) {
    Add(name, {x0, y1, z}, Eigen::Vector3d::UnitX(), -Eigen::Vector3d::UnitY(), canvas, repeat,
        shade, width_m, height_m);
  }
  // A horizontal rectangle seen from below; u runs along +x, v along +y.
  void AddDownFacing(const std::string& name, double x0, double y0, double z, const Canvas& canvas,
                     float shade) {
    Add(name, {x0, y0, z}, Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY(), canvas, false,
        shade);
  }

  Scene& scene() { return scene_; }

 private:
  Scene scene_;
  uint32_t seed_;
};

// The colour made lighter or darker by up to `amount` grey levels, with a slight tint.
cv::Scalar Jitter(const cv::Scalar& colour, int amount, cv::RNG& rng) {
  const int tone = rng.uniform(-amount, amount + 1);
  return cv::Scalar(colour[0] + tone + rng.uniform(-3, 4), colour[1] + tone + rng.uniform(-3, 4),
                    colour[2] + tone + rng.uniform(-3, 4));
}

// Painted wall: mottled paint, skirting board, then the furniture drawn by `furnish`, then
// a fine grain. `texture` scales the paint's mottle, flecks and grain
// (Scenario::surface_texture; at 1 the paint has texture to track everywhere, at 0 none);
// the generator is drawn from the same at any strength, so the furniture stays as it is.
template <typename Furnish>
Canvas PaintedWall(double width_m, double height_m, double texel_m, const cv::Scalar& paint,
                   double texture, cv::RNG& rng, Furnish furnish) {
  Canvas c(width_m, height_m, texel_m, paint);
  c.Mottle(0.4, 14.0 * texture, rng);
  c.Flecks(0.004, 0.004, cv::Scalar(paint[0] * 0.85, paint[1] * 0.85, paint[2] * 0.85), rng,
           texture);
  c.Fill(0.0, height_m - 0.08, width_m, 0.08, cv::Scalar(55, 60, 70));
  c.Fill(0.0, height_m - 0.085, width_m, 0.006, cv::Scalar(120, 125, 130));
  furnish(c);
  c.Grain(5.0 * texture, rng);
  return c;
}

void DrawSwitch(Canvas* c, double a, double b) {
  c->Fill(a, b, 0.08, 0.08, cv::Scalar(240, 240, 240));
  c->Outline(a, b, 0.08, 0.08, 0.004, cv::Scalar(150, 150, 150));
  c->Fill(a + 0.025, b + 0.02, 0.03, 0.04, cv::Scalar(200, 200, 200));
}

// Carpet tiles; `texture` scales their pile (mottle, flecks, grain), not the tiles' tones.
Canvas Carpet(double width_m, double height_m, double texel_m, double texture, cv::RNG& rng) {
  Canvas c(width_m, height_m, texel_m, cv::Scalar(105, 92, 85));
  constexpr double kTile = 0.5;
  for (double b = 0.0; b < height_m; b += kTile) {
    for (double a = 0.0; a < width_m; a += kTile) {
      c.Fill(a, b, kTile, kTile, Jitter(cv::Scalar(105, 92, 85), 12, rng));
    }
  }
  c.Mottle(0.15, 16.0 * texture, rng);
  c.Flecks(0.008, 0.025, cv::Scalar(150, 140, 132), rng, texture);
  c.Flecks(0.006, 0.02, cv::Scalar(65, 58, 52), rng, texture);
  for (double a = 0.0; a <= width_m; a += kTile)
    c.Fill(a - 0.002, 0.0, 0.004, height_m, {70, 62, 58});
  for (double b = 0.0; b <= height_m; b += kTile)
    c.Fill(0.0, b - 0.002, width_m, 0.004, {70, 62, 58});
  c.Grain(8.0 * texture, rng);
  return c;
}

Canvas TiledCeiling(double width_m, double height_m, double texel_m, double light_every_m,
                    cv::RNG& rng) {
  Canvas c(width_m, height_m, texel_m, cv::Scalar(222, 225, 225));
  c.Flecks(0.004, 0.04, cv::Scalar(170, 172, 172), rng);
  c.Mottle(0.3, 6.0, rng);
  constexpr double kTile = 0.6;
  // Light panels, 0.6 x 1.2 m, with a louvre grid.
  for (double a = 1.2; a + kTile < width_m; a += light_every_m) {
    for (double b = 0.6; b + 2 * kTile <= height_m; b += 2.4) {
      c.Fill(a, b, kTile, 2 * kTile, cv::Scalar(252, 252, 250));
      for (double x = a + 0.1; x < a + kTile; x += 0.1)
        c.Fill(x, b, 0.006, 2 * kTile, {200, 200, 200});
      for (double y = b + 0.1; y < b + 2 * kTile; y += 0.1)
        c.Fill(a, y, kTile, 0.006, {200, 200, 200});
    }
  }
  // The T-bar grid: the strong straight lines of a suspended ceiling.
  for (double a = 0.0; a <= width_m; a += kTile)
    c.Fill(a - 0.012, 0.0, 0.024, height_m, {185, 188, 190});
  for (double b = 0.0; b <= height_m; b += kTile)
    c.Fill(0.0, b - 0.012, width_m, 0.024, {185, 188, 190});
  for (int i = 0; i < static_cast<int>(width_m * height_m / 8.0); ++i) {
    const double a = kTile * (rng.uniform(0, static_cast<int>(width_m / kTile)) + 0.5);
    const double b = kTile * (rng.uniform(0, static_cast<int>(height_m / kTile)) + 0.5);
    c.Disc(a, b, 0.05, cv::Scalar(245, 245, 245));
    c.Ring(a, b, 0.05, 0.006, cv::Scalar(150, 150, 150));
  }
  return c;
}

Canvas Cardboard(double width_m, double height_m, bool top, cv::RNG& rng) {
  Canvas c(width_m, height_m, 0.0025, cv::Scalar(95, 150, 200));
  c.Mottle(0.1, 14.0, rng, false, {0.7f, 0.9f, 1.1f});
  if (top) {
    c.Fill(0.0, 0.5 * height_m - 0.003, width_m, 0.006, cv::Scalar(60, 100, 140));
    c.Fill(0.0, 0.5 * height_m - 0.025, width_m, 0.05, cv::Scalar(150, 190, 215));
  } else {
    c.Fill(0.0, 0.0, width_m, 0.05, cv::Scalar(150, 190, 215));
    c.Text(RandomWord(rng, 7), 0.06, 0.2, 0.06, cv::Scalar(40, 40, 40));
    // Two "this side up" arrows.
    for (double a : {0.08, 0.2}) {
      c.Line(a, 0.42, a, 0.3, 0.012, cv::Scalar(40, 40, 40));
      c.Line(a, 0.3, a - 0.03, 0.34, 0.012, cv::Scalar(40, 40, 40));
      c.Line(a, 0.3, a + 0.03, 0.34, 0.012, cv::Scalar(40, 40, 40));
    }
    DrawBarcodeLabel(&c, width_m - 0.28, height_m - 0.22, 0.2, 0.12, rng);
  }
  c.Grain(6.0, rng);
  return c;
}

Canvas CabinetSide(double width_m, double height_m, cv::RNG& rng) {
  Canvas c(width_m, height_m, 0.0025, cv::Scalar(150, 148, 145));
  c.Mottle(0.2, 8.0, rng);
  const int drawers = 3;
  const double pitch = (height_m - 0.06) / drawers;
  for (int i = 0; i < drawers; ++i) {
    const double b = 0.03 + i * pitch;
    c.Outline(0.02, b, width_m - 0.04, pitch - 0.01, 0.004, cv::Scalar(90, 90, 90));
    c.Fill(0.5 * width_m - 0.08, b + 0.12, 0.16, 0.03, cv::Scalar(60, 60, 60));
    c.Fill(0.5 * width_m - 0.05, b + 0.04, 0.1, 0.05, cv::Scalar(235, 235, 235));
    c.Text(RandomWord(rng, 3), 0.5 * width_m - 0.04, b + 0.08, 0.025, cv::Scalar(30, 30, 30));
  }
  c.Grain(5.0, rng);
  return c;
}

Canvas WoodPanel(double width_m, double height_m, bool drawer, cv::RNG& rng) {
  Canvas c(width_m, height_m, 0.0025, cv::Scalar(80, 125, 170));
  c.Mottle(0.05, 16.0, rng, false, {0.8f, 1.0f, 1.2f});
  c.Fill(0.0, 0.0, width_m, 0.03, cv::Scalar(60, 90, 120));
  if (drawer) {
    c.Outline(0.1, 0.08, width_m - 0.2, 0.2, 0.006, cv::Scalar(50, 80, 110));
    c.Fill(0.5 * width_m - 0.07, 0.16, 0.14, 0.025, cv::Scalar(180, 180, 185));
  }
  c.Grain(6.0, rng);
  return c;
}

Canvas DeskTop(double width_m, double height_m, cv::RNG& rng) {
  Canvas c(width_m, height_m, 0.002, cv::Scalar(110, 150, 185));
  c.Mottle(0.06, 16.0, rng, false, {0.8f, 1.0f, 1.2f});
  DrawKeyboard(&c, 0.45, 0.45, 0.44, 0.15);
  DrawPaper(&c, 0.08, 0.1, 0.21, 0.297, rng);
  DrawPaper(&c, 0.33, 0.06, 0.21, 0.297, rng);
  DrawPaper(&c, 1.0, 0.15, 0.297, 0.21, rng);
  c.Fill(0.95, 0.5, 0.25, 0.18, cv::Scalar(40, 40, 140));  // A notebook.
  c.Disc(0.2, 0.6, 0.045, cv::Scalar(235, 235, 235));      // A mug.
  c.Ring(0.2, 0.6, 0.045, 0.006, cv::Scalar(60, 60, 60));
  c.Disc(0.2, 0.6, 0.032, cv::Scalar(40, 60, 90));
  c.Grain(5.0, rng);
  return c;
}

// A cuboid on the floor: top and four sides (the bottom is never seen).
template <typename SideCanvas, typename TopCanvas>
void AddBox(SceneBuilder* builder, const std::string& name, const Eigen::Vector3d& centre,
            const Eigen::Vector3d& size, SideCanvas side_canvas, TopCanvas top_canvas) {
  const double x0 = centre.x() - 0.5 * size.x(), x1 = centre.x() + 0.5 * size.x();
  const double y0 = centre.y() - 0.5 * size.y(), y1 = centre.y() + 0.5 * size.y();
  const double z = size.z();
  {
    cv::RNG rng = builder->NextRng();
    builder->AddUpFacing(name + "_top", x0, y1, z, top_canvas(size.x(), size.y(), rng), 1.0f);
  }
  struct Side {
    const char* suffix;
    Eigen::Vector3d normal, top_left;
    double width;
    float shade;
  };
  const Side sides[] = {
      {"_east", Eigen::Vector3d::UnitX(), {x1, y0, z}, size.y(), 0.85f},
      {"_north", Eigen::Vector3d::UnitY(), {x1, y1, z}, size.x(), 0.78f},
      {"_west", -Eigen::Vector3d::UnitX(), {x0, y1, z}, size.y(), 0.72f},
      {"_south", -Eigen::Vector3d::UnitY(), {x0, y0, z}, size.x(), 0.9f},
  };
  for (const Side& side : sides) {
    cv::RNG rng = builder->NextRng();
    builder->AddVertical(name + side.suffix, side.normal, side.top_left,
                         side_canvas(side.width, z, rng), side.shade);
  }
}

Scene BuildOffice(uint32_t seed, double texture) {
  // Room x in [-4, 4], y in [-3, 3], z in [0, 2.8]; walls are named by the direction
  // they lie in.
  constexpr double kW = 8.0, kD = 6.0, kH = 2.8;
  SceneBuilder builder("office", seed);
  {
    cv::RNG rng = builder.NextRng();
    builder.AddUpFacing("floor", -4.0, 3.0, 0.0, Carpet(kW, kD, 0.005, texture, rng), 0.9f);
  }
  {
    cv::RNG rng = builder.NextRng();
    builder.AddDownFacing("ceiling", -4.0, -3.0, kH, TiledCeiling(kW, kD, 0.005, 2.4, rng), 1.0f);
  }
  const cv::Scalar paint(200, 215, 222);
  {
    cv::RNG rng = builder.NextRng();
    Canvas wall = PaintedWall(kW, kH, 0.004, paint, texture, rng, [&](Canvas& c) {
      DrawWindow(&c, 1.4, 0.6, 1.8, 1.3, 3, 2, rng);
      DrawRadiator(&c, 1.5, 2.15, 1.6, 0.45);
      DrawWhiteboard(&c, 3.7, 0.75, 2.0, 1.1, rng);
      DrawPoster(&c, 6.1, 0.7, 0.6, 0.85, rng);
      DrawPoster(&c, 7.0, 0.9, 0.55, 0.7, rng);
      DrawSocket(&c, 3.9, 2.45);
      DrawSocket(&c, 5.3, 2.45);
    });
    builder.AddVertical("wall_north", -Eigen::Vector3d::UnitY(), {-4.0, 3.0, kH}, wall, 0.95f);
  }
  {
    cv::RNG rng = builder.NextRng();
    Canvas wall = PaintedWall(kD, kH, 0.004, paint, texture, rng, [&](Canvas& c) {
      DrawDoor(&c, 0.6, 0.7, 0.95, 2.1, false, rng);
      DrawSwitch(&c, 1.7, 1.5);
      DrawBookshelf(&c, 2.1, 0.8, 1.4, 2.0, rng);
      DrawPoster(&c, 3.9, 0.7, 0.7, 1.0, rng);
      DrawPicture(&c, 4.8, 1.05, 0.8, 0.55, rng);
      DrawClock(&c, 5.4, 0.5, 0.15, rng);
      DrawSocket(&c, 4.2, 2.45);
    });
    builder.AddVertical("wall_east", -Eigen::Vector3d::UnitX(), {4.0, 3.0, kH}, wall, 0.88f);
  }
  {
    cv::RNG rng = builder.NextRng();
    Canvas wall =
        PaintedWall(kW, kH, 0.004, cv::Scalar(185, 210, 215), texture, rng, [&](Canvas& c) {
          DrawNoticeBoard(&c, 1.4, 0.8, 1.5, 1.0, rng);
          DrawPoster(&c, 3.3, 0.75, 0.6, 0.85, rng);
          DrawPicture(&c, 4.2, 1.0, 0.9, 0.6, rng);
          DrawDoor(&c, 5.8, 0.7, 0.95, 2.1, false, rng);
          DrawSwitch(&c, 6.9, 1.5);
          DrawPoster(&c, 7.2, 0.9, 0.5, 0.7, rng);
          DrawSocket(&c, 2.0, 2.45);
        });
    builder.AddVertical("wall_south", Eigen::Vector3d::UnitY(), {4.0, -3.0, kH}, wall, 0.8f);
  }
  {
    cv::RNG rng = builder.NextRng();
    Canvas wall = PaintedWall(kD, kH, 0.004, paint, texture, rng, [&](Canvas& c) {
      DrawWindow(&c, 0.9, 0.6, 1.8, 1.3, 2, 2, rng);
      DrawRadiator(&c, 1.0, 2.15, 1.6, 0.45);
      DrawPoster(&c, 3.1, 0.8, 0.5, 0.7, rng);
      DrawBookshelf(&c, 3.8, 1.0, 1.1, 1.8, rng);
      DrawPicture(&c, 5.1, 0.9, 0.6, 0.8, rng);
      DrawSocket(&c, 3.3, 2.45);
    });
    builder.AddVertical("wall_west", Eigen::Vector3d::UnitX(), {-4.0, -3.0, kH}, wall, 0.92f);
  }
  AddBox(
      &builder, "desk", {0.0, 0.0, 0.0}, {1.4, 0.8, 0.75},
      [](double w, double h, cv::RNG& rng) { return WoodPanel(w, h, w > 1.0, rng); },
      [](double w, double h, cv::RNG& rng) { return DeskTop(w, h, rng); });
  AddBox(
      &builder, "box", {3.3, -2.3, 0.0}, {0.8, 0.6, 0.6},
      [](double w, double h, cv::RNG& rng) { return Cardboard(w, h, false, rng); },
      [](double w, double h, cv::RNG& rng) { return Cardboard(w, h, true, rng); });
  AddBox(
      &builder, "cabinet", {-3.25, 2.35, 0.0}, {0.6, 0.5, 1.1},
      [](double w, double h, cv::RNG& rng) { return CabinetSide(w, h, rng); },
      [](double w, double h, cv::RNG& rng) {
        Canvas c(w, h, 0.0025, cv::Scalar(150, 148, 145));
        c.Mottle(0.1, 8.0, rng);
        c.Disc(0.5 * w, 0.5 * h, 0.12, cv::Scalar(50, 80, 140));  // A plant pot.
        c.Disc(0.5 * w, 0.5 * h, 0.09, cv::Scalar(40, 110, 60));
        c.Grain(5.0, rng);
        return c;
      });
  return std::move(builder.scene());
}

Canvas CorridorWall(double length_m, double height_m, double first_door_m, double texture,
                    cv::RNG& rng) {
  return PaintedWall(
      length_m, height_m, 0.006, cv::Scalar(190, 220, 230), texture, rng, [&](Canvas& c) {
        // Handrail 0.9 m above the floor along the whole wall: a long vanishing line.
        c.Fill(0.0, height_m - 0.92, length_m, 0.04, cv::Scalar(50, 80, 110));
        int i = 0;
        for (double a = first_door_m; a + 1.0 < length_m; a += 4.5, ++i) {
          DrawDoor(&c, a, height_m - 2.1, 0.95, 2.1, true, rng);
          c.Fill(a + 1.05, height_m - 1.55, 0.25, 0.12, cv::Scalar(240, 240, 240));
          c.Text(RandomWord(rng, 4), a + 1.07, height_m - 1.46, 0.05, cv::Scalar(30, 30, 30));
          const double gap = a + 1.5;
          switch (i % 3) {
            case 0:
              DrawPoster(&c, gap + 0.5, height_m - 2.0, 0.6, 0.85, rng);
              DrawPoster(&c, gap + 1.4, height_m - 1.9, 0.5, 0.7, rng);
              break;
            case 1:
              DrawNoticeBoard(&c, gap + 0.4, height_m - 2.0, 1.6, 0.9, rng);
              break;
            default:
              DrawPicture(&c, gap + 0.6, height_m - 1.9, 0.9, 0.6, rng);
              c.Fill(gap + 2.2, height_m - 0.65, 0.15, 0.4,
                     cv::Scalar(30, 30, 200));  // Extinguisher.
              break;
          }
        }
      });
}

Scene BuildCorridor(uint32_t seed, double texture) {
  // x in [-15, 15], y in [-1.2, 1.2], z in [0, 2.7].
  constexpr double kL = 30.0, kW = 2.4, kH = 2.7;
  SceneBuilder builder("corridor", seed);
  {
    cv::RNG rng = builder.NextRng();
    Canvas floor(kL, kW, 0.006, cv::Scalar(170, 175, 180));
    constexpr double kTile = 0.3;
    for (double b = 0.0; b < kW; b += kTile) {
      for (double a = 0.0; a < kL; a += kTile) {
        floor.Fill(a, b, kTile, kTile, Jitter(cv::Scalar(165, 172, 178), 18, rng));
      }
    }
    floor.Flecks(0.01, 0.03, cv::Scalar(130, 135, 140), rng, texture);
    floor.Flecks(0.008, 0.02, cv::Scalar(215, 215, 215), rng, texture);
    for (double a = 0.0; a <= kL; a += kTile) floor.Fill(a - 0.003, 0.0, 0.006, kW, {95, 95, 100});
    for (double b = 0.0; b <= kW; b += kTile) floor.Fill(0.0, b - 0.003, kL, 0.006, {95, 95, 100});
    floor.Grain(6.0 * texture, rng);
    builder.AddUpFacing("floor", -15.0, 1.2, 0.0, floor, 0.9f);
  }
  {
    cv::RNG rng = builder.NextRng();
    builder.AddDownFacing("ceiling", -15.0, -1.2, kH, TiledCeiling(kL, kW, 0.008, 3.0, rng), 1.0f);
  }
  {
    cv::RNG rng = builder.NextRng();
    builder.AddVertical("wall_north", -Eigen::Vector3d::UnitY(), {-15.0, 1.2, kH},
                        CorridorWall(kL, kH, 1.5, texture, rng), 0.92f);
  }
  {
    cv::RNG rng = builder.NextRng();
    builder.AddVertical("wall_south", Eigen::Vector3d::UnitY(), {15.0, -1.2, kH},
                        CorridorWall(kL, kH, 3.5, texture, rng), 0.82f);
  }
  {
    cv::RNG rng = builder.NextRng();
    Canvas end =
        PaintedWall(kW, kH, 0.004, cv::Scalar(190, 220, 230), texture, rng, [&](Canvas& c) {
          DrawDoor(&c, 0.25, kH - 2.1, 0.95, 2.1, true, rng);
          DrawDoor(&c, 1.2, kH - 2.1, 0.95, 2.1, true, rng);
          c.Fill(0.9, 0.2, 0.6, 0.2, cv::Scalar(60, 160, 40));  // Exit sign.
          c.Text("EXIT", 1.0, 0.35, 0.1, cv::Scalar(255, 255, 255));
        });
    builder.AddVertical("end_east", -Eigen::Vector3d::UnitX(), {15.0, 1.2, kH}, end, 0.95f);
  }
  {
    cv::RNG rng = builder.NextRng();
    Canvas end =
        PaintedWall(kW, kH, 0.004, cv::Scalar(190, 220, 230), texture, rng, [&](Canvas& c) {
          DrawWindow(&c, 0.3, 0.5, 1.8, 1.5, 3, 3, rng);
          DrawRadiator(&c, 0.4, 2.1, 1.6, 0.45);
        });
    builder.AddVertical("end_west", Eigen::Vector3d::UnitX(), {-15.0, -1.2, kH}, end, 0.9f);
  }
  return std::move(builder.scene());
}

Canvas Facade(double width_m, double height_m, const cv::Scalar& wall, cv::RNG& rng) {
  Canvas c(width_m, height_m, 0.025, wall);
  c.Mottle(2.0, 14.0, rng);
  c.Mottle(0.2, 8.0, rng);
  constexpr double kStorey = 3.2;
  const double window_w = rng.uniform(1.2, 1.8), window_h = 1.6,
               bay = window_w + rng.uniform(0.8, 1.5);
  const cv::Scalar frame(225, 225, 225);
  for (double top = height_m - kStorey; top >= kStorey * 0.9; top -= kStorey) {
    const double b = height_m - top - kStorey;  // Storey's top in plane coordinates.
    c.Fill(0.0, b + kStorey - 0.25, width_m, 0.25,
           cv::Scalar(wall[0] * 0.8, wall[1] * 0.8, wall[2] * 0.8));
    for (double a = 0.8; a + window_w < width_m - 0.5; a += bay) {
      const int shade = rng.uniform(60, 130);
      c.Fill(a, b + 0.7, window_w, window_h, cv::Scalar(shade + 30, shade + 10, shade));
      c.Fill(a, b + 0.7, window_w, 0.4 * window_h, cv::Scalar(shade + 70, shade + 50, shade + 40));
      c.Outline(a, b + 0.7, window_w, window_h, 0.08, frame);
      c.Fill(a + 0.5 * window_w - 0.04, b + 0.7, 0.08, window_h, frame);
      c.Fill(a - 0.1, b + 0.7 + window_h, window_w + 0.2, 0.1, cv::Scalar(170, 170, 170));
    }
  }
  // Ground floor: shop windows and doors.
  for (double a = 1.0; a + 3.0 < width_m; a += rng.uniform(4.0, 7.0)) {
    c.Fill(a, height_m - 2.8, 3.0, 2.5, cv::Scalar(90, 80, 70));
    c.Outline(a, height_m - 2.8, 3.0, 2.5, 0.1, cv::Scalar(40, 40, 40));
    c.Fill(a, height_m - 3.4, 3.0, 0.45, RandomColour(rng, 30, 220));
    c.Text(RandomWord(rng, 5), a + 0.2, height_m - 3.05, 0.25, cv::Scalar(250, 250, 250));
  }
  c.Fill(0.0, 0.0, width_m, 0.4, cv::Scalar(wall[0] * 0.7, wall[1] * 0.7, wall[2] * 0.7));
  c.Grain(6.0, rng);
  return c;
}

Scene BuildOutdoor(uint32_t seed) {
  SceneBuilder builder("outdoor", seed);
  builder.scene().background = cv::Vec3f(235.f, 205.f, 170.f);
  {
    // Asphalt with gravel, a seamless tile repeated over a 200 m square.
    cv::RNG rng = builder.NextRng();
    Canvas ground(25.6, 25.6, 0.0125, cv::Scalar(105, 108, 110));
    ground.Mottle(3.2, 22.0, rng, true);
    ground.Mottle(0.1, 14.0, rng, true);
    ground.Flecks(0.015, 0.02, cv::Scalar(150, 152, 155), rng);
    ground.Flecks(0.012, 0.02, cv::Scalar(70, 70, 72), rng);
    ground.Grain(8.0, rng);
    builder.AddUpFacing("ground", -100.0, 100.0, 0.0, ground, 1.0f, true, 200.0, 200.0);
  }
  struct FacadeSpec {
    const char* name;
    Eigen::Vector3d normal, top_left;
    double width, height;
    cv::Scalar colour;
    float shade;
  };
  const FacadeSpec facades[] = {
      {"facade_east",
       -Eigen::Vector3d::UnitX(),
       {32.0, 20.0, 18.0},
       40.0,
       18.0,
       {80, 90, 150},
       0.9f},
      {"facade_north",
       -Eigen::Vector3d::UnitY(),
       {-25.0, 28.0, 12.0},
       30.0,
       12.0,
       {170, 180, 185},
       0.75f},
      {"facade_west",
       Eigen::Vector3d::UnitX(),
       {-30.0, -12.0, 24.0},
       26.0,
       24.0,
       {150, 190, 210},
       1.0f},
      {"facade_south",
       Eigen::Vector3d::UnitY(),
       {20.0, -26.0, 15.0},
       30.0,
       15.0,
       {120, 140, 160},
       0.85f},
  };
  for (const FacadeSpec& f : facades) {
    cv::RNG rng = builder.NextRng();
    builder.AddVertical(f.name, f.normal, f.top_left, Facade(f.width, f.height, f.colour, rng),
                        f.shade);
  }
  return std::move(builder.scene());
}

Scene BuildCheckerboard(const CheckerboardOptions& options, uint32_t seed) {
  SceneBuilder builder("checkerboard", seed);
  builder.scene().background = cv::Vec3f(90.f, 90.f, 90.f);
  // 64 texels per square keep square edges on texel boundaries down to mip level 6.
  const double texel = options.square_m / 64.0;
  const double width = (options.squares_x + 2) * options.square_m;
  const double height = (options.squares_y + 2) * options.square_m;
  Canvas board(width, height, texel, cv::Scalar(235, 235, 235));
  for (int j = 0; j < options.squares_y; ++j) {
    for (int i = 0; i < options.squares_x; ++i) {
      if ((i + j) % 2 == 0) {
        board.Fill((i + 1) * options.square_m, (j + 1) * options.square_m, options.square_m,
                   options.square_m, cv::Scalar(20, 20, 20));
      }
    }
  }
  builder.AddVertical("checkerboard", -Eigen::Vector3d::UnitX(),
                      {kCheckerboardDistanceM, 0.5 * width, 1.0 + 0.5 * height}, board, 1.0f);
  return std::move(builder.scene());
}

// A side of a person, `width_m` across: a head band, a shirt (striped, or with a print),
// trousers; textured enough to be tracked, as most clothes are.
Canvas PersonSide(double width_m, double height_m, const cv::Scalar& shirt,
                  const cv::Scalar& trousers, bool stripes, cv::RNG& rng) {
  constexpr double kHeadM = 0.25, kWaistM = 0.95;
  Canvas c(width_m, height_m, 0.004, trousers);
  c.Fill(0.0, 0.0, width_m, kHeadM, Jitter(cv::Scalar(90, 120, 170), 40, rng));
  c.Fill(0.0, kHeadM, width_m, kWaistM - kHeadM, shirt);
  if (stripes) {
    const cv::Scalar stripe = RandomColour(rng);
    for (double b = kHeadM + 0.03; b < kWaistM; b += 0.07) c.Fill(0.0, b, width_m, 0.025, stripe);
  } else {
    c.Text(RandomWord(rng, 3), 0.05 * width_m, kHeadM + 0.2, 0.08, RandomColour(rng));
  }
  c.Mottle(0.05, 14.0, rng);
  c.Flecks(0.006, 0.02, cv::Scalar(30, 30, 30), rng);
  c.Grain(6.0, rng);
  return c;
}

// People crossing the walking camera's view, evenly spread over the duration: each walks
// at 1.3 m/s square to where the camera looks halfway through its crossing, 1.8-3 m ahead
// of it, for 2.6 s, and is not in the scene before or after. A person is a box 0.45 m
// square and 1.75 m tall; walls and furniture do not stop them.
Scene AddPeople(Scene scene, const Scenario& scenario) {
  constexpr double kSpeedMps = 1.3, kCrossingS = 2.6, kSideM = 0.45, kHeightM = 1.75;
  const Trajectory trajectory(scenario.motion, scenario.scene);
  SceneBuilder builder(std::move(scene), scenario.seed);
  for (int i = 0; i < scenario.people; ++i) {
    cv::RNG rng(MixSeed(scenario.seed, kPeopleStream, static_cast<uint64_t>(i)));
    const double middle_s = (i + 0.5) * scenario.seconds / scenario.people;
    Eigen::Vector3d ahead = trajectory.WorldFromCamAt(middle_s).col(2);
    ahead.z() = 0.0;
    ahead.normalize();
    const Eigen::Vector3d left = kUp.cross(ahead);
    const Eigen::Vector3d heading = rng.uniform(0, 2) == 0 ? left : Eigen::Vector3d(-left);
    const Eigen::Vector3d side = kUp.cross(heading);
    Eigen::Vector3d middle = trajectory.PositionAt(middle_s) + rng.uniform(1.8, 3.0) * ahead;
    middle.z() = 0.0;
    const Eigen::Vector3d velocity = kSpeedMps * heading;
    // Where the person's centre is at t = 0, on the line it walks.
    const Eigen::Vector3d centre_at_zero = middle - middle_s * velocity;
    const cv::Scalar shirt = RandomColour(rng),
                     trousers = Jitter(RandomColour(rng, 30, 110), 10, rng);
    const bool stripes = rng.uniform(0, 2) == 0;
    const std::string name = "person" + std::to_string(i + 1);
    const size_t first = builder.scene().planes.size();
    const double half = 0.5 * kSideM;
    for (const auto& [suffix, normal, shade] :
         {std::tuple{"_front", heading, 0.9f},
          std::tuple{"_back", Eigen::Vector3d(-heading), 0.75f}, std::tuple{"_left", side, 0.85f},
          std::tuple{"_right", Eigen::Vector3d(-side), 0.8f}}) {
      const Eigen::Vector3d u = (-normal).cross(kUp);
      const Eigen::Vector3d top_left = centre_at_zero + half * normal - half * u + kHeightM * kUp;
      cv::RNG side_rng = builder.NextRng();
      builder.AddVertical(name + suffix, normal, top_left,
                          PersonSide(kSideM, kHeightM, shirt, trousers, stripes, side_rng), shade);
    }
    {
      cv::RNG top_rng = builder.NextRng();
      Canvas hair(kSideM, kSideM, 0.004, Jitter(cv::Scalar(40, 50, 60), 20, top_rng));
      hair.Mottle(0.04, 12.0, top_rng);
      builder.Add(name + "_top", centre_at_zero - half * heading + half * side + kHeightM * kUp,
                  heading, -side, hair, false, 1.0f);
    }
    for (size_t p = first; p < builder.scene().planes.size(); ++p) {
      Plane& plane = builder.scene().planes[p];
      plane.velocity_mps = velocity;
      plane.from_s = middle_s - 0.5 * kCrossingS;
      plane.until_s = middle_s + 0.5 * kCrossingS;
    }
  }
  return std::move(builder.scene());
}

// Scenario::surface_texture changes these scenes only.
bool UsesSurfaceTexture(const std::string& scene) {
  return scene == "office" || scene == "corridor";
}

// The scene without its people, cached.
std::shared_ptr<const Scene> BuildStillScene(const Scenario& scenario) {
  std::ostringstream key;
  key << scenario.scene << "/" << scenario.seed;
  if (UsesSurfaceTexture(scenario.scene)) key << "/" << scenario.surface_texture;
  if (scenario.scene == "checkerboard") {
    key << "/" << scenario.checkerboard.squares_x << "x" << scenario.checkerboard.squares_y << "/"
        << scenario.checkerboard.square_m;
  }
  // Scenes are large (tens of MB of textures) and deterministic: share them while any
  // sequence still uses them.
  static std::mutex mutex;
  static std::map<std::string, std::weak_ptr<const Scene>> cache;
  std::lock_guard<std::mutex> lock(mutex);
  if (auto cached = cache[key.str()].lock()) return cached;
  std::shared_ptr<const Scene> scene;
  if (scenario.scene == "office") {
    scene = std::make_shared<const Scene>(BuildOffice(scenario.seed, scenario.surface_texture));
  } else if (scenario.scene == "corridor") {
    scene = std::make_shared<const Scene>(BuildCorridor(scenario.seed, scenario.surface_texture));
  } else if (scenario.scene == "outdoor") {
    scene = std::make_shared<const Scene>(BuildOutdoor(scenario.seed));
  } else if (scenario.scene == "checkerboard") {
    scene = std::make_shared<const Scene>(BuildCheckerboard(scenario.checkerboard, scenario.seed));
  } else {
    throw Error("unknown scene '" + scenario.scene +
                "', expected office, corridor, outdoor or checkerboard");
  }
  cache[key.str()] = scene;
  return scene;
}

}  // namespace

std::vector<std::string> SceneNames() { return {"office", "corridor", "outdoor", "checkerboard"}; }

std::shared_ptr<const Scene> BuildScene(const Scenario& scenario) {
  std::shared_ptr<const Scene> scene = BuildStillScene(scenario);
  // The people's planes go on a copy, which shares the scene's texture pixels.
  if (scenario.people > 0) return std::make_shared<const Scene>(AddPeople(*scene, scenario));
  return scene;
}

}  // namespace autocal
