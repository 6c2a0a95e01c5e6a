#include "pipeline/radon_snake.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace autocal {

bool SnakeOptions::Check(std::string* error) const {
  std::ostringstream why;
  if (!(spacing_px >= 3)) {
    why << "spacing_px must be at least 3";
  } else if (!(search_px > 0 && search_px < spacing_px)) {
    why << "search_px must be positive and below spacing_px";
  } else if (!(min_edge_strength > 0)) {
    why << "min_edge_strength must be positive";
  } else if (!(max_bend_change_deg > 0 && max_bend_change_deg < 90)) {
    why << "max_bend_change_deg must be in (0, 90)";
  } else if (!(min_length_px >= 2 * spacing_px)) {
    why << "min_length_px must be at least two spacings";
  } else if (max_grow_per_frame < 0) {
    why << "max_grow_per_frame must not be negative";
  } else if (!(border_margin_px >= 1)) {
    why << "border_margin_px must be at least 1 (the gradient needs a neighbour)";
  } else if (!(seed_max_distance > 0 && seed_max_distance <= 1)) {
    why << "seed_max_distance must be in (0, 1]";
  } else if (max_snakes < 1) {
    why << "max_snakes must be at least 1";
  }
  if (why.str().empty()) return true;
  if (error) *error = why.str();
  return false;
}

namespace {

// Signed turn at b on the way a -> b -> c, degrees.
double Bend(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c) {
  const Eigen::Vector2d ab = b - a, bc = c - b;
  return std::atan2(ab.x() * bc.y() - ab.y() * bc.x(), ab.dot(bc)) * 180.0 / M_PI;
}

}  // namespace

std::vector<double> RadonSnake::BendAngles() const {
  std::vector<double> bends;
  for (size_t i = 1; i + 1 < vertices.size(); ++i) {
    bends.push_back(Bend(vertices[i - 1], vertices[i], vertices[i + 1]));
  }
  return bends;
}

std::vector<Eigen::Vector2d> RadonSnake::InnerVertices() const {
  if (vertices.size() < 3) return {};
  return std::vector<Eigen::Vector2d>(vertices.begin() + 1, vertices.end() - 1);
}

double RadonSnake::Length() const {
  double length = 0.0;
  for (size_t i = 1; i < vertices.size(); ++i) length += (vertices[i] - vertices[i - 1]).norm();
  return length;
}

namespace {

// How far a hinge may stray from the snake's common motion in one frame, px.
constexpr double kNarrowSearchPx = 2.0;

bool Inside(const Eigen::Vector2d& p, cv::Size size, double margin) {
  return p.x() >= margin && p.y() >= margin && p.x() <= size.width - 1 - margin &&
         p.y() <= size.height - 1 - margin;
}

Eigen::Vector2d LeftNormal(const Eigen::Vector2d& tangent) {
  return Eigen::Vector2d(-tangent.y(), tangent.x()).normalized();
}

Eigen::Vector2d Tangent(const std::vector<Eigen::Vector2d>& v, size_t i) {
  const size_t before = i == 0 ? 0 : i - 1;
  const size_t after = std::min(i + 1, v.size() - 1);
  return (v[after] - v[before]).normalized();
}

// Points every `spacing` along the polyline, from its first vertex to its last.
std::vector<Eigen::Vector2d> Resample(const std::vector<Eigen::Vector2d>& polyline,
                                      double spacing) {
  std::vector<Eigen::Vector2d> points = {polyline.front()};
  double to_next = spacing;  // Arc length still to go before the next point.
  for (size_t i = 1; i < polyline.size(); ++i) {
    const Eigen::Vector2d a = polyline[i - 1], b = polyline[i];
    const double length = (b - a).norm();
    double at = 0.0;
    while (length - at >= to_next) {
      at += to_next;
      points.push_back(a + (b - a) * (at / length));
      to_next = spacing;
    }
    to_next -= length - at;
  }
  // Keep the true end unless it is almost on the last point.
  if ((polyline.back() - points.back()).norm() > 0.5 * spacing) points.push_back(polyline.back());
  return points;
}

// Finds the snake's edge near `point` along `normal`. An edge whose gradient does not
// point along the normal runs across the snake (a corner, a T-junction, an occluding
// outline) and is not the snake's edge, even where it is the strongest one found.
bool LockOne(const Gradients& gradients, const Eigen::Vector2d& point,
             const Eigen::Vector2d& normal, double search, double min_strength, int polarity,
             Eigen::Vector2d* edge) {
  constexpr double kMaxAcross = 0.36;  // tan(20 deg)
  if (!LocateEdgeAlongNormal(gradients, point, normal, search, min_strength, edge, polarity)) {
    return false;
  }
  const Eigen::Vector2d tangent(normal.y(), -normal.x());
  return std::abs(gradients.Directional(*edge, tangent)) <=
         kMaxAcross * std::abs(gradients.Directional(*edge, normal));
}

// Moves every vertex onto the edge along its normal, with the edge sign `polarities`
// gives it (any sign where that is empty); returns which ones locked.
std::vector<bool> Lock(std::vector<Eigen::Vector2d>* vertices, const Gradients& gradients,
                       double search, double min_strength,
                       const std::vector<int>& polarities = {}) {
  std::vector<Eigen::Vector2d>& v = *vertices;
  std::vector<Eigen::Vector2d> moved = v;
  std::vector<bool> locked(v.size(), false);
  for (size_t i = 0; i < v.size(); ++i) {
    const Eigen::Vector2d normal = LeftNormal(Tangent(v, i));
    const int polarity = polarities.empty() ? 0 : polarities[i];
    locked[i] = LockOne(gradients, v[i], normal, search, min_strength, polarity, &moved[i]);
  }
  v = moved;
  return locked;
}

// The median of the bends at the inner vertices [begin, end) of a polyline, skipping
// `skip`; 0 when there are none.
double MedianBend(const std::vector<Eigen::Vector2d>& v, size_t begin, size_t end,
                  size_t skip = 0) {
  std::vector<double> bends;
  for (size_t i = std::max<size_t>(begin, 1); i < std::min(end, v.size() - 1); ++i) {
    if (i != skip) bends.push_back(Bend(v[i - 1], v[i], v[i + 1]));
  }
  if (bends.empty()) return 0.0;
  std::nth_element(bends.begin(), bends.begin() + bends.size() / 2, bends.end());
  return bends[bends.size() / 2];
}

// How many neighbours on each side a hinge's bend is compared with: the lens bends a line
// more toward the border, so only nearby bends are a fair reference.
constexpr size_t kBendNeighbours = 3;

// The bend change past which a hinge of `v` counts as off its edge: three times the
// polyline's own scatter of bend changes, within [lowest_deg, highest_deg]. Real texture
// and JPEG put hinges 0.2-0.4 px off a smooth curve, which at a 12 px spacing scatters the
// bends by 2-5 deg, against a few hundredths of a pixel on a clean edge; a jump to another
// edge 2 px away bends by some 20 deg. Too short a polyline to say takes `lowest_deg`.
double BendTolerance(const std::vector<Eigen::Vector2d>& v, double lowest_deg,
                     double highest_deg) {
  std::vector<double> changes;
  for (size_t i = 1; i + 1 < v.size(); ++i) {
    const size_t from = i > kBendNeighbours ? i - kBendNeighbours : 1;
    changes.push_back(std::abs(Bend(v[i - 1], v[i], v[i + 1]) -
                               MedianBend(v, from, i + kBendNeighbours + 1, i)));
  }
  if (changes.size() < 5) return lowest_deg;
  std::nth_element(changes.begin(), changes.begin() + changes.size() / 2, changes.end());
  const double scatter = 1.4826 * changes[changes.size() / 2];
  return std::clamp(3.0 * scatter, lowest_deg, std::max(lowest_deg, highest_deg));
}

// How far a snake's bend change may go: with adaptive_bend up to four times the option,
// so that an edge through clutter is still cut.
double HighestTolerance(const SnakeOptions& options) {
  return (options.adaptive_bend ? 4.0 : 1.0) * options.max_bend_change_deg;
}

// The lens bends a world line smoothly, so a hinge bends about as much as its
// neighbours; a hinge that jumped to another edge, or an end that turned a corner onto
// another line, bends unlike them. Cuts the polyline at such hinges and keeps its longest
// run (with the matching entries of `locked`).
void KeepLongestSmoothRun(std::vector<Eigen::Vector2d>* vertices, std::vector<bool>* locked,
                          double lowest_deg, double highest_deg) {
  std::vector<Eigen::Vector2d>& v = *vertices;
  std::vector<bool> kinked(v.size(), false);
  const double tolerance = BendTolerance(v, lowest_deg, highest_deg);
  while (true) {
    double worst = tolerance;
    size_t worst_index = 0;
    for (size_t i = 1; i + 1 < v.size(); ++i) {
      if (kinked[i]) continue;
      const size_t from = i > kBendNeighbours ? i - kBendNeighbours : 1;
      const double typical = MedianBend(v, from, i + kBendNeighbours + 1, i);
      const double change = std::abs(Bend(v[i - 1], v[i], v[i + 1]) - typical);
      if (change > worst) {
        worst = change;
        worst_index = i;
      }
    }
    if (worst_index == 0) break;
    kinked[worst_index] = true;
    // Straighten it so that its neighbours' bends are judged on their own.
    v[worst_index] = 0.5 * (v[worst_index - 1] + v[worst_index + 1]);
  }
  size_t run_begin = 0, best_begin = 0, best_end = 0;
  for (size_t i = 0; i <= v.size(); ++i) {
    if (i < v.size() && !kinked[i]) continue;
    if (i - run_begin > best_end - best_begin) {
      best_begin = run_begin;
      best_end = i;
    }
    run_begin = i + 1;
  }
  v = std::vector<Eigen::Vector2d>(v.begin() + best_begin, v.begin() + best_end);
  *locked = std::vector<bool>(locked->begin() + best_begin, locked->begin() + best_end);
}

// Sign of the edge across the polyline's left normal at each vertex.
std::vector<int> EdgeSigns(const std::vector<Eigen::Vector2d>& v, const Gradients& gradients) {
  std::vector<int> signs(v.size());
  for (size_t i = 0; i < v.size(); ++i) {
    signs[i] = gradients.Directional(v[i], LeftNormal(Tangent(v, i))) > 0 ? 1 : -1;
  }
  return signs;
}

// One frame of tracking. Returns false when the snake lost its edge.
// `lowest_deg`: the least bend change tolerated (the option, or the image's edge noise).
bool Track(RadonSnake* snake, const Gradients& gradients, const SnakeOptions& options,
           cv::Size size, double lowest_deg) {
  std::vector<Eigen::Vector2d>& v = snake->vertices;
  // Slide every hinge along its normal onto the edge in two passes: a wide search whose
  // median displacement says how far the whole snake moved, then a narrow one from there,
  // so that a hinge near a parallel edge does not jump to it.
  std::vector<Eigen::Vector2d> normals(v.size());
  for (size_t i = 0; i < v.size(); ++i) normals[i] = LeftNormal(Tangent(v, i));
  std::vector<Eigen::Vector2d> wide = v;
  const std::vector<bool> found =
      Lock(&wide, gradients, options.search_px, options.min_edge_strength, snake->polarities);
  std::vector<double> shifts;
  for (size_t i = 0; i < v.size(); ++i) {
    if (found[i]) shifts.push_back(normals[i].dot(wide[i] - v[i]));
  }
  if (shifts.size() < 3) return false;
  std::nth_element(shifts.begin(), shifts.begin() + shifts.size() / 2, shifts.end());
  const double shift = shifts[shifts.size() / 2];
  for (size_t i = 0; i < v.size(); ++i) v[i] += shift * normals[i];
  std::vector<bool> locked =
      Lock(&v, gradients, kNarrowSearchPx, options.min_edge_strength, snake->polarities);
  for (size_t i = 0; i < v.size(); ++i) {
    locked[i] = locked[i] && Inside(v[i], size, options.border_margin_px);
  }

  KeepLongestSmoothRun(&v, &locked, lowest_deg, HighestTolerance(options));

  // Trim unlocked ends; a snake with too many lost hinges inside is gone.
  size_t first = 0, last = v.size();
  while (first < last && !locked[first]) ++first;
  while (last > first && !locked[last - 1]) --last;
  if (last - first < 3) return false;
  const size_t inner_locked = std::count(locked.begin() + first, locked.begin() + last, true);
  if (inner_locked < 0.7 * (last - first)) return false;
  v = std::vector<Eigen::Vector2d>(v.begin() + first, v.begin() + last);
  locked = std::vector<bool>(locked.begin() + first, locked.begin() + last);
  // Unlocked inner hinges follow their locked neighbours.
  for (size_t i = 1; i + 1 < v.size(); ++i) {
    if (locked[i]) continue;
    size_t next = i + 1;
    while (!locked[next]) ++next;
    v[i] = v[i - 1] + (v[next] - v[i - 1]) / double(next - i + 1);
  }

  // Grow at both ends while the edge goes on.
  const double tolerance = BendTolerance(v, lowest_deg, HighestTolerance(options));
  for (int end = 0; end < 2; ++end) {
    if (end == 1) std::reverse(v.begin(), v.end());
    for (int k = 0; k < options.max_grow_per_frame; ++k) {
      const Eigen::Vector2d tangent = (v.back() - v[v.size() - 2]).normalized();
      Eigen::Vector2d candidate = v.back() + options.spacing_px * tangent;
      if (!Inside(candidate, size, options.border_margin_px)) break;
      // Either sign: the edge may change sign where it runs on (a checkerboard).
      if (!LockOne(gradients, candidate, LeftNormal(tangent), 0.25 * options.spacing_px,
                   options.min_edge_strength, 0, &candidate) ||
          !Inside(candidate, size, options.border_margin_px)) {
        break;
      }
      // Growing round a corner onto another line is not following the edge.
      const double bend = Bend(v[v.size() - 2], v.back(), candidate);
      const size_t from = v.size() > kBendNeighbours + 1 ? v.size() - kBendNeighbours - 1 : 1;
      if (std::abs(bend - MedianBend(v, from, v.size())) > tolerance) break;
      v.push_back(candidate);
    }
    if (end == 1) std::reverse(v.begin(), v.end());
  }

  // Even spacing again, then each resampled hinge back onto the curve (resampling
  // puts points on chords, a little inside a bend).
  v = Resample(v, options.spacing_px);
  if (v.size() < 3) return false;
  std::vector<Eigen::Vector2d> relocked = v;
  const std::vector<bool> on_edge = Lock(&relocked, gradients, 1.0, options.min_edge_strength);
  for (size_t i = 0; i < v.size(); ++i) {
    if (on_edge[i] && Inside(relocked[i], size, options.border_margin_px)) v[i] = relocked[i];
  }
  std::vector<bool> all_locked(v.size(), true);
  KeepLongestSmoothRun(&v, &all_locked, lowest_deg, HighestTolerance(options));
  if (v.size() < 3) return false;
  snake->polarities = EdgeSigns(v, gradients);
  ++snake->age;
  return snake->Length() >= options.min_length_px;
}

// Distance from a point to a polyline.
double DistanceToPolyline(const Eigen::Vector2d& p, const std::vector<Eigen::Vector2d>& polyline) {
  double best = std::numeric_limits<double>::infinity();
  for (size_t i = 1; i < polyline.size(); ++i) {
    const Eigen::Vector2d a = polyline[i - 1], ab = polyline[i] - a;
    const double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
    best = std::min(best, (a + t * ab - p).norm());
  }
  return best;
}

}  // namespace

void SnakeTracker::Update(const Gradients& gradients, const std::vector<LineSegment>& lines,
                          const Eigen::Vector2d& principal_point, cv::Size image_size) {
  // The image's edge noise, from the snakes long enough to show it, for those too short:
  // a seed of a few hinges on a noisy edge would otherwise be cut at its first bend.
  std::vector<double> tolerances;
  for (const RadonSnake& snake : snakes_) {
    if (options_.adaptive_bend && snake.vertices.size() >= 8) {
      tolerances.push_back(BendTolerance(snake.vertices, options_.max_bend_change_deg,
                                         HighestTolerance(options_)));
    }
  }
  double lowest = options_.max_bend_change_deg;
  if (tolerances.size() >= 3) {
    std::nth_element(tolerances.begin(), tolerances.begin() + tolerances.size() / 2,
                     tolerances.end());
    lowest = tolerances[tolerances.size() / 2];
  }
  std::vector<RadonSnake> kept;
  for (RadonSnake& snake : snakes_) {
    if (Track(&snake, gradients, options_, image_size, lowest)) kept.push_back(std::move(snake));
  }
  snakes_ = std::move(kept);

  const double half_diagonal = 0.5 * std::hypot(image_size.width, image_size.height);
  for (const LineSegment& line : lines) {
    if (int(snakes_.size()) >= options_.max_snakes) break;
    if (line.Length() < options_.min_length_px) continue;
    if (std::abs(line.Distance(principal_point)) > options_.seed_max_distance * half_diagonal) {
      continue;
    }
    // A line some snake already follows is not seeded twice.
    const Eigen::Vector2d middle = 0.5 * (line.start + line.end);
    const bool followed = std::any_of(snakes_.begin(), snakes_.end(), [&](const RadonSnake& s) {
      return DistanceToPolyline(middle, s.vertices) < 2.0;
    });
    if (followed) continue;
    RadonSnake snake;
    snake.vertices = Resample({line.start, line.end}, options_.spacing_px);
    if (snake.vertices.size() < 3) continue;
    const std::vector<bool> locked =
        Lock(&snake.vertices, gradients, 1.5, options_.min_edge_strength);
    if (std::count(locked.begin(), locked.end(), false) > 0) continue;
    snake.polarities = EdgeSigns(snake.vertices, gradients);
    snake.id = next_id_++;
    snakes_.push_back(std::move(snake));
  }
}

void SnakeTracker::Seed(const Gradients& gradients,
                        const std::vector<std::vector<Eigen::Vector2d>>& polylines,
                        double search_px, cv::Size image_size) {
  for (const std::vector<Eigen::Vector2d>& polyline : polylines) {
    if (int(snakes_.size()) >= options_.max_snakes) break;
    if (polyline.size() < 2) continue;
    const Eigen::Vector2d middle = polyline[polyline.size() / 2];
    const bool followed = std::any_of(snakes_.begin(), snakes_.end(), [&](const RadonSnake& s) {
      return DistanceToPolyline(middle, s.vertices) < 2.0;
    });
    if (followed) continue;
    std::vector<Eigen::Vector2d> v = Resample(polyline, options_.spacing_px);
    if (v.size() < 3) continue;
    std::vector<bool> locked = Lock(&v, gradients, search_px, options_.min_edge_strength);
    for (size_t i = 0; i < v.size(); ++i) {
      locked[i] = locked[i] && Inside(v[i], image_size, options_.border_margin_px);
    }
    size_t begin = 0, best_begin = 0, best_end = 0;
    for (size_t i = 0; i <= v.size(); ++i) {
      if (i < v.size() && locked[i]) continue;
      if (i - begin > best_end - best_begin) {
        best_begin = begin;
        best_end = i;
      }
      begin = i + 1;
    }
    if (best_end - best_begin < 3) continue;
    // Shorter than a seed may be: growing along its edge, it reaches its length or is
    // dropped when next tracked, as a snake that lost its edge is.
    RadonSnake snake;
    snake.vertices.assign(v.begin() + best_begin, v.begin() + best_end);
    snake.polarities = EdgeSigns(snake.vertices, gradients);
    snake.id = next_id_++;
    snakes_.push_back(std::move(snake));
  }
}

}  // namespace autocal
