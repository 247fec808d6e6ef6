#include "core/likelihood_field.h"

#include <cmath>
#include <limits>
#include <sstream>

#include "glog/logging.h"

namespace hetslam {
namespace {
const Eigen::Vector2f kNone(std::numeric_limits<float>::quiet_NaN(),
                            std::numeric_limits<float>::quiet_NaN());
constexpr float kInfinity = std::numeric_limits<float>::infinity();
// Marks a squared distance as stale (no real d^2 is negative); see ApplyChanges.
constexpr float kStale = -1.f;
}  // namespace

bool LikelihoodFieldOptions::IsValid(std::string* error) const {
  std::ostringstream msg;
  // Upper limits: the field's window is (2 max_distance / cell)^2 cells around every hit.
  if (!(sigma_meters > 0.0 && sigma_meters <= 5.0))
    msg << "sigma_meters must be in (0, 5] (got " << sigma_meters << "); ";
  if (!(max_distance_meters > 0.0 && max_distance_meters <= 5.0))
    msg << "max_distance_meters must be in (0, 5] (got " << max_distance_meters << "); ";
  if (!(republish_distance_meters >= 0.0)) msg << "republish_distance_meters must be >= 0; ";
  if (error != nullptr) *error = msg.str();
  return msg.str().empty();
}

LikelihoodField::LikelihoodField(const LikelihoodFieldOptions& options) : options_(options) {
  std::string error;
  CHECK(options_.IsValid(&error)) << "invalid LikelihoodFieldOptions: " << error;
}

void LikelihoodField::Freeze() {
  frozen_ = true;
  std::vector<Eigen::Vector2f>().swap(published_);
  std::vector<float>().swap(squared_distances_);
}

void LikelihoodField::Resize(const GridGeometry& g) {
  CHECK(!frozen_) << "Resize on a frozen likelihood field";
  const double r = g.resolution_meters();
  radius_cells_ = static_cast<int>(std::ceil(options_.max_distance_meters / r - 1e-9));
  std::vector<float> values(g.num_cells(), 0.f);
  std::vector<float> squared_distances(g.num_cells(), kInfinity);
  std::vector<Eigen::Vector2f> published(g.num_cells(), kNone);
  if (geometry_.num_cells() > 0) {
    CHECK_EQ(g.resolution_meters(), geometry_.resolution_meters()) << "resolution changed";
    const int dx = static_cast<int>(std::lround((geometry_.origin().x() - g.origin().x()) / r));
    const int dy = static_cast<int>(std::lround((geometry_.origin().y() - g.origin().y()) / r));
    for (int y = 0; y < geometry_.height(); ++y) {
      for (int x = 0; x < geometry_.width(); ++x) {
        const int from = y * geometry_.width() + x;
        const int to = (y + dy) * g.width() + (x + dx);
        values[to] = values_[from];
        squared_distances[to] = squared_distances_[from];
        published[to] = published_[from];
      }
    }
  }
  geometry_ = g;
  values_.swap(values);
  squared_distances_.swap(squared_distances);
  published_.swap(published);
}

float LikelihoodField::ValueFromSquaredDistance(float squared_distance) const {
  return std::exp(-std::sqrt(squared_distance) / static_cast<float>(options_.sigma_meters));
}

float LikelihoodField::RecomputeSquaredDistance(const CellIndex& c) const {
  float best = kInfinity;
  const int x0 = std::max(0, c.x - radius_cells_), x1 = std::min(geometry_.width() - 1, c.x + radius_cells_);
  const int y0 = std::max(0, c.y - radius_cells_), y1 = std::min(geometry_.height() - 1, c.y + radius_cells_);
  for (int y = y0; y <= y1; ++y) {
    for (int x = x0; x <= x1; ++x) {
      // No HasPublished branch: an unpublished cell's NaN point gives a NaN d^2, which
      // std::min(best, NaN) ignores (it returns best when the comparison is false).
      best = std::min(best, SquaredDistance(c, {x, y}, published_[y * geometry_.width() + x]));
    }
  }
  return best;
}

void LikelihoodField::ApplyChanges(const OccupancyGrid& grid, const std::vector<int>& changed_cells) {
  CHECK(!frozen_) << "ApplyChanges on a frozen likelihood field";
  if (geometry_.num_cells() != grid.geometry().num_cells() ||
      geometry_.origin() != grid.geometry().origin()) {
    Resize(grid.geometry());
  }
  const float republish_sq = static_cast<float>(options_.republish_distance_meters * options_.republish_distance_meters);
  // Cells that may have lost their nearest point are recomputed once, after every change of
  // this batch is published: neighbouring hit points along a wall often republish together,
  // and would otherwise recompute the same cells several times. Until then they are marked
  // kStale and skipped (the final recompute reads the final published points, so the result
  // is the same as recomputing at once).
  stale_cells_.clear();
  for (int i : changed_cells) {
    const CellIndex o = geometry_.FromLinearIndex(i);
    const Eigen::Vector2f old_p = published_[i];
    const bool had = HasPublished(i);
    const bool has = grid.IsOccupied(i);
    Eigen::Vector2f new_p = kNone;
    if (has) {
      new_p = (grid.HitPoint(i) - geometry_.CellMinCorner(o)).cast<float>();
      if (had && (new_p - old_p).squaredNorm() <= republish_sq) continue;  // not worth republishing
    } else if (!had) {
      continue;
    }
    published_[i] = new_p;
    const int x0 = std::max(0, o.x - radius_cells_), x1 = std::min(geometry_.width() - 1, o.x + radius_cells_);
    const int y0 = std::max(0, o.y - radius_cells_), y1 = std::min(geometry_.height() - 1, o.y + radius_cells_);
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        const CellIndex c{x, y};
        const int j = y * geometry_.width() + x;
        float& squared_distance = squared_distances_[j];
        if (squared_distance == kStale) continue;
        const float new_squared_distance = has ? SquaredDistance(c, o, new_p) : kInfinity;
        if (new_squared_distance < squared_distance) {
          squared_distance = new_squared_distance;
          values_[j] = ValueFromSquaredDistance(squared_distance);
        } else if (had && new_squared_distance > squared_distance &&
                   SquaredDistance(c, o, old_p) <= squared_distance) {
          // c's nearest point may have been o's old point, which is gone: recompute it
          // (below). A new d^2 equal to the old minimum leaves the minimum as it is.
          squared_distance = kStale;
          stale_cells_.push_back(j);
        }
      }
    }
  }
  for (int j : stale_cells_) {
    squared_distances_[j] = RecomputeSquaredDistance(geometry_.FromLinearIndex(j));
    values_[j] = ValueFromSquaredDistance(squared_distances_[j]);
  }
}

void LikelihoodField::RebuildAll() {
  CHECK(!frozen_) << "RebuildAll on a frozen likelihood field";
  for (int y = 0; y < geometry_.height(); ++y) {
    for (int x = 0; x < geometry_.width(); ++x) {
      const int i = y * geometry_.width() + x;
      squared_distances_[i] = RecomputeSquaredDistance({x, y});
      values_[i] = ValueFromSquaredDistance(squared_distances_[i]);
    }
  }
}

void LikelihoodField::RebuildFrom(const OccupancyGrid& grid) {
  Resize(grid.geometry());
  for (int i = 0; i < geometry_.num_cells(); ++i) {
    published_[i] = grid.IsOccupied(i)
                        ? Eigen::Vector2f((grid.HitPoint(i) - geometry_.CellMinCorner(geometry_.FromLinearIndex(i))).cast<float>())
                        : kNone;
  }
  RebuildAll();
}

}  // namespace hetslam
