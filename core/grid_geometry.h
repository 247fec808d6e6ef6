// The one grid convention of hetslam, used by every grid (occupancy, likelihood field,
// rendered images):
//
//  * the grid is axis-aligned in the map frame; `origin` is the world position of the
//    MINIMUM corner of cell (0, 0) (not its centre);
//  * a cell is addressed as CellIndex{x, y}: x is the COLUMN (grows with world x), y is the
//    ROW (grows with world y); cells are stored row-major, linear index = y * width + x;
//  * `resolution_meters` is the side of a square cell; cell (x, y) covers
//    [origin.x + x * r, origin.x + (x + 1) * r) × [origin.y + y * r, origin.y + (y + 1) * r)
//    and its centre is origin + (x + 0.5, y + 0.5) * r.
//
// Images written to disk (PGM, PNG) put row 0 at the top, i.e. they are flipped in y.
#ifndef HETSLAM_CORE_GRID_GEOMETRY_H_
#define HETSLAM_CORE_GRID_GEOMETRY_H_

#include <cmath>

#include "Eigen/Core"

namespace hetslam {

struct CellIndex {
  int x = 0;  // column
  int y = 0;  // row
  bool operator==(const CellIndex& o) const { return x == o.x && y == o.y; }
};

class GridGeometry {
 public:
  GridGeometry() = default;
  GridGeometry(const Eigen::Vector2d& origin, double resolution_meters, int width, int height)
      : origin_(origin), resolution_meters_(resolution_meters), width_(width), height_(height) {}

  const Eigen::Vector2d& origin() const { return origin_; }
  double resolution_meters() const { return resolution_meters_; }
  int width() const { return width_; }
  int height() const { return height_; }
  int num_cells() const { return width_ * height_; }

  CellIndex WorldToCell(const Eigen::Vector2d& p_world) const {
    return {static_cast<int>(std::floor((p_world.x() - origin_.x()) / resolution_meters_)),
            static_cast<int>(std::floor((p_world.y() - origin_.y()) / resolution_meters_))};
  }
  // Continuous cell coordinates: cell centres are at integer + 0.5.
  Eigen::Vector2d WorldToContinuousCell(const Eigen::Vector2d& p_world) const {
    return (p_world - origin_) / resolution_meters_;
  }
  Eigen::Vector2d CellCenter(const CellIndex& c) const {
    return origin_ + Eigen::Vector2d(c.x + 0.5, c.y + 0.5) * resolution_meters_;
  }
  Eigen::Vector2d CellMinCorner(const CellIndex& c) const {
    return origin_ + Eigen::Vector2d(c.x, c.y) * resolution_meters_;
  }
  bool Contains(const CellIndex& c) const {
    return c.x >= 0 && c.y >= 0 && c.x < width_ && c.y < height_;
  }
  int LinearIndex(const CellIndex& c) const { return c.y * width_ + c.x; }
  CellIndex FromLinearIndex(int index) const { return {index % width_, index / width_}; }

 private:
  Eigen::Vector2d origin_ = Eigen::Vector2d::Zero();
  double resolution_meters_ = 0.05;
  int width_ = 0;
  int height_ = 0;
};

}  // namespace hetslam

#endif  // HETSLAM_CORE_GRID_GEOMETRY_H_
