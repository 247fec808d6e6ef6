#include "factors/scan_cost.h"

#include <algorithm>
#include <cmath>

#include "ceres/autodiff_cost_function.h"
#include "ceres/cubic_interpolation.h"
#include "glog/logging.h"

namespace hetslam {
namespace {

// A frozen field's tiled, quantised values (core/likelihood_field.h Freeze) as a Ceres grid:
// row y, column x, clamped to the edge like ceres::Grid2D; value = kQuantizationStep * sample.
class FrozenFieldGrid {
 public:
  enum { DATA_DIMENSION = 1 };
  explicit FrozenFieldGrid(const LikelihoodField& field) : field_(field) {}
  void GetValue(int row, int col, double* f) const {
    const GridGeometry& g = field_.geometry();
    f[0] = field_.FrozenValue(std::clamp(col, 0, g.width() - 1), std::clamp(row, 0, g.height() - 1));
  }

 private:
  const LikelihoodField& field_;  // outlives the cost (see the header's lifetime note)
};

// `Grid` is the field's storage: ceres::Grid2D<float> over values() while the field is built,
// FrozenFieldGrid once frozen (quantised: value = value_scale * sample; interpolation is linear
// in the samples, so scaling the interpolated sample is scaling the samples).
template <typename Grid>
class ScanToLikelihoodFieldFunctor {
 public:
  ScanToLikelihoodFieldFunctor(const Grid& grid, double value_scale, const GridGeometry& geometry,
                               const std::vector<Eigen::Vector2f>& points_robot, const std::vector<float>& weights)
      : geometry_(geometry),
        value_scale_(value_scale),
        grid_(grid),
        interpolator_(grid_),
        points_robot_(points_robot),
        scaled_weights_(Scale(weights, points_robot.size())) {}

  template <typename T>
  bool operator()(const T* const world_T_robot, T* residuals) const {
    const T c = ceres::cos(world_T_robot[2]);
    const T s = ceres::sin(world_T_robot[2]);
    const double inv_r = 1.0 / geometry_.resolution_meters();
    for (size_t i = 0; i < points_robot_.size(); ++i) {
      const T px = T(double(points_robot_[i].x()));
      const T py = T(double(points_robot_[i].y()));
      const T wx = c * px - s * py + world_T_robot[0];
      const T wy = s * px + c * py + world_T_robot[1];
      // Samples sit at cell centres: continuous cell coordinate minus 0.5.
      const T col = (wx - geometry_.origin().x()) * inv_r - 0.5;
      const T row = (wy - geometry_.origin().y()) * inv_r - 0.5;
      T likelihood;
      interpolator_.Evaluate(row, col, &likelihood);
      residuals[i] = scaled_weights_[i] * (1.0 - value_scale_ * likelihood);
    }
    return true;
  }

 private:
  static std::vector<double> Scale(const std::vector<float>& weights, size_t n) {
    CHECK(weights.empty() || weights.size() == n)
        << "got " << weights.size() << " weights for " << n << " points";
    CHECK_GT(n, 0u) << "a scan cost needs at least one point";
    std::vector<double> scaled(n, 1.0 / std::sqrt(static_cast<double>(n)));
    for (size_t i = 0; i < weights.size(); ++i) scaled[i] *= weights[i];
    return scaled;
  }

  const GridGeometry geometry_;                            // map frame, metres
  const double value_scale_;                               // field value per stored unit
  const Grid grid_;                                        // field values, row = y, col = x
  const ceres::BiCubicInterpolator<Grid> interpolator_;
  const std::vector<Eigen::Vector2f> points_robot_;        // robot frame, metres
  const std::vector<double> scaled_weights_;               // w_i / sqrt(N)
};

}  // namespace

ceres::CostFunction* CreateScanToLikelihoodFieldCost(const LikelihoodField& field,
                                                     const std::vector<Eigen::Vector2f>& points_robot,
                                                     const std::vector<float>& weights) {
  CHECK_GT(field.geometry().num_cells(), 0) << "the likelihood field is empty";
  const int n = static_cast<int>(points_robot.size());
  if (field.frozen()) {
    using Functor = ScanToLikelihoodFieldFunctor<FrozenFieldGrid>;
    return new ceres::AutoDiffCostFunction<Functor, ceres::DYNAMIC, 3>(
        new Functor(FrozenFieldGrid(field), LikelihoodField::kQuantizationStep, field.geometry(), points_robot,
                    weights),
        n);
  }
  using Grid = ceres::Grid2D<float, 1>;
  using Functor = ScanToLikelihoodFieldFunctor<Grid>;
  return new ceres::AutoDiffCostFunction<Functor, ceres::DYNAMIC, 3>(
      new Functor(Grid(field.values().data(), 0, field.geometry().height(), 0, field.geometry().width()), 1.0,
                  field.geometry(), points_robot, weights),
      n);
}

}  // namespace hetslam
