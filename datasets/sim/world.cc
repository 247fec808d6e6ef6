#include "datasets/sim/world.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include "core/se2.h"
#include "glog/logging.h"

namespace hetslam {
namespace sim {
namespace {

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

}  // namespace

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
    auto consider = [&best](double t, Surface surface, int line, int prism_index = -1) {
      if (t < best.range_meters) {
        best.range_meters = t;
        best.surface = surface;
        best.source_line = line;
        best.prism_index = prism_index;
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
      consider(RayPrismDistance(origin, d, *prism), prism->surface, prism->source_line,
               static_cast<int>(prism - prisms_.data()));
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

}  // namespace sim
}  // namespace hetslam
