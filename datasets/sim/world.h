// The simulator's world: a 2.5D building (walls, furniture, floor obstacles, a floor and a
// ceiling) with exact 2D and 3D ray casting. Scenario files describe one
// (datasets/sim/scenario.h).
//
// Frames and units: the world frame is right-handed, x east, y north, z up, the floor is the
// plane z = 0; all lengths in metres, angles in radians.
//
// Geometry: walls are zero-thickness vertical rectangles (a segment x [0, wall height]);
// furniture and floor obstacles are vertical prisms (a convex footprint x [z_min, z_max]); a
// table is a top slab on four legs, a shelf a deep lower prism under a shallow upper one. The 2D
// queries (CastRay, CastRays, SegmentHitsWall, DistanceToNearestWall) see the walls only, as
// infinitely tall segments: the z-independent special case the 2D CARMEN path has always used.
// CastRay3D / CastRays3D see everything, including the floor and the ceiling.
#ifndef HETSLAM_DATASETS_SIM_WORLD_H_
#define HETSLAM_DATASETS_SIM_WORLD_H_

#include <limits>
#include <vector>

#include "Eigen/Core"
#include "Eigen/Geometry"

namespace hetslam {
namespace sim {

// What a 3D ray hit (CastRay3D). kFurniture: tables and shelves (they break the 2.5D
// assumption: different footprints at different heights); kObstacle: low floor obstacles.
enum class Surface { kNone = 0, kFloor, kCeiling, kWall, kFurniture, kObstacle };

// "none", "floor", "ceiling", "wall", "furniture", "obstacle".
const char* SurfaceName(Surface surface);

// A wall: the segment from `a` to `b` in the world frame (metres), zero thickness; in 3D it
// spans z in [0, World::wall_height_meters()]. `source_line` is the scenario line it came from
// (0 when added in code).
struct WallSegment {
  Eigen::Vector2d a = Eigen::Vector2d::Zero();
  Eigen::Vector2d b = Eigen::Vector2d::Zero();
  int source_line = 0;
};

// A vertical prism: the convex polygon `footprint` (world frame, counter-clockwise, at least
// three vertices) extruded from z_min_meters to z_max_meters. A table top, a table leg, one
// part of a shelf, a floor obstacle.
struct Prism {
  std::vector<Eigen::Vector2d> footprint;
  double z_min_meters = 0.0;
  double z_max_meters = 0.0;
  Surface surface = Surface::kFurniture;  // kFurniture or kObstacle
  int source_line = 0;
};

// The result of a 3D ray cast: the distance along the (unit) direction to the first surface,
// and which kind of surface it is, with the scenario line that made it (0 for floor/ceiling).
struct RayHit {
  bool hit = false;
  double range_meters = std::numeric_limits<double>::infinity();
  Surface surface = Surface::kNone;
  int source_line = 0;
  int prism_index = -1;  // into World::prisms() when a prism was hit, else -1
};

// Table geometry used by World::AddTable (metres).
struct TableShape {
  double top_thickness_meters = 0.04;
  double leg_width_meters = 0.05;  // square legs
  double leg_inset_meters = 0.05;  // from the top's corners to the legs' outer faces
};

// A building: walls, prisms, the floor z = 0 and an optional ceiling, with exact ray casting.
// A World built in code has infinitely tall walls and no ceiling (the 2D special case: a
// level 3D ray at any height sees exactly what the 2D ray sees, plus prisms); the scenario
// parser sets the heights (defaults 2.6 m). Queries are brute force over the structures within
// range of the ray origin: a few hundred walls and a few hundred thousand rays take well under
// a second.
class World {
 public:
  // Adds one wall. CHECK-fails on a non-finite or zero-length segment (the parser reports
  // those as user errors before calling this).
  void AddWall(const Eigen::Vector2d& a, const Eigen::Vector2d& b, int source_line = 0);
  // Adds the four walls of a `size_meters.x() x size_meters.y()` rectangle centred at
  // `center`, rotated by `yaw_radians` about its centre.
  void AddBox(const Eigen::Vector2d& center, const Eigen::Vector2d& size_meters,
              double yaw_radians, int source_line = 0);

  // Adds a prism. The footprint must be convex with at least three vertices, either winding
  // (it is stored counter-clockwise); 0 <= z_min < z_max; surface kFurniture or kObstacle.
  // CHECK-fails otherwise (the parser validates user input first).
  void AddPrism(std::vector<Eigen::Vector2d> footprint, double z_min_meters,
                double z_max_meters, Surface surface, int source_line = 0);
  // A rectangular prism of size_meters (x along the yawed box axis) centred at `center`.
  void AddBoxPrism(const Eigen::Vector2d& center, const Eigen::Vector2d& size_meters,
                   double yaw_radians, double z_min_meters, double z_max_meters,
                   Surface surface, int source_line = 0);
  // A table: a top slab of size_meters at [height - top thickness, height] on four square legs
  // [0, height - top thickness] inset from the corners (all kFurniture). Needs each side larger
  // than 2 * (leg inset + leg width) and height larger than the top thickness.
  void AddTable(const Eigen::Vector2d& center, const Eigen::Vector2d& size_meters,
                double yaw_radians, double height_meters, int source_line = 0,
                const TableShape& shape = TableShape());
  // A shelf standing with its back along the segment back_a -> back_b, on the left of that
  // segment seen from above: a lower part `lower_depth` deep from the floor to lower_height,
  // and an upper part `upper_depth` deep from lower_height to height (both kFurniture).
  void AddShelf(const Eigen::Vector2d& back_a, const Eigen::Vector2d& back_b,
                double lower_depth_meters, double lower_height_meters,
                double upper_depth_meters, double height_meters, int source_line = 0);

  // Vertical extent: walls span [0, wall_height], the ceiling is the plane z = ceiling_height
  // (+infinity: none). Both > 0 (CHECK).
  void SetHeights(double wall_height_meters, double ceiling_height_meters);
  double wall_height_meters() const { return wall_height_meters_; }
  double ceiling_height_meters() const { return ceiling_height_meters_; }

  const std::vector<WallSegment>& walls() const { return walls_; }
  const std::vector<Prism>& prisms() const { return prisms_; }
  bool empty() const { return walls_.empty(); }

  // Casts the ray origin + t * (cos(angle), sin(angle)), t >= 0 (world frame), and returns
  // true with the distance `*range_meters` to the nearest wall hit with t <= max_range_meters.
  // Exact segment intersection; a ray parallel to a wall never hits it (grazing), a ray
  // through a wall end point hits it. Returns false when nothing is hit within range.
  // Walls only (see the file comment).
  bool CastRay(const Eigen::Vector2d& origin, double angle_radians, double max_range_meters,
               double* range_meters) const;

  // Casts one ray per entry of `angles_radians` (world frame) from the same origin, with the
  // same result as CastRay for each: `(*ranges_meters)[i]` is the range of ray i, or +infinity
  // when it hits nothing within max range. Faster than calling CastRay per ray: each wall
  // is tested only against the rays inside the angle it subtends at the origin, so a scan
  // costs O(walls log rays + rays + hits) instead of O(walls * rays). Walls only.
  void CastRays(const Eigen::Vector2d& origin, const std::vector<double>& angles_radians,
                double max_range_meters, std::vector<double>* ranges_meters) const;

  // Casts the 3D ray origin + t * direction (direction normalised here; t >= 0, world frame)
  // against the floor, the ceiling, the walls (z within [0, wall height]) and the prisms
  // (exact slab clipping of the convex prism), and returns the nearest hit with
  // t <= max_range_meters (hit = false otherwise). A ray starting inside a prism hits it at 0.
  // Touching counts as a hit (a ray through a wall's top edge or a prism's corner hits it).
  RayHit CastRay3D(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                   double max_range_meters) const;
  // CastRay3D for many directions from one origin (same results); structures farther than
  // max range from the origin (horizontally) are skipped once for all rays.
  void CastRays3D(const Eigen::Vector3d& origin, const std::vector<Eigen::Vector3d>& directions,
                  double max_range_meters, std::vector<RayHit>* hits) const;

  // True when nothing (walls, prisms, floor, ceiling) blocks the open segment from p to q:
  // hits closer than `end_margin_meters` to q are ignored (q may lie on a wall, e.g. a tag).
  bool LineOfSight(const Eigen::Vector3d& p, const Eigen::Vector3d& q,
                   double end_margin_meters = 0.02) const;

  // True when the closed segment p..q crosses or touches any wall.
  bool SegmentHitsWall(const Eigen::Vector2d& p, const Eigen::Vector2d& q) const;

  // Euclidean distance from `p` to the nearest wall (infinity for an empty world).
  double DistanceToNearestWall(const Eigen::Vector2d& p) const;
  // Horizontal distance from `p` to the nearest wall or prism footprint (0 inside a
  // footprint; infinity when there is nothing).
  double DistanceToNearestStructure(const Eigen::Vector2d& p) const;

  // Axis-aligned bounds of all wall end points (an empty box for an empty world).
  Eigen::AlignedBox2d Bounds() const;

 private:
  std::vector<WallSegment> walls_;
  std::vector<Prism> prisms_;
  double wall_height_meters_ = std::numeric_limits<double>::infinity();
  double ceiling_height_meters_ = std::numeric_limits<double>::infinity();
};

}  // namespace sim
}  // namespace hetslam

#endif  // HETSLAM_DATASETS_SIM_WORLD_H_
