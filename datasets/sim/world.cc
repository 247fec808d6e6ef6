#include "datasets/sim/world.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <utility>

#include "core/euler.h"
#include "glog/logging.h"

namespace hetslam {
namespace sim {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

double Cross(const Eigen::Vector2d& u, const Eigen::Vector2d& v) {
  return u.x() * v.y() - u.y() * v.x();
}

// Orientation of the triangle (p, q, r): +1 counter-clockwise, -1 clockwise, 0 collinear.
int Orientation(const Eigen::Vector2d& p, const Eigen::Vector2d& q, const Eigen::Vector2d& r) {
  const double c = Cross(q - p, r - p);
  const double scale = (q - p).norm() * (r - p).norm();
  if (std::abs(c) <= 1e-12 * scale) return 0;
  return c > 0.0 ? 1 : -1;
}

// For collinear p, q, r: is r within the bounding box of p..q?
bool OnSegment(const Eigen::Vector2d& p, const Eigen::Vector2d& q, const Eigen::Vector2d& r) {
  return r.x() <= std::max(p.x(), q.x()) && r.x() >= std::min(p.x(), q.x()) &&
         r.y() <= std::max(p.y(), q.y()) && r.y() >= std::min(p.y(), q.y());
}

bool SegmentsIntersect(const Eigen::Vector2d& p1, const Eigen::Vector2d& q1,
                       const Eigen::Vector2d& p2, const Eigen::Vector2d& q2) {
  const int o1 = Orientation(p1, q1, p2), o2 = Orientation(p1, q1, q2);
  const int o3 = Orientation(p2, q2, p1), o4 = Orientation(p2, q2, q1);
  if (o1 != o2 && o3 != o4) return true;
  if (o1 == 0 && OnSegment(p1, q1, p2)) return true;
  if (o2 == 0 && OnSegment(p1, q1, q2)) return true;
  if (o3 == 0 && OnSegment(p2, q2, p1)) return true;
  if (o4 == 0 && OnSegment(p2, q2, q1)) return true;
  return false;
}

// The distance t >= 0 along the ray origin + t * d (|d| = 1) to `wall`, or +infinity when the
// ray misses it or runs parallel to it. The one intersection formula of CastRay and CastRays.
double RayWallDistance(const Eigen::Vector2d& origin, const Eigen::Vector2d& d,
                       const WallSegment& wall) {
  // origin + t d = a + s e  =>  t = (w x e) / (d x e),  s = (w x d) / (d x e),  w = a - origin.
  const Eigen::Vector2d e = wall.b - wall.a;
  const double denom = Cross(d, e);
  if (std::abs(denom) <= 1e-12 * e.norm()) return std::numeric_limits<double>::infinity();
  const Eigen::Vector2d w = wall.a - origin;
  const double t = Cross(w, e) / denom;
  const double s = Cross(w, d) / denom;
  if (t < 0.0 || s < 0.0 || s > 1.0) return std::numeric_limits<double>::infinity();
  return t;
}

double PointSegmentDistance(const Eigen::Vector2d& p, const Eigen::Vector2d& a,
                            const Eigen::Vector2d& b) {
  const Eigen::Vector2d ab = b - a;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0.0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return (a + t * ab - p).norm();
}

// Nearest hit of the 3D ray o + t d (any d, t >= 0) with a wall rectangle segment x
// [0, wall_height], or +infinity.
double RayWall3DDistance(const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                         const WallSegment& wall, double wall_height) {
  const Eigen::Vector2d d_xy(d.x(), d.y());
  const Eigen::Vector2d e = wall.b - wall.a;
  const double denom = Cross(d_xy, e);
  if (std::abs(denom) <= 1e-12 * e.norm() * d.norm()) {
    return std::numeric_limits<double>::infinity();  // vertical or parallel: grazing
  }
  const Eigen::Vector2d w = wall.a - Eigen::Vector2d(o.x(), o.y());
  const double t = Cross(w, e) / denom;
  const double s = Cross(w, d_xy) / denom;
  if (t < 0.0 || s < 0.0 || s > 1.0) return std::numeric_limits<double>::infinity();
  const double z = o.z() + t * d.z();
  if (z < 0.0 || z > wall_height) return std::numeric_limits<double>::infinity();
  return t;
}

// Entry distance of the ray o + t d (t >= 0) into a convex prism by slab clipping
// (Cyrus-Beck): each side face and the two caps bound t; the ray is inside where all
// half-spaces hold. 0 when o is inside, +infinity on a miss.
double RayPrismDistance(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const Prism& prism) {
  constexpr double kInfinity = std::numeric_limits<double>::infinity();
  double t_in = 0.0, t_out = kInfinity;
  // Half-space n . x <= c, written as num + t * den <= 0 with num = n . o - c, den = n . d.
  auto clip = [&](double num, double den) {
    if (den == 0.0) return num <= 0.0;
    const double t = -num / den;
    if (den < 0.0) {
      t_in = std::max(t_in, t);
    } else {
      t_out = std::min(t_out, t);
    }
    return t_in <= t_out;
  };
  if (!clip(prism.z_min_meters - o.z(), -d.z())) return kInfinity;  // z >= z_min
  if (!clip(o.z() - prism.z_max_meters, d.z())) return kInfinity;   // z <= z_max
  const std::vector<Eigen::Vector2d>& v = prism.footprint;
  for (size_t i = 0; i < v.size(); ++i) {
    const Eigen::Vector2d& p = v[i];
    const Eigen::Vector2d e = v[(i + 1) % v.size()] - p;
    const Eigen::Vector2d n(e.y(), -e.x());  // outward for a counter-clockwise polygon
    if (!clip(n.x() * (o.x() - p.x()) + n.y() * (o.y() - p.y()), n.x() * d.x() + n.y() * d.y())) {
      return kInfinity;
    }
  }
  return t_in;
}

// Horizontal distance from p to a convex counter-clockwise polygon (0 inside).
double PointPolygonDistance(const Eigen::Vector2d& p, const std::vector<Eigen::Vector2d>& v) {
  bool inside = true;
  double best = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < v.size(); ++i) {
    const Eigen::Vector2d& a = v[i];
    const Eigen::Vector2d& b = v[(i + 1) % v.size()];
    if (Cross(b - a, p - a) < 0.0) inside = false;
    best = std::min(best, PointSegmentDistance(p, a, b));
  }
  return inside ? 0.0 : best;
}

// Signed area (twice) of a polygon: > 0 counter-clockwise.
double TwiceSignedArea(const std::vector<Eigen::Vector2d>& v) {
  double area = 0.0;
  for (size_t i = 0; i < v.size(); ++i) area += Cross(v[i], v[(i + 1) % v.size()]);
  return area;
}

std::vector<Eigen::Vector2d> RectangleCorners(const Eigen::Vector2d& center,
                                              const Eigen::Vector2d& size, double yaw) {
  const Pose2 world_T_box(center, yaw);
  const double hx = 0.5 * size.x(), hy = 0.5 * size.y();
  return {world_T_box * Eigen::Vector2d(-hx, -hy), world_T_box * Eigen::Vector2d(hx, -hy),
          world_T_box * Eigen::Vector2d(hx, hy), world_T_box * Eigen::Vector2d(-hx, hy)};
}

// ---- Scenario parsing -----------------------------------------------------------------------

// Splits a line into white-space separated tokens, dropping a '#' comment.
std::vector<std::string> Tokenize(const std::string& line) {
  const std::string content = line.substr(0, line.find('#'));
  std::istringstream stream(content);
  std::vector<std::string> tokens;
  std::string token;
  while (stream >> token) tokens.push_back(token);
  return tokens;
}

// Context for error messages of one line.
struct LineContext {
  const std::string& source;
  int line_number;
  Status Error(const std::string& message) const {
    return Status::Error(source + ":" + std::to_string(line_number) + ": " + message);
  }
};

// Parses tokens[1..] as exactly `expected` finite numbers (or between `expected` and
// `expected_max` when the latter is larger).
Status ParseNumbers(const std::vector<std::string>& tokens, size_t expected, size_t expected_max,
                    const std::string& usage, const LineContext& context,
                    std::vector<double>* values) {
  const size_t given = tokens.size() - 1;
  if (given < expected || given > std::max(expected, expected_max)) {
    return context.Error("'" + tokens[0] + "' takes " +
                         (expected_max > expected ? std::to_string(expected) + " or " +
                                                        std::to_string(expected_max)
                                                  : std::to_string(expected)) +
                         " numbers (" + usage + "), got " + std::to_string(given));
  }
  values->clear();
  for (size_t i = 1; i < tokens.size(); ++i) {
    const std::string& token = tokens[i];
    char* end = nullptr;
    errno = 0;
    const double value = std::strtod(token.c_str(), &end);
    if (end == token.c_str() || *end != '\0') {
      return context.Error("'" + tokens[0] + "' field " + std::to_string(i) + " '" + token +
                           "' is not a number (" + usage + ")");
    }
    if (!std::isfinite(value) || errno == ERANGE) {
      return context.Error("'" + tokens[0] + "' field " + std::to_string(i) + " '" + token +
                           "' is not a finite number");
    }
    values->push_back(value);
  }
  return Status::Ok();
}

bool IsInteger(double value) { return std::floor(value) == value; }

std::string Fixed(double value, int digits) {
  std::ostringstream os;
  os.setf(std::ios::fixed);
  os.precision(digits);
  os << value;
  return os.str();
}

}  // namespace

// ---- World ----------------------------------------------------------------------------------

const char* SurfaceName(Surface surface) {
  switch (surface) {
    case Surface::kNone: return "none";
    case Surface::kFloor: return "floor";
    case Surface::kCeiling: return "ceiling";
    case Surface::kWall: return "wall";
    case Surface::kFurniture: return "furniture";
    case Surface::kObstacle: return "obstacle";
  }
  return "unknown";
}

void World::AddWall(const Eigen::Vector2d& a, const Eigen::Vector2d& b, int source_line) {
  CHECK(a.allFinite() && b.allFinite()) << "wall end points must be finite: (" << a.transpose()
                                        << ") (" << b.transpose() << ")";
  CHECK_GT((b - a).norm(), 0.0) << "zero-length wall at (" << a.transpose() << ")";
  walls_.push_back({a, b, source_line});
}

void World::AddBox(const Eigen::Vector2d& center, const Eigen::Vector2d& size_meters,
                   double yaw_radians, int source_line) {
  CHECK(size_meters.x() > 0.0 && size_meters.y() > 0.0)
      << "box size must be positive: " << size_meters.transpose();
  const std::vector<Eigen::Vector2d> corners = RectangleCorners(center, size_meters, yaw_radians);
  for (int i = 0; i < 4; ++i) AddWall(corners[i], corners[(i + 1) % 4], source_line);
}

void World::AddPrism(std::vector<Eigen::Vector2d> footprint, double z_min_meters,
                     double z_max_meters, Surface surface, int source_line) {
  CHECK_GE(footprint.size(), 3u) << "a prism footprint needs at least three vertices";
  CHECK(std::isfinite(z_min_meters) && std::isfinite(z_max_meters) && z_min_meters >= 0.0 &&
        z_min_meters < z_max_meters)
      << "prism heights must satisfy 0 <= z_min < z_max: " << z_min_meters << " "
      << z_max_meters;
  CHECK(surface == Surface::kFurniture || surface == Surface::kObstacle)
      << "a prism is furniture or an obstacle, got " << SurfaceName(surface);
  for (const Eigen::Vector2d& p : footprint) CHECK(p.allFinite()) << "non-finite footprint";
  if (TwiceSignedArea(footprint) < 0.0) std::reverse(footprint.begin(), footprint.end());
  const size_t n = footprint.size();
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d& a = footprint[i];
    const Eigen::Vector2d& b = footprint[(i + 1) % n];
    const Eigen::Vector2d& c = footprint[(i + 2) % n];
    CHECK_GT(Cross(b - a, c - b), 0.0) << "prism footprint must be strictly convex (vertex "
                                       << (i + 1) % n << ")";
  }
  prisms_.push_back({std::move(footprint), z_min_meters, z_max_meters, surface, source_line});
}

void World::AddBoxPrism(const Eigen::Vector2d& center, const Eigen::Vector2d& size_meters,
                        double yaw_radians, double z_min_meters, double z_max_meters,
                        Surface surface, int source_line) {
  CHECK(size_meters.x() > 0.0 && size_meters.y() > 0.0)
      << "box size must be positive: " << size_meters.transpose();
  AddPrism(RectangleCorners(center, size_meters, yaw_radians), z_min_meters, z_max_meters,
           surface, source_line);
}

void World::AddTable(const Eigen::Vector2d& center, const Eigen::Vector2d& size_meters,
                     double yaw_radians, double height_meters, int source_line,
                     const TableShape& shape) {
  const double leg_span = 2.0 * (shape.leg_inset_meters + shape.leg_width_meters);
  CHECK(size_meters.x() > leg_span && size_meters.y() > leg_span)
      << "table of " << size_meters.transpose() << " m too small for its legs";
  CHECK_GT(height_meters, shape.top_thickness_meters) << "table lower than its top";
  const double leg_top = height_meters - shape.top_thickness_meters;
  AddBoxPrism(center, size_meters, yaw_radians, leg_top, height_meters, Surface::kFurniture,
              source_line);
  const Pose2 world_T_table(center, yaw_radians);
  const double lx = 0.5 * size_meters.x() - shape.leg_inset_meters - 0.5 * shape.leg_width_meters;
  const double ly = 0.5 * size_meters.y() - shape.leg_inset_meters - 0.5 * shape.leg_width_meters;
  for (const Eigen::Vector2d& corner : {Eigen::Vector2d(-lx, -ly), Eigen::Vector2d(lx, -ly),
                                        Eigen::Vector2d(lx, ly), Eigen::Vector2d(-lx, ly)}) {
    AddBoxPrism(world_T_table * corner, Eigen::Vector2d::Constant(shape.leg_width_meters),
                yaw_radians, 0.0, leg_top, Surface::kFurniture, source_line);
  }
}

void World::AddShelf(const Eigen::Vector2d& back_a, const Eigen::Vector2d& back_b,
                     double lower_depth_meters, double lower_height_meters,
                     double upper_depth_meters, double height_meters, int source_line) {
  const Eigen::Vector2d along = back_b - back_a;
  CHECK_GT(along.norm(), 0.0) << "shelf back has zero length";
  CHECK(lower_depth_meters > 0.0 && upper_depth_meters > 0.0 && lower_height_meters > 0.0 &&
        height_meters > lower_height_meters)
      << "shelf sizes must be positive and height > lower height";
  const Eigen::Vector2d left = Eigen::Vector2d(-along.y(), along.x()).normalized();
  AddPrism({back_a, back_b, back_b + lower_depth_meters * left, back_a + lower_depth_meters * left},
           0.0, lower_height_meters, Surface::kFurniture, source_line);
  AddPrism({back_a, back_b, back_b + upper_depth_meters * left, back_a + upper_depth_meters * left},
           lower_height_meters, height_meters, Surface::kFurniture, source_line);
}

void World::SetHeights(double wall_height_meters, double ceiling_height_meters) {
  CHECK(wall_height_meters > 0.0 && ceiling_height_meters > 0.0)
      << "heights must be positive: wall " << wall_height_meters << ", ceiling "
      << ceiling_height_meters;
  wall_height_meters_ = wall_height_meters;
  ceiling_height_meters_ = ceiling_height_meters;
}

RayHit World::CastRay3D(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                        double max_range_meters) const {
  std::vector<RayHit> hits;
  CastRays3D(origin, {direction}, max_range_meters, &hits);
  return hits[0];
}

void World::CastRays3D(const Eigen::Vector3d& origin, const std::vector<Eigen::Vector3d>& directions,
                       double max_range_meters, std::vector<RayHit>* hits) const {
  CHECK(hits != nullptr);
  CHECK(origin.allFinite()) << "ray origin must be finite";
  hits->assign(directions.size(), RayHit());
  // Structures that can be hit at all: within max range of the origin, horizontally.
  const Eigen::Vector2d origin_xy(origin.x(), origin.y());
  std::vector<const WallSegment*> walls;
  for (const WallSegment& wall : walls_) {
    if (PointSegmentDistance(origin_xy, wall.a, wall.b) <= max_range_meters) {
      walls.push_back(&wall);
    }
  }
  std::vector<const Prism*> prisms;
  for (const Prism& prism : prisms_) {
    if (PointPolygonDistance(origin_xy, prism.footprint) <= max_range_meters) {
      prisms.push_back(&prism);
    }
  }
  for (size_t i = 0; i < directions.size(); ++i) {
    const double norm = directions[i].norm();
    CHECK(norm > 0.0 && std::isfinite(norm)) << "ray direction must be non-zero and finite";
    const Eigen::Vector3d d = directions[i] / norm;
    RayHit& best = (*hits)[i];
    auto consider = [&best](double t, Surface surface, int line) {
      if (t < best.range_meters) {
        best.range_meters = t;
        best.surface = surface;
        best.source_line = line;
      }
    };
    if (d.z() < 0.0 && origin.z() >= 0.0) consider(-origin.z() / d.z(), Surface::kFloor, 0);
    if (d.z() > 0.0 && std::isfinite(ceiling_height_meters_) &&
        origin.z() <= ceiling_height_meters_) {
      consider((ceiling_height_meters_ - origin.z()) / d.z(), Surface::kCeiling, 0);
    }
    for (const WallSegment* wall : walls) {
      consider(RayWall3DDistance(origin, d, *wall, wall_height_meters_), Surface::kWall,
               wall->source_line);
    }
    for (const Prism* prism : prisms) {
      consider(RayPrismDistance(origin, d, *prism), prism->surface, prism->source_line);
    }
    if (best.range_meters <= max_range_meters) {
      best.hit = true;
    } else {
      best = RayHit();
    }
  }
}

bool World::LineOfSight(const Eigen::Vector3d& p, const Eigen::Vector3d& q,
                        double end_margin_meters) const {
  const double distance = (q - p).norm();
  if (distance <= end_margin_meters) return true;
  const RayHit hit = CastRay3D(p, q - p, distance);
  return !hit.hit || hit.range_meters >= distance - end_margin_meters;
}

bool World::CastRay(const Eigen::Vector2d& origin, double angle_radians,
                    double max_range_meters, double* range_meters) const {
  CHECK(range_meters != nullptr);
  const Eigen::Vector2d d(std::cos(angle_radians), std::sin(angle_radians));
  double best = std::numeric_limits<double>::infinity();
  for (const WallSegment& wall : walls_) best = std::min(best, RayWallDistance(origin, d, wall));
  if (best > max_range_meters) return false;
  *range_meters = best;
  return true;
}

void World::CastRays(const Eigen::Vector2d& origin, const std::vector<double>& angles_radians,
                     double max_range_meters, std::vector<double>* ranges_meters) const {
  CHECK(ranges_meters != nullptr);
  constexpr double kInfinity = std::numeric_limits<double>::infinity();
  const size_t n = angles_radians.size();
  ranges_meters->assign(n, kInfinity);
  if (n == 0) return;
  // Rays sorted by wrapped angle in [-pi, pi); the directions use the caller's angles as given,
  // exactly as CastRay does, so both give the same numbers.
  std::vector<std::pair<double, int>> sorted(n);
  std::vector<Eigen::Vector2d> directions(n);
  for (size_t i = 0; i < n; ++i) {
    sorted[i] = {WrapAngle(angles_radians[i]), static_cast<int>(i)};
    directions[i] = Eigen::Vector2d(std::cos(angles_radians[i]), std::sin(angles_radians[i]));
  }
  std::sort(sorted.begin(), sorted.end());
  auto test_rays_in = [&](double lo, double hi, const WallSegment& wall) {
    auto it = std::lower_bound(sorted.begin(), sorted.end(), std::make_pair(lo, -1));
    for (; it != sorted.end() && it->first <= hi; ++it) {
      double& range = (*ranges_meters)[it->second];
      range = std::min(range, RayWallDistance(origin, directions[it->second], wall));
    }
  };
  // Widening of each wall's angular interval, so that rays through an end point are never
  // culled by rounding in atan2.
  constexpr double kSlackRadians = 1e-9;
  for (const WallSegment& wall : walls_) {
    const double distance = PointSegmentDistance(origin, wall.a, wall.b);
    if (distance > max_range_meters) continue;
    if (distance <= 1e-9) {
      // The origin is on (or within rounding of) the wall: rays leave it at t ~ 0 in almost
      // every direction. Test every ray, as CastRay does.
      test_rays_in(-M_PI - 1.0, M_PI + 1.0, wall);
      continue;
    }
    // The wall subtends the shorter arc (less than pi: the origin is off the segment) from
    // angle(pa) to angle(pb).
    const Eigen::Vector2d pa = wall.a - origin, pb = wall.b - origin;
    double start = WrapAngle(std::atan2(pa.y(), pa.x()));
    double width = WrapAngle(std::atan2(pb.y(), pb.x()) - start);
    if (width < 0.0) {
      start = WrapAngle(start + width);
      width = -width;
    }
    const double lo = start - kSlackRadians;
    const double hi = start + width + kSlackRadians;
    test_rays_in(lo, std::min(hi, M_PI), wall);
    if (lo < -M_PI) test_rays_in(lo + 2.0 * M_PI, M_PI, wall);
    if (hi >= M_PI) test_rays_in(-M_PI, hi - 2.0 * M_PI, wall);
  }
  for (double& range : *ranges_meters) {
    if (range > max_range_meters) range = kInfinity;
  }
}

bool World::SegmentHitsWall(const Eigen::Vector2d& p, const Eigen::Vector2d& q) const {
  for (const WallSegment& wall : walls_) {
    if (SegmentsIntersect(p, q, wall.a, wall.b)) return true;
  }
  return false;
}

double World::DistanceToNearestWall(const Eigen::Vector2d& p) const {
  double best = std::numeric_limits<double>::infinity();
  for (const WallSegment& wall : walls_) {
    best = std::min(best, PointSegmentDistance(p, wall.a, wall.b));
  }
  return best;
}

double World::DistanceToNearestStructure(const Eigen::Vector2d& p) const {
  double best = DistanceToNearestWall(p);
  for (const Prism& prism : prisms_) best = std::min(best, PointPolygonDistance(p, prism.footprint));
  return best;
}

Eigen::AlignedBox2d World::Bounds() const {
  Eigen::AlignedBox2d box;  // empty
  for (const WallSegment& wall : walls_) {
    box.extend(wall.a);
    box.extend(wall.b);
  }
  return box;
}

// ---- Options --------------------------------------------------------------------------------

bool LaserOptions::IsValid(std::string* error) const {
  std::ostringstream why;
  if (!(field_of_view_radians > 0.0 && field_of_view_radians <= 2.0 * M_PI + 1e-12)) {
    why << "laser field of view must be in (0, 360] degrees, got "
        << field_of_view_radians / kDegToRad;
  } else if (num_beams < 2 || num_beams > 100000) {
    why << "laser num_beams must be in [2, 100000], got " << num_beams;
  } else if (!(max_range_meters > 0.0 && max_range_meters <= 1000.0)) {
    why << "laser max range must be in (0, 1000] m, got " << max_range_meters;
  } else if (!(range_noise_std_meters >= 0.0 && range_noise_std_meters < max_range_meters)) {
    why << "laser range noise std must be in [0, max range), got " << range_noise_std_meters;
  } else if (!(dropout_probability >= 0.0 && dropout_probability < 1.0)) {
    why << "laser dropout probability must be in [0, 1), got " << dropout_probability;
  } else if (!(rate_hz > 0.0 && rate_hz <= 1000.0)) {
    why << "laser rate must be in (0, 1000] Hz, got " << rate_hz;
  }
  if (why.str().empty()) return true;
  if (error != nullptr) *error = why.str();
  return false;
}

double LaserOptions::AngleIncrementRadians() const {
  CHECK_GE(num_beams, 2) << "num_beams=" << num_beams;
  return num_beams % 2 == 1 ? field_of_view_radians / (num_beams - 1)
                            : field_of_view_radians / num_beams;
}

std::vector<double> LaserOptions::BeamAnglesRadians() const {
  const double increment = AngleIncrementRadians();
  std::vector<double> angles(num_beams);
  for (int i = 0; i < num_beams; ++i) angles[i] = -0.5 * field_of_view_radians + i * increment;
  return angles;
}

bool RobotOptions::IsValid(std::string* error) const {
  std::ostringstream why;
  if (!(max_speed_mps > 0.0 && max_speed_mps <= 20.0)) {
    why << "robot speed must be in (0, 20] m/s, got " << max_speed_mps;
  } else if (!(max_turn_rate_radps > 0.0 && max_turn_rate_radps <= 4.0 * M_PI)) {
    why << "robot turn rate must be in (0, 720] deg/s, got " << max_turn_rate_radps / kDegToRad;
  }
  if (why.str().empty()) return true;
  if (error != nullptr) *error = why.str();
  return false;
}

bool OdometryOptions::IsValid(std::string* error) const {
  std::ostringstream why;
  if (!(rate_hz > 0.0 && rate_hz <= 1000.0)) {
    why << "odometry rate must be in (0, 1000] Hz, got " << rate_hz;
  } else if (!(trans_noise_meters_per_sqrt_meter >= 0.0 &&
               std::isfinite(trans_noise_meters_per_sqrt_meter))) {
    why << "odometry translation noise must be finite and >= 0, got "
        << trans_noise_meters_per_sqrt_meter;
  } else if (!(rot_noise_radians_per_sqrt_meter >= 0.0 &&
               std::isfinite(rot_noise_radians_per_sqrt_meter))) {
    why << "odometry rotation noise per sqrt(m) must be finite and >= 0, got "
        << rot_noise_radians_per_sqrt_meter;
  } else if (!(rot_noise_radians_per_sqrt_radian >= 0.0 &&
               std::isfinite(rot_noise_radians_per_sqrt_radian))) {
    why << "odometry rotation noise per sqrt(rad) must be finite and >= 0, got "
        << rot_noise_radians_per_sqrt_radian;
  }
  if (why.str().empty()) return true;
  if (error != nullptr) *error = why.str();
  return false;
}

// ---- Team options ---------------------------------------------------------------------------

namespace {

Eigen::Isometry3d PoseFromXyzRpy(const Eigen::Vector3d& xyz, double roll, double pitch,
                                 double yaw) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = RotationFromRollPitchYaw(roll, pitch, yaw);
  pose.translation() = xyz;
  return pose;
}

bool FiniteNonNegative(double v) { return std::isfinite(v) && v >= 0.0; }

}  // namespace

const char* RobotKindName(RobotKind kind) {
  switch (kind) {
    case RobotKind::kWheeled: return "wheeled";
    case RobotKind::kUav: return "uav";
    case RobotKind::kHumanoid: return "humanoid";
  }
  return "unknown";
}

bool MargOptions::IsValid(std::string* error) const {
  std::ostringstream why;
  if (!(rate_hz > 0.0 && rate_hz <= 1000.0)) {
    why << "marg rate must be in (0, 1000] Hz, got " << rate_hz;
  } else if (!(FiniteNonNegative(gyro_noise_radps) && FiniteNonNegative(gyro_bias_radps) &&
               FiniteNonNegative(gyro_bias_walk_radps_per_sqrt_s) &&
               FiniteNonNegative(accel_noise_mps2) && FiniteNonNegative(accel_bias_mps2) &&
               FiniteNonNegative(mag_noise_microtesla) &&
               FiniteNonNegative(attitude_noise_radians) &&
               FiniteNonNegative(attitude_offset_radians))) {
    why << "marg noise and bias values must be finite and >= 0";
  } else if (!(gravity_mps2 > 0.0 && std::isfinite(gravity_mps2))) {
    why << "gravity must be positive, got " << gravity_mps2;
  } else if (!(std::isfinite(mag_horizontal_microtesla) &&
               std::isfinite(mag_vertical_microtesla))) {
    why << "magnetic field must be finite";
  }
  if (why.str().empty()) return true;
  if (error != nullptr) *error = why.str();
  return false;
}

Eigen::Isometry3d CameraOptions::DefaultLaserTCamera(const Eigen::Vector3d& translation,
                                                     double roll_radians, double pitch_radians,
                                                     double yaw_radians) {
  // Columns: the optical x (right), y (down), z (forward) axes in the camera body frame
  // (x forward, y left, z up).
  Eigen::Matrix3d body_R_optical;
  body_R_optical << 0.0, 0.0, 1.0,  //
      -1.0, 0.0, 0.0,               //
      0.0, -1.0, 0.0;
  Eigen::Isometry3d laser_T_camera = Eigen::Isometry3d::Identity();
  laser_T_camera.linear() = RotationFromRollPitchYaw(roll_radians, pitch_radians, yaw_radians) * body_R_optical;
  laser_T_camera.translation() = translation;
  return laser_T_camera;
}

bool CameraOptions::IsValid(std::string* error) const {
  std::ostringstream why;
  if (!enabled) return true;
  if (!(rate_hz > 0.0 && rate_hz <= 100.0)) {
    why << "camera rate must be in (0, 100] Hz, got " << rate_hz;
  } else if (width < 16 || width > 4096 || height < 16 || height > 4096) {
    why << "camera size must be in [16, 4096] pixels, got " << width << " x " << height;
  } else if (!(fx > 0.0 && fy > 0.0 && std::isfinite(fx) && std::isfinite(fy))) {
    why << "camera focal lengths must be positive, got " << fx << " " << fy;
  } else if (!(cx >= 0.0 && cx <= width && cy >= 0.0 && cy <= height)) {
    why << "camera principal point (" << cx << ", " << cy << ") must be inside the image";
  } else if (!laser_T_camera.matrix().allFinite()) {
    why << "camera mount must be finite";
  }
  if (why.str().empty()) return true;
  if (error != nullptr) *error = why.str();
  return false;
}

bool AltimeterOptions::IsValid(std::string* error) const {
  std::ostringstream why;
  if (!(rate_hz > 0.0 && rate_hz <= 1000.0)) {
    why << "altimeter rate must be in (0, 1000] Hz, got " << rate_hz;
  } else if (!FiniteNonNegative(noise_std_meters)) {
    why << "altimeter noise must be finite and >= 0, got " << noise_std_meters;
  }
  if (why.str().empty()) return true;
  if (error != nullptr) *error = why.str();
  return false;
}

RobotSpec DefaultRobotSpec(const std::string& name, RobotKind kind) {
  RobotSpec spec;
  spec.name = name;
  spec.kind = kind;
  spec.laser.field_of_view_radians = 240.0 * kDegToRad;
  spec.laser.num_beams = 667;  // 0.36° steps
  spec.laser.max_range_meters = 5.6;
  spec.laser.range_noise_std_meters = 0.01;
  spec.laser.dropout_probability = 0.005;
  spec.laser.rate_hz = 10.0;
  switch (kind) {
    case RobotKind::kWheeled:
      spec.motion.max_speed_mps = 0.5;
      spec.motion.max_turn_rate_radps = 45.0 * kDegToRad;
      spec.body_T_laser.translation() = Eigen::Vector3d(0.1, 0.0, 0.3);
      break;
    case RobotKind::kHumanoid:
      spec.motion.max_speed_mps = 0.15;
      spec.motion.max_turn_rate_radps = 30.0 * kDegToRad;
      // Level head: the laser 3 cm in front of and 5 cm above the head joint (0.45 m).
      spec.body_T_laser.translation() = Eigen::Vector3d(0.03, 0.0, 0.5);
      spec.head_joint_height_meters = 0.45;
      break;
    case RobotKind::kUav:
      spec.motion.max_speed_mps = 0.6;
      spec.motion.max_turn_rate_radps = 60.0 * kDegToRad;
      spec.body_T_laser.translation() = Eigen::Vector3d(0.0, 0.0, 0.05);
      break;
  }
  return spec;
}

double RobotSpec::HeadPitchRadians(double t_seconds) const {
  if (head_profile.empty()) return 0.0;
  double total = 0.0;
  for (const HeadPhase& phase : head_profile) total += phase.duration_seconds;
  double tau = std::fmod(std::max(0.0, t_seconds), total);
  double pitch = 0.0;  // at the start of the current phase
  for (const HeadPhase& phase : head_profile) {
    const bool inside = tau < phase.duration_seconds;
    const double local = inside ? tau : phase.duration_seconds;
    switch (phase.type) {
      case HeadPhase::Type::kLevel:
        pitch = 0.0;
        break;
      case HeadPhase::Type::kHold:
        pitch = phase.pitch_radians;
        break;
      case HeadPhase::Type::kMove:
        pitch += (phase.pitch_radians - pitch) * (local / phase.duration_seconds);
        break;
      case HeadPhase::Type::kSweep: {
        const double u = std::fmod(local, phase.period_seconds) / phase.period_seconds;
        const double triangle = u < 0.5 ? 2.0 * u : 2.0 - 2.0 * u;
        pitch = phase.min_pitch_radians +
                (phase.max_pitch_radians - phase.min_pitch_radians) * triangle;
        break;
      }
    }
    if (inside) return pitch;
    tau -= phase.duration_seconds;
  }
  return pitch;
}

Eigen::Isometry3d RobotSpec::BodyTLaser(double head_pitch_radians) const {
  if (kind != RobotKind::kHumanoid) return body_T_laser;
  // Rotation about the body y axis through the joint point (0, 0, joint height).
  Eigen::Isometry3d joint = Eigen::Isometry3d::Identity();
  joint.translation() = Eigen::Vector3d(0.0, 0.0, head_joint_height_meters);
  Eigen::Isometry3d pitch = Eigen::Isometry3d::Identity();
  pitch.linear() = Eigen::AngleAxisd(head_pitch_radians, Eigen::Vector3d::UnitY()).toRotationMatrix();
  return joint * pitch * joint.inverse() * body_T_laser;
}

Pose2 RobotSpec::InitialPose() const {
  if (has_start_pose) return start_pose;
  std::vector<Eigen::Vector2d> targets;
  for (const RouteStep& step : route) {
    if (step.type == RouteStep::Type::kWaypoint) targets.push_back(step.target);
  }
  CHECK(!targets.empty() && route.front().type == RouteStep::Type::kWaypoint)
      << "robot '" << name << "' has no start pose and does not begin with a waypoint";
  if (targets.size() == 1) return Pose2(targets[0], 0.0);
  const Eigen::Vector2d heading = targets[1] - targets[0];
  return Pose2(targets[0], std::atan2(heading.y(), heading.x()));
}

bool RobotSpec::IsValid(std::string* error) const {
  std::string why;
  std::ostringstream os;
  const bool options_valid = laser.IsValid(&why) && motion.IsValid(&why) &&
                             marg.IsValid(&why) && camera.IsValid(&why) &&
                             odometry.IsValid(&why) && altimeter.IsValid(&why);
  if (!options_valid) {
    os << why;
  } else if (route.empty()) {
    os << "has no waypoint, stand or command lines (at least one is needed)";
  } else if (!has_start_pose && route.front().type != RouteStep::Type::kWaypoint) {
    os << "needs a 'start' line (its plan does not begin with a waypoint)";
  } else if (kind == RobotKind::kHumanoid && motion.max_speed_mps > 0.15 + 1e-12) {
    os << "a humanoid walks at most 0.15 m/s, got speed " << motion.max_speed_mps;
  } else if (kind == RobotKind::kUav && !(altitude_meters >= 0.2 && altitude_meters <= 10.0)) {
    os << "UAV altitude must be in [0.2, 10] m, got " << altitude_meters;
  } else if (!body_T_laser.matrix().allFinite()) {
    os << "laser mount must be finite";
  } else if (!(head_joint_height_meters > 0.0 && head_joint_height_meters < 5.0)) {
    os << "head joint height must be in (0, 5) m, got " << head_joint_height_meters;
  }
  if (os.str().empty()) {
    for (const HeadPhase& phase : head_profile) {
      if (!(phase.duration_seconds > 0.0 && std::isfinite(phase.duration_seconds))) {
        os << "head phase durations must be positive";
        break;
      }
      if (phase.type == HeadPhase::Type::kSweep && !(phase.period_seconds > 0.0)) {
        os << "head sweep period must be positive";
        break;
      }
    }
  }
  if (os.str().empty()) return true;
  if (error != nullptr) *error = "robot '" + name + "' " + os.str();
  return false;
}

Eigen::Isometry3d TagSpec::WorldTTag() const {
  const double c = std::cos(normal_yaw_radians), s = std::sin(normal_yaw_radians);
  Eigen::Isometry3d world_T_tag = Eigen::Isometry3d::Identity();
  world_T_tag.linear().col(0) = Eigen::Vector3d(-s, c, 0.0);  // right, seen facing the tag
  world_T_tag.linear().col(1) = Eigen::Vector3d(0.0, 0.0, 1.0);  // up
  world_T_tag.linear().col(2) = Eigen::Vector3d(c, s, 0.0);   // out of the wall
  world_T_tag.translation() = center;
  return world_T_tag;
}

// ---- Scenario -------------------------------------------------------------------------------

Pose2 Scenario::InitialPose() const {
  if (has_start_pose) return start_pose;
  CHECK(!waypoints.empty()) << "scenario '" << source_name << "' has no waypoints";
  if (waypoints.size() == 1) return Pose2(waypoints[0], 0.0);
  const Eigen::Vector2d heading = waypoints[1] - waypoints[0];
  return Pose2(waypoints[0], std::atan2(heading.y(), heading.x()));
}

int Scenario::FirstWaypointToReach() const { return has_start_pose ? 0 : 1; }

bool Scenario::IsValid(std::string* error) const {
  std::string why;
  if (!IsTeam()) {
    const bool options_valid =
        laser.IsValid(&why) && robot.IsValid(&why) && odometry.IsValid(&why);
    if (!options_valid) {
      // `why` names the first invalid option.
    } else if (waypoints.empty()) {
      why = "scenario has no 'waypoint' lines (at least one is needed)";
    }
  } else {
    for (size_t i = 0; i < robots.size() && why.empty(); ++i) {
      if (!robots[i].IsValid(&why)) break;
      for (size_t j = 0; j < i; ++j) {
        if (robots[j].name == robots[i].name) why = "robot name '" + robots[i].name + "' used twice";
      }
    }
    for (size_t i = 0; i < tags.size() && why.empty(); ++i) {
      if (tags[i].id < 0 || tags[i].id > 586) {
        why = "tag id " + std::to_string(tags[i].id) + " is not a tag36h11 id (0 .. 586)";
      }
      for (size_t j = 0; j < i; ++j) {
        if (tags[j].id == tags[i].id) why = "tag id " + std::to_string(tags[i].id) + " used twice";
      }
    }
  }
  if (!why.empty()) {
    // Reported below.
  } else if (world.empty()) {
    why = "scenario has no walls ('wall' or 'box' lines)";
  } else if (!(duration_limit_seconds > 0.0)) {
    why = "duration limit must be positive";
  }
  if (why.empty()) return true;
  if (error != nullptr) *error = why;
  return false;
}

namespace {

constexpr char kTopLevelKeywords[] =
    "wall, box, wall_height, ceiling, table, shelf, obstacle, random_obstacles, tag, "
    "robot_begin, waypoint, start, laser, robot, odometry or duration_limit_s";
constexpr char kRobotKeywords[] =
    "start, altitude, waypoint, stand, command, speed, laser, laser_mount, head_joint_height, "
    "head_level, head_hold, head_move, head_sweep, marg, camera, camera_mount, odometry, "
    "altimeter or robot_end";

// One pass over the scenario text. Statements outside robot blocks fill the world and the
// single-robot settings; inside a block they fill that robot's spec.
class ScenarioParser {
 public:
  ScenarioParser(const std::string& source_name, Scenario* scenario)
      : source_(source_name), scenario_(scenario) {}

  Status Parse(const std::string& text) {
    std::istringstream stream(text);
    std::string line;
    int line_number = 0;
    while (std::getline(stream, line)) {
      ++line_number;
      const std::vector<std::string> tokens = Tokenize(line);
      if (tokens.empty()) continue;
      const LineContext context{source_, line_number};
      const Status status =
          robot_ == nullptr ? TopLevel(tokens, context) : RobotStatement(tokens, context);
      if (!status.ok()) return status;
    }
    if (robot_ != nullptr) {
      return Status::Error(source_ + ":" + std::to_string(robot_->source_line) + ": robot block '" +
                           robot_->name + "' is not closed (robot_end missing)");
    }
    if (scenario_->IsTeam() && !single_robot_lines_.empty()) {
      const auto& first = single_robot_lines_.front();
      return Status::Error(source_ + ":" + std::to_string(first.second) + ": '" + first.first +
                           "' outside a robot block: in a scenario with robot blocks every "
                           "robot statement goes inside its robot_begin .. robot_end block");
    }
    // Heights: walls reach the ceiling unless wall_height says otherwise.
    const double wall_height =
        wall_height_ > 0.0 ? wall_height_ : (std::isfinite(ceiling_) ? ceiling_ : 2.6);
    scenario_->world.SetHeights(wall_height, ceiling_);
    // Tags sit on something: a surface within 2 cm behind the tag's centre.
    for (const TagSpec& tag : scenario_->tags) {
      const Eigen::Vector3d normal = tag.WorldTTag().linear().col(2);
      const RayHit hit = scenario_->world.CastRay3D(tag.center + 0.02 * normal, -normal, 0.04);
      if (!hit.hit) {
        return Status::Error(source_ + ":" + std::to_string(tag.source_line) + ": tag " +
                             std::to_string(tag.id) +
                             " is not on a wall (nothing within 2 cm behind its centre; its "
                             "yaw is the direction it faces)");
      }
      if (tag.center.z() - 0.5 * tag.size_meters * 1.25 < 0.0 ||
          tag.center.z() + 0.5 * tag.size_meters * 1.25 > wall_height) {
        return Status::Error(source_ + ":" + std::to_string(tag.source_line) + ": tag " +
                             std::to_string(tag.id) + " does not fit between floor and wall top");
      }
    }
    std::string why;
    if (!scenario_->IsValid(&why)) return Status::Error(source_ + ": " + why);
    return Status::Ok();
  }

 private:
  // Records the first line of a singleton statement; an error when seen before.
  Status Once(std::map<std::string, int>* seen, const std::string& keyword,
              const LineContext& context) {
    const auto it = seen->find(keyword);
    if (it != seen->end()) {
      return context.Error("'" + keyword + "' given twice (first on line " +
                           std::to_string(it->second) + ")");
    }
    (*seen)[keyword] = context.line_number;
    return Status::Ok();
  }

  Status ParseLaser(const std::vector<std::string>& tokens, const LineContext& context,
                    LaserOptions* laser) {
    std::vector<double> v;
    Status status = ParseNumbers(
        tokens, 6, 6, "laser fov_deg num_beams max_range_m noise_std_m dropout_prob rate_hz",
        context, &v);
    if (!status.ok()) return status;
    if (!IsInteger(v[1]) || std::abs(v[1]) > 1e9) {
      return context.Error("laser num_beams must be an integer, got " + tokens[2]);
    }
    laser->field_of_view_radians = v[0] * kDegToRad;
    laser->num_beams = static_cast<int>(v[1]);
    laser->max_range_meters = v[2];
    laser->range_noise_std_meters = v[3];
    laser->dropout_probability = v[4];
    laser->rate_hz = v[5];
    std::string why;
    if (!laser->IsValid(&why)) return context.Error(why);
    return Status::Ok();
  }

  Status ParseOdometry(const std::vector<std::string>& tokens, const LineContext& context,
                       OdometryOptions* odometry) {
    std::vector<double> v;
    Status status = ParseNumbers(tokens, 4, 4,
                                 "odometry rate_hz trans_noise_m_per_sqrt_m "
                                 "rot_noise_deg_per_sqrt_m rot_noise_deg_per_sqrt_deg",
                                 context, &v);
    if (!status.ok()) return status;
    odometry->rate_hz = v[0];
    odometry->trans_noise_meters_per_sqrt_meter = v[1];
    odometry->rot_noise_radians_per_sqrt_meter = v[2] * kDegToRad;
    // deg/sqrt(deg) -> rad/sqrt(rad): sigma_rad = k_deg * sqrt(dtheta_deg) * d2r
    //                                           = k_deg * sqrt(d2r) * sqrt(dtheta_rad).
    odometry->rot_noise_radians_per_sqrt_radian = v[3] >= 0.0 ? v[3] * std::sqrt(kDegToRad) : v[3];
    std::string why;
    if (!odometry->IsValid(&why)) return context.Error(why);
    return Status::Ok();
  }

  Status ParseSpeed(const std::vector<std::string>& tokens, const std::string& usage,
                    const LineContext& context, RobotOptions* motion) {
    std::vector<double> v;
    Status status = ParseNumbers(tokens, 2, 2, usage, context, &v);
    if (!status.ok()) return status;
    motion->max_speed_mps = v[0];
    motion->max_turn_rate_radps = v[1] * kDegToRad;
    std::string why;
    if (!motion->IsValid(&why)) return context.Error(why);
    return Status::Ok();
  }

  // A box-like statement "KEY cx cy w h height [yaw_deg]".
  Status ParseBoxPrism(const std::vector<std::string>& tokens, const std::string& usage,
                       const LineContext& context, std::vector<double>* v) {
    Status status = ParseNumbers(tokens, 5, 6, usage, context, v);
    if (!status.ok()) return status;
    if (!((*v)[2] > 0.0 && (*v)[3] > 0.0 && (*v)[4] > 0.0)) {
      return context.Error("'" + tokens[0] + "' width, depth and height must be positive");
    }
    if ((*v)[4] > 100.0) return context.Error("'" + tokens[0] + "' height must be <= 100 m");
    if (v->size() == 5) v->push_back(0.0);
    return Status::Ok();
  }

  Status TopLevel(const std::vector<std::string>& tokens, const LineContext& context) {
    const std::string& keyword = tokens[0];
    std::vector<double> v;
    Status status;
    World& world = scenario_->world;
    if (keyword == "wall") {
      if (!(status = ParseNumbers(tokens, 4, 4, "wall x1 y1 x2 y2", context, &v)).ok()) {
        return status;
      }
      const Eigen::Vector2d a(v[0], v[1]), b(v[2], v[3]);
      if ((b - a).norm() < 1e-6) return context.Error("wall has zero length");
      world.AddWall(a, b, context.line_number);
    } else if (keyword == "box") {
      if (!(status = ParseNumbers(tokens, 4, 5, "box cx cy w h [yaw_deg]", context, &v)).ok()) {
        return status;
      }
      if (!(v[2] > 0.0 && v[3] > 0.0)) {
        return context.Error("box width and height must be positive");
      }
      const double yaw = v.size() == 5 ? v[4] * kDegToRad : 0.0;
      world.AddBox(Eigen::Vector2d(v[0], v[1]), Eigen::Vector2d(v[2], v[3]), yaw,
                   context.line_number);
    } else if (keyword == "wall_height") {
      if (!(status = Once(&seen_, keyword, context)).ok()) return status;
      if (!(status = ParseNumbers(tokens, 1, 1, "wall_height meters", context, &v)).ok()) {
        return status;
      }
      if (!(v[0] > 0.0 && v[0] <= 100.0)) {
        return context.Error("wall_height must be in (0, 100] m");
      }
      wall_height_ = v[0];
    } else if (keyword == "ceiling") {
      if (!(status = Once(&seen_, keyword, context)).ok()) return status;
      if (tokens.size() == 2 && tokens[1] == "none") {
        ceiling_ = std::numeric_limits<double>::infinity();
        return Status::Ok();
      }
      if (!(status = ParseNumbers(tokens, 1, 1, "ceiling meters | ceiling none", context, &v))
               .ok()) {
        return status;
      }
      if (!(v[0] > 0.0 && v[0] <= 100.0)) return context.Error("ceiling must be in (0, 100] m");
      ceiling_ = v[0];
    } else if (keyword == "table") {
      if (!(status = ParseBoxPrism(tokens, "table cx cy w h height [yaw_deg]", context, &v))
               .ok()) {
        return status;
      }
      const TableShape shape;
      const double leg_span = 2.0 * (shape.leg_inset_meters + shape.leg_width_meters);
      if (!(v[2] > leg_span && v[3] > leg_span)) {
        return context.Error("table sides must be larger than " + Fixed(leg_span, 2) +
                             " m (room for the legs)");
      }
      if (!(v[4] > shape.top_thickness_meters)) {
        return context.Error("table height must be larger than its top's thickness " +
                             Fixed(shape.top_thickness_meters, 2) + " m");
      }
      world.AddTable(Eigen::Vector2d(v[0], v[1]), Eigen::Vector2d(v[2], v[3]), v[5] * kDegToRad,
                     v[4], context.line_number, shape);
    } else if (keyword == "obstacle") {
      if (!(status = ParseBoxPrism(tokens, "obstacle cx cy w h height [yaw_deg]", context, &v))
               .ok()) {
        return status;
      }
      world.AddBoxPrism(Eigen::Vector2d(v[0], v[1]), Eigen::Vector2d(v[2], v[3]),
                        v[5] * kDegToRad, 0.0, v[4], Surface::kObstacle, context.line_number);
    } else if (keyword == "shelf") {
      const std::string usage =
          "shelf x1 y1 x2 y2 lower_depth lower_height upper_depth height";
      if (!(status = ParseNumbers(tokens, 8, 8, usage, context, &v)).ok()) return status;
      if ((Eigen::Vector2d(v[2], v[3]) - Eigen::Vector2d(v[0], v[1])).norm() < 1e-6) {
        return context.Error("shelf back has zero length");
      }
      if (!(v[4] > 0.0 && v[5] > 0.0 && v[6] > 0.0 && v[7] > v[5] && v[7] <= 100.0)) {
        return context.Error("shelf depths and heights must be positive, height > lower_height");
      }
      world.AddShelf(Eigen::Vector2d(v[0], v[1]), Eigen::Vector2d(v[2], v[3]), v[4], v[5], v[6],
                     v[7], context.line_number);
    } else if (keyword == "random_obstacles") {
      if (!(status = ParseNumbers(tokens, 6, 6, "random_obstacles n x0 y0 x1 y1 max_height",
                                  context, &v))
               .ok()) {
        return status;
      }
      if (!IsInteger(v[0]) || v[0] < 1 || v[0] > 1000) {
        return context.Error("random_obstacles count must be an integer in [1, 1000], got " +
                             tokens[1]);
      }
      if (!(v[1] < v[3] && v[2] < v[4])) {
        return context.Error("random_obstacles region needs x0 < x1 and y0 < y1");
      }
      if (!(v[5] >= 0.05 && v[5] <= 2.0)) {
        return context.Error("random_obstacles max_height must be in [0.05, 2] m");
      }
      RandomObstacleSpec spec;
      spec.count = static_cast<int>(v[0]);
      spec.region = Eigen::AlignedBox2d(Eigen::Vector2d(v[1], v[2]), Eigen::Vector2d(v[3], v[4]));
      spec.max_height_meters = v[5];
      spec.source_line = context.line_number;
      scenario_->random_obstacles.push_back(spec);
    } else if (keyword == "tag") {
      if (!(status = ParseNumbers(tokens, 6, 6, "tag id size x y z yaw_deg", context, &v)).ok()) {
        return status;
      }
      if (!IsInteger(v[0]) || v[0] < 0 || v[0] > 586) {
        return context.Error("tag id must be a tag36h11 id (an integer in [0, 586]), got " +
                             tokens[1]);
      }
      if (!(v[1] > 0.0 && v[1] <= 2.0)) return context.Error("tag size must be in (0, 2] m");
      TagSpec tag;
      tag.id = static_cast<int>(v[0]);
      tag.size_meters = v[1];
      tag.center = Eigen::Vector3d(v[2], v[3], v[4]);
      tag.normal_yaw_radians = v[5] * kDegToRad;
      tag.source_line = context.line_number;
      for (const TagSpec& other : scenario_->tags) {
        if (other.id == tag.id) {
          return context.Error("tag id " + tokens[1] + " used twice (first on line " +
                               std::to_string(other.source_line) + ")");
        }
      }
      scenario_->tags.push_back(tag);
    } else if (keyword == "robot_begin") {
      if (tokens.size() != 3) {
        return context.Error("'robot_begin' takes a name and a kind (robot_begin NAME "
                             "wheeled|uav|humanoid), got " + std::to_string(tokens.size() - 1) +
                             " fields");
      }
      RobotKind kind;
      if (tokens[2] == "wheeled") {
        kind = RobotKind::kWheeled;
      } else if (tokens[2] == "uav") {
        kind = RobotKind::kUav;
      } else if (tokens[2] == "humanoid") {
        kind = RobotKind::kHumanoid;
      } else {
        return context.Error("unknown robot kind '" + tokens[2] +
                             "' (expected wheeled, uav or humanoid)");
      }
      const std::string& name = tokens[1];
      for (char c : name) {
        if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-')) {
          return context.Error("robot name '" + name +
                               "' may only hold letters, digits, '_' and '-' (it names a folder)");
        }
      }
      for (const RobotSpec& other : scenario_->robots) {
        if (other.name == name) {
          return context.Error("robot name '" + name + "' used twice (first on line " +
                               std::to_string(other.source_line) + ")");
        }
      }
      scenario_->robots.push_back(DefaultRobotSpec(name, kind));
      robot_ = &scenario_->robots.back();
      robot_->source_line = context.line_number;
      robot_seen_.clear();
    } else if (keyword == "robot_end") {
      return context.Error("'robot_end' without robot_begin");
    } else if (keyword == "waypoint") {
      single_robot_lines_.emplace_back(keyword, context.line_number);
      if (!(status = ParseNumbers(tokens, 2, 2, "waypoint x y", context, &v)).ok()) {
        return status;
      }
      scenario_->waypoints.emplace_back(v[0], v[1]);
    } else if (keyword == "start") {
      single_robot_lines_.emplace_back(keyword, context.line_number);
      if (!(status = Once(&seen_, keyword, context)).ok()) return status;
      if (!(status = ParseNumbers(tokens, 3, 3, "start x y yaw_deg", context, &v)).ok()) {
        return status;
      }
      scenario_->has_start_pose = true;
      scenario_->start_pose = Pose2(v[0], v[1], v[2] * kDegToRad);
    } else if (keyword == "laser") {
      single_robot_lines_.emplace_back(keyword, context.line_number);
      if (!(status = Once(&seen_, keyword, context)).ok()) return status;
      return ParseLaser(tokens, context, &scenario_->laser);
    } else if (keyword == "robot") {
      single_robot_lines_.emplace_back(keyword, context.line_number);
      if (!(status = Once(&seen_, keyword, context)).ok()) return status;
      return ParseSpeed(tokens, "robot speed_mps turn_rate_dps", context, &scenario_->robot);
    } else if (keyword == "odometry") {
      single_robot_lines_.emplace_back(keyword, context.line_number);
      if (!(status = Once(&seen_, keyword, context)).ok()) return status;
      return ParseOdometry(tokens, context, &scenario_->odometry);
    } else if (keyword == "duration_limit_s") {
      if (!(status = Once(&seen_, keyword, context)).ok()) return status;
      if (!(status = ParseNumbers(tokens, 1, 1, "duration_limit_s seconds", context, &v)).ok()) {
        return status;
      }
      if (!(v[0] > 0.0)) return context.Error("duration_limit_s must be positive");
      scenario_->duration_limit_seconds = v[0];
    } else {
      return context.Error("unknown keyword '" + keyword + "' (expected " + kTopLevelKeywords +
                           ")");
    }
    return Status::Ok();
  }

  Status RobotStatement(const std::vector<std::string>& tokens, const LineContext& context) {
    const std::string& keyword = tokens[0];
    RobotSpec& robot = *robot_;
    const std::string kind_name = RobotKindName(robot.kind);
    auto only_for = [&](RobotKind kind) -> Status {
      if (robot.kind == kind) return Status::Ok();
      return context.Error("'" + keyword + "' is for " + RobotKindName(kind) + " robots, and '" +
                           robot.name + "' is " + kind_name);
    };
    std::vector<double> v;
    Status status;
    static const char* const kSingletons[] = {
        "start", "altitude", "speed", "laser", "laser_mount", "head_joint_height", "marg",
        "camera", "camera_mount", "odometry", "altimeter"};
    for (const char* singleton : kSingletons) {
      if (keyword == singleton && !(status = Once(&robot_seen_, keyword, context)).ok()) {
        return status;
      }
    }
    if (keyword == "robot_end") {
      if (tokens.size() != 1) return context.Error("'robot_end' takes no fields");
      std::string why;
      if (!robot.IsValid(&why)) {
        return Status::Error(source_ + ":" + std::to_string(robot.source_line) + ": " + why);
      }
      robot_ = nullptr;
    } else if (keyword == "start") {
      if (!(status = ParseNumbers(tokens, 3, 3, "start x y yaw_deg", context, &v)).ok()) {
        return status;
      }
      robot.has_start_pose = true;
      robot.start_pose = Pose2(v[0], v[1], v[2] * kDegToRad);
    } else if (keyword == "altitude") {
      if (!(status = only_for(RobotKind::kUav)).ok()) return status;
      if (!(status = ParseNumbers(tokens, 1, 1, "altitude meters", context, &v)).ok()) {
        return status;
      }
      if (!(v[0] >= 0.2 && v[0] <= 10.0)) return context.Error("altitude must be in [0.2, 10] m");
      robot.altitude_meters = v[0];
    } else if (keyword == "waypoint") {
      const bool uav = robot.kind == RobotKind::kUav;
      if (!(status = ParseNumbers(tokens, 2, uav ? 3 : 2,
                                  uav ? "waypoint x y [altitude]" : "waypoint x y", context, &v))
               .ok()) {
        return status;
      }
      RouteStep step;
      step.type = RouteStep::Type::kWaypoint;
      step.target = Eigen::Vector2d(v[0], v[1]);
      if (v.size() == 3) {
        if (!(v[2] >= 0.2 && v[2] <= 10.0)) {
          return context.Error("waypoint altitude must be in [0.2, 10] m");
        }
        step.altitude_meters = v[2];
      }
      step.source_line = context.line_number;
      robot.route.push_back(step);
    } else if (keyword == "stand") {
      if (!(status = ParseNumbers(tokens, 1, 1, "stand seconds", context, &v)).ok()) {
        return status;
      }
      if (!(v[0] > 0.0)) return context.Error("stand duration must be positive");
      RouteStep step;
      step.type = RouteStep::Type::kStand;
      step.duration_seconds = v[0];
      step.source_line = context.line_number;
      robot.route.push_back(step);
    } else if (keyword == "command") {
      if (!(status = ParseNumbers(tokens, 4, 4, "command seconds vx_mps vy_mps yaw_rate_dps",
                                  context, &v))
               .ok()) {
        return status;
      }
      if (!(v[0] > 0.0)) return context.Error("command duration must be positive");
      if (robot.kind == RobotKind::kWheeled && v[2] != 0.0) {
        return context.Error("a wheeled robot cannot move sideways (vy must be 0)");
      }
      if (std::hypot(v[1], v[2]) > robot.motion.max_speed_mps + 1e-12 ||
          std::abs(v[3] * kDegToRad) > robot.motion.max_turn_rate_radps + 1e-12) {
        return context.Error("command exceeds the robot's speed or yaw rate limit (" +
                             Fixed(robot.motion.max_speed_mps, 3) + " m/s, " +
                             Fixed(robot.motion.max_turn_rate_radps / kDegToRad, 1) +
                             " deg/s; set 'speed' first)");
      }
      RouteStep step;
      step.type = RouteStep::Type::kCommand;
      step.duration_seconds = v[0];
      step.vx_mps = v[1];
      step.vy_mps = v[2];
      step.yaw_rate_radps = v[3] * kDegToRad;
      step.source_line = context.line_number;
      robot.route.push_back(step);
    } else if (keyword == "speed") {
      if (!(status = ParseSpeed(tokens, "speed max_speed_mps turn_rate_dps", context,
                                &robot.motion))
               .ok()) {
        return status;
      }
      if (robot.kind == RobotKind::kHumanoid && robot.motion.max_speed_mps > 0.15) {
        return context.Error("a humanoid walks at most 0.15 m/s");
      }
    } else if (keyword == "laser") {
      return ParseLaser(tokens, context, &robot.laser);
    } else if (keyword == "laser_mount" || keyword == "camera_mount") {
      if (!(status = ParseNumbers(tokens, 6, 6,
                                  keyword + " x y z roll_deg pitch_deg yaw_deg", context, &v))
               .ok()) {
        return status;
      }
      if (keyword == "laser_mount") {
        robot.body_T_laser = PoseFromXyzRpy(Eigen::Vector3d(v[0], v[1], v[2]), v[3] * kDegToRad,
                                            v[4] * kDegToRad, v[5] * kDegToRad);
      } else {
        robot.camera.laser_T_camera = CameraOptions::DefaultLaserTCamera(
            Eigen::Vector3d(v[0], v[1], v[2]), v[3] * kDegToRad, v[4] * kDegToRad,
            v[5] * kDegToRad);
      }
    } else if (keyword == "head_joint_height") {
      if (!(status = only_for(RobotKind::kHumanoid)).ok()) return status;
      if (!(status = ParseNumbers(tokens, 1, 1, "head_joint_height meters", context, &v)).ok()) {
        return status;
      }
      if (!(v[0] > 0.0 && v[0] < 5.0)) return context.Error("head_joint_height must be in (0, 5) m");
      robot.head_joint_height_meters = v[0];
    } else if (keyword == "head_level" || keyword == "head_hold" || keyword == "head_move" ||
               keyword == "head_sweep") {
      if (!(status = only_for(RobotKind::kHumanoid)).ok()) return status;
      HeadPhase phase;
      if (keyword == "head_level") {
        status = ParseNumbers(tokens, 1, 1, "head_level seconds", context, &v);
        phase.type = HeadPhase::Type::kLevel;
      } else if (keyword == "head_hold") {
        status = ParseNumbers(tokens, 2, 2, "head_hold seconds pitch_deg", context, &v);
        phase.type = HeadPhase::Type::kHold;
      } else if (keyword == "head_move") {
        status = ParseNumbers(tokens, 2, 2, "head_move seconds pitch_deg", context, &v);
        phase.type = HeadPhase::Type::kMove;
      } else {
        status = ParseNumbers(tokens, 4, 4, "head_sweep seconds min_deg max_deg period_s",
                              context, &v);
        phase.type = HeadPhase::Type::kSweep;
      }
      if (!status.ok()) return status;
      if (!(v[0] > 0.0)) return context.Error("'" + keyword + "' duration must be positive");
      for (size_t i = 1; i < v.size() && (phase.type != HeadPhase::Type::kSweep || i < 3); ++i) {
        if (!(v[i] >= -30.0 && v[i] <= 60.0)) {
          return context.Error("head pitch must be in [-30, 60] degrees, got " + tokens[i + 1]);
        }
      }
      phase.duration_seconds = v[0];
      if (phase.type == HeadPhase::Type::kHold || phase.type == HeadPhase::Type::kMove) {
        phase.pitch_radians = v[1] * kDegToRad;
      }
      if (phase.type == HeadPhase::Type::kSweep) {
        if (!(v[1] < v[2])) return context.Error("head_sweep needs min_deg < max_deg");
        if (!(v[3] > 0.0)) return context.Error("head_sweep period must be positive");
        phase.min_pitch_radians = v[1] * kDegToRad;
        phase.max_pitch_radians = v[2] * kDegToRad;
        phase.period_seconds = v[3];
      }
      robot.head_profile.push_back(phase);
    } else if (keyword == "marg") {
      if (!(status = ParseNumbers(tokens, 9, 9,
                                  "marg rate_hz gyro_noise_dps gyro_bias_dps "
                                  "gyro_bias_walk_dps_per_sqrt_s accel_noise_mps2 "
                                  "accel_bias_mps2 mag_noise_ut attitude_noise_deg "
                                  "attitude_offset_deg",
                                  context, &v))
               .ok()) {
        return status;
      }
      MargOptions& marg = robot.marg;
      marg.rate_hz = v[0];
      marg.gyro_noise_radps = v[1] * kDegToRad;
      marg.gyro_bias_radps = v[2] * kDegToRad;
      marg.gyro_bias_walk_radps_per_sqrt_s = v[3] * kDegToRad;
      marg.accel_noise_mps2 = v[4];
      marg.accel_bias_mps2 = v[5];
      marg.mag_noise_microtesla = v[6];
      marg.attitude_noise_radians = v[7] * kDegToRad;
      marg.attitude_offset_radians = v[8] * kDegToRad;
      std::string why;
      if (!marg.IsValid(&why)) return context.Error(why);
    } else if (keyword == "camera") {
      CameraOptions& camera = robot.camera;
      if (tokens.size() == 2 && tokens[1] == "none") {
        camera.enabled = false;
        return Status::Ok();
      }
      if (!(status = ParseNumbers(tokens, 7, 7,
                                  "camera rate_hz width height fx fy cx cy | camera none",
                                  context, &v))
               .ok()) {
        return status;
      }
      if (!IsInteger(v[1]) || !IsInteger(v[2]) || std::abs(v[1]) > 1e6 || std::abs(v[2]) > 1e6) {
        return context.Error("camera width and height must be integers");
      }
      camera.enabled = true;
      camera.rate_hz = v[0];
      camera.width = static_cast<int>(v[1]);
      camera.height = static_cast<int>(v[2]);
      camera.fx = v[3];
      camera.fy = v[4];
      camera.cx = v[5];
      camera.cy = v[6];
      std::string why;
      if (!camera.IsValid(&why)) return context.Error(why);
    } else if (keyword == "odometry") {
      if (!(status = only_for(RobotKind::kWheeled)).ok()) return status;
      return ParseOdometry(tokens, context, &robot.odometry);
    } else if (keyword == "altimeter") {
      if (!(status = only_for(RobotKind::kUav)).ok()) return status;
      if (!(status = ParseNumbers(tokens, 2, 2, "altimeter rate_hz noise_std_m", context, &v))
               .ok()) {
        return status;
      }
      robot.altimeter.rate_hz = v[0];
      robot.altimeter.noise_std_meters = v[1];
      std::string why;
      if (!robot.altimeter.IsValid(&why)) return context.Error(why);
    } else {
      return context.Error("unknown keyword '" + keyword + "' inside robot block '" + robot.name +
                           "' (opened on line " + std::to_string(robot.source_line) +
                           "; expected " + kRobotKeywords + ")");
    }
    return Status::Ok();
  }

  const std::string& source_;
  Scenario* scenario_;
  RobotSpec* robot_ = nullptr;  // the open robot block, if any
  std::map<std::string, int> seen_;        // top-level singletons: first line
  std::map<std::string, int> robot_seen_;  // singletons of the open robot block
  std::vector<std::pair<std::string, int>> single_robot_lines_;  // top-level robot statements
  double wall_height_ = 0.0;  // 0: not given
  double ceiling_ = 2.6;
};

}  // namespace

Status ParseScenario(const std::string& text, const std::string& source_name,
                     Scenario* scenario) {
  CHECK(scenario != nullptr);
  *scenario = Scenario();
  scenario->source_name = source_name;
  return ScenarioParser(source_name, scenario).Parse(text);
}

Status ReadScenarioFile(const std::string& path, Scenario* scenario) {
  std::ifstream file(path);
  if (!file) return Status::Error(path + ": cannot open scenario file");
  std::ostringstream contents;
  contents << file.rdbuf();
  if (file.bad()) return Status::Error(path + ": error while reading scenario file");
  return ParseScenario(contents.str(), path, scenario);
}

}  // namespace sim
}  // namespace hetslam
