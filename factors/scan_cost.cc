#include "factors/scan_cost.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <mutex>

#include "glog/logging.h"

namespace hetslam {
namespace {

// A frozen field's tiled distance codes (core/likelihood_field.h Freeze) as a Ceres grid of
// what each code stands for (`table`: its value or its squared distance): row y, column x,
// clamped to the edge like ceres::Grid2D.
template <typename T>
class FrozenFieldGrid {
 public:
  enum { DATA_DIMENSION = 1 };
  FrozenFieldGrid(const LikelihoodField& field, const T* table) : field_(field), table_(table) {}
  void GetValue(int row, int col, double* f) const {
    const GridGeometry& g = field_.geometry();
    f[0] = table_[field_.FrozenCode(std::clamp(col, 0, g.width() - 1), std::clamp(row, 0, g.height() - 1))];
  }

 private:
  const LikelihoodField& field_;  // outlives the cost (see the header's lifetime note)
  const T* table_;                // 256 entries, shared and never freed (LikelihoodField::FrozenCodes)
};

// The same for a field that is being built: its values, tiled (core/likelihood_field.h values).
class BuiltFieldGrid {
 public:
  enum { DATA_DIMENSION = 1 };
  explicit BuiltFieldGrid(const LikelihoodField& field) : field_(field) {}
  void GetValue(int row, int col, double* f) const {
    const GridGeometry& g = field_.geometry();
    f[0] = field_.values().Get(std::clamp(col, 0, g.width() - 1), std::clamp(row, 0, g.height() - 1));
  }

 private:
  const LikelihoodField& field_;  // outlives the cost (see the header's lifetime note)
};

// The field's distances instead of its values (a field being built; a frozen one keeps
// distances, FrozenFieldGrid): at each cell centre the distance d to the
// nearest surface recovered from the stored value L = exp(-d / sigma) as d = -sigma ln L (the
// window's radius where L is 0 or below exp(-radius / sigma)), served squared. Near a straight
// wall d^2 is a quadratic in the position, which the bicubic (Catmull-Rom) interpolation
// reproduces exactly between cell centres, so the interpolated kernel exp(-d / sigma) peaks on
// the wall itself; the interpolated values peak at cell centres (a cusp is interpolated by
// its samples), which pulls each wall towards the cell grid by up to half a cell.
//
// The squared distances served are remembered per thread: a refinement evaluates its cost about
// twenty times around one pose and reads the same cells each time, each read a tile lookup and
// a logarithm (the logarithms alone were ~3% of a FR079 run). A direct-mapped table, each
// entry keyed by the grid's id (unique to each SquaredDistanceGrid made, so a later cost never
// reads an earlier one's entries) and the cell; a cell's value is fixed while the cost is used (the header's lifetime
// note), so every value served is the one computed without the table.
struct CachedSquaredDistance {
  uint64_t grid_id = 0;  // 0: empty
  int row = 0;
  int col = 0;
  double value = 0.0;
};
constexpr int kCacheBits = 12;  // 4096 entries, 96 KiB a thread

CachedSquaredDistance* ThreadSquaredDistanceCache() {
  thread_local std::unique_ptr<CachedSquaredDistance[]> cache(new CachedSquaredDistance[1 << kCacheBits]);
  return cache.get();
}

uint64_t NewGridId() {
  static std::atomic<uint64_t> next{1};
  return next.fetch_add(1, std::memory_order_relaxed);
}

template <typename ValueGrid>
class SquaredDistanceGrid {
 public:
  enum { DATA_DIMENSION = 1 };
  SquaredDistanceGrid(const ValueGrid& values, double value_scale, double sigma_meters, double max_distance_meters)
      : values_(values),
        value_scale_(value_scale),
        sigma_(sigma_meters),
        max_distance_(max_distance_meters),
        min_value_(std::exp(-max_distance_meters / sigma_meters)),
        id_(NewGridId()) {}
  void GetValue(int row, int col, double* f) const {
    const uint32_t hash = (static_cast<uint32_t>(row) * 0x9E3779B1u) ^ (static_cast<uint32_t>(col) * 0x85EBCA77u);
    CachedSquaredDistance& entry = ThreadSquaredDistanceCache()[hash >> (32 - kCacheBits)];
    if (entry.grid_id == id_ && entry.row == row && entry.col == col) {
      f[0] = entry.value;
      return;
    }
    double value = 0.0;
    values_.GetValue(row, col, &value);
    value *= value_scale_;
    const double d = value > min_value_ ? -sigma_ * std::log(value) : max_distance_;
    f[0] = d * d;
    entry = {id_, row, col, f[0]};
  }

 private:
  const ValueGrid values_;
  const double value_scale_;
  const double sigma_;
  const double max_distance_;
  const double min_value_;
  const uint64_t id_;
};

// ceres::CubicHermiteSpline (ceres/cubic_interpolation.h) for one value, operation for
// operation, so the same doubles: the Catmull-Rom spline through p[0..3] at x in [0, 1]
// between p[1] and p[2] is d + x (c + x (b + x a)) with these coefficients; its derivative
// c + x (2 b + 3 a x).
struct SplineCoefficients {
  double a, b, c, d;
};
inline SplineCoefficients HermiteCoefficients(const double p[4]) {
  return {0.5 * (-p[0] + 3.0 * p[1] - 3.0 * p[2] + p[3]), 0.5 * (2.0 * p[0] - 5.0 * p[1] + 4.0 * p[2] - p[3]),
          0.5 * (-p[0] + p[2]), p[1]};
}
inline void HermiteSpline(const SplineCoefficients& k, double x, double* f, double* dfdx) {
  *f = k.d + x * (k.c + x * (k.b + x * k.a));
  if (dfdx != nullptr) *dfdx = k.c + x * (2.0 * k.b + 3.0 * k.a * x);
}
inline void HermiteSpline(const double p[4], double x, double* f, double* dfdx) {
  HermiteSpline(HermiteCoefficients(p), x, f, dfdx);
}

// `Grid` is the field's storage: BuiltFieldGrid over values() (or SquaredDistanceGrid of it)
// while the field is built, FrozenFieldGrid over its codes' values or squared distances once
// frozen; value = value_scale * sample (interpolation is linear in the samples, so scaling the
// interpolated sample is scaling the samples).
//
// The derivatives are written out. Each evaluation reads 16 cells a point (the bicubic
// interpolation), and Ceres' trust-region loop evaluates each point it accepts twice, its cost
// and then its Jacobian: the last pose's interpolated samples and their derivatives are kept,
// and an evaluation at the same pose only redoes the arithmetic after them (issue #15: the
// refinement was ~17% of an Intel run, half of it these second reads and the automatic
// differentiation's Jet arithmetic). The arithmetic repeats, operation for operation, what
// ceres::AutoDiffCostFunction computed over this formula until session 31 (its Jet scalar parts
// with a Jacobian; plain doubles without one, which differ in a last bit: -d / sigma there
// against -d * (1 / sigma) in a Jet), so every residual and Jacobian entry is the same double
// (tests/factors/scan_cost_test.cc checks them against the automatic differentiation over
// ceres::BiCubicInterpolator). The interpolation is that interpolator's arithmetic, inline
// (HermiteSpline), over cells read once per cell a point enters (Sample::patch).
template <typename Grid>
class ScanToLikelihoodFieldCost final : public ceres::CostFunction {
 public:
  // sigma_meters > 0: `grid` serves squared distances (SquaredDistanceGrid), turned into the
  // kernel exp(-d / sigma) after interpolation; else field values times value_scale.
  ScanToLikelihoodFieldCost(const Grid& grid, double value_scale, double sigma_meters, const GridGeometry& geometry,
                            const std::vector<Eigen::Vector2f>& points_robot, const std::vector<float>& weights)
      : geometry_(geometry),
        value_scale_(value_scale),
        sigma_meters_(sigma_meters),
        grid_(grid),
        points_robot_(points_robot),
        scaled_weights_(Scale(weights, points_robot.size())),
        samples_(points_robot.size()) {
    set_num_residuals(static_cast<int>(points_robot.size()));
    mutable_parameter_block_sizes()->push_back(3);
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const double* pose = parameters[0];
    // One evaluation at a time: the kept samples are shared (a cost added to several residual
    // blocks of a problem solved on several threads waits here).
    std::lock_guard<std::mutex> lock(mutex_);
    const double c = std::cos(pose[2]);
    const double s = std::sin(pose[2]);
    const double inv_r = 1.0 / geometry_.resolution_meters();
    if (!sampled_ || std::memcmp(sampled_pose_, pose, sizeof(sampled_pose_)) != 0) {
      for (size_t i = 0; i < points_robot_.size(); ++i) {
        const double px = double(points_robot_[i].x());
        const double py = double(points_robot_[i].y());
        const double wx = c * px - s * py + pose[0];
        const double wy = s * px + c * py + pose[1];
        // Samples sit at cell centres: continuous cell coordinate minus 0.5.
        const double col = (wx - geometry_.origin().x()) * inv_r - 0.5;
        const double row = (wy - geometry_.origin().y()) * inv_r - 0.5;
        Sample& sample = samples_[i];
        // ceres::BiCubicInterpolator<Grid>::Evaluate's arithmetic, operation for operation: the
        // four rows' splines along x, then theirs and their derivatives' along y. Its 16 cells
        // are read, and the rows' spline coefficients computed, again only when the point
        // moved to another cell.
        const int cell_row = std::floor(row);
        const int cell_col = std::floor(col);
        if (!sample.has_patch || cell_row != sample.row || cell_col != sample.col) {
          for (int r = 0; r < 4; ++r) {
            double patch_row[4];
            for (int k = 0; k < 4; ++k) grid_.GetValue(cell_row - 1 + r, cell_col - 1 + k, &patch_row[k]);
            sample.rows[r] = HermiteCoefficients(patch_row);
          }
          sample.row = cell_row;
          sample.col = cell_col;
          sample.has_patch = true;
        }
        double along_x[4], along_x_derivative[4];
        for (int r = 0; r < 4; ++r) HermiteSpline(sample.rows[r], col - cell_col, &along_x[r], &along_x_derivative[r]);
        HermiteSpline(along_x, row - cell_row, &sample.f, &sample.dfdr);
        HermiteSpline(along_x_derivative, row - cell_row, &sample.dfdc, nullptr);
      }
      std::memcpy(sampled_pose_, pose, sizeof(sampled_pose_));
      sampled_ = true;
    }
    // With `jacobians` (even when its block is constant, jacobians[0] null) the residuals are a
    // Jet's scalar parts, as the automatic differentiation's were.
    const bool jet = jacobians != nullptr;
    double* jacobian = jet ? jacobians[0] : nullptr;
    const double inv_sigma = sigma_meters_ > 0 ? 1.0 / sigma_meters_ : 0.0;
    for (size_t i = 0; i < points_robot_.size(); ++i) {
      const Sample& sample = samples_[i];
      const double w = scaled_weights_[i];
      if (!jet) {
        double likelihood;
        if (sigma_meters_ > 0) {  // the sample is d^2 (SquaredDistanceGrid)
          // 1 mm floor: sqrt's derivative at 0 is infinite.
          const double d = std::sqrt((sample.f < 0.0 ? 0.0 : sample.f) + 1e-6);
          likelihood = std::exp(-d / sigma_meters_);
        } else {
          likelihood = value_scale_ * sample.f;
        }
        residuals[i] = w * (1.0 - likelihood);
        continue;
      }
      // d sample / d (x, y, yaw): the chain through the point's world position (as a Jet's
      // dual parts: d col / dx = 1 / r, d row / dy = 1 / r, the yaw through both).
      const double px = double(points_robot_[i].x());
      const double py = double(points_robot_[i].y());
      const double dwx_dyaw = -s * px - c * py;
      const double dwy_dyaw = c * px + -s * py;
      double v[3] = {sample.dfdc * inv_r, sample.dfdr * inv_r,
                     sample.dfdr * (dwy_dyaw * inv_r) + sample.dfdc * (dwx_dyaw * inv_r)};
      double likelihood;
      if (sigma_meters_ > 0) {
        const bool floored = sample.f < 0.0;
        const double d = std::sqrt((floored ? 0.0 : sample.f) + 1e-6);
        const double two_d_inverse = 1.0 / (2.0 * d);
        likelihood = std::exp(-d * inv_sigma);
        for (double& vk : v) vk = floored ? 0.0 : likelihood * (-(vk * two_d_inverse) * inv_sigma);
      } else {
        likelihood = sample.f * value_scale_;
        for (double& vk : v) vk = vk * value_scale_;
      }
      residuals[i] = (1.0 - likelihood) * w;
      if (jacobian != nullptr) {
        for (int k = 0; k < 3; ++k) jacobian[3 * i + k] = -v[k] * w;
      }
    }
    return true;
  }

 private:
  struct Sample {
    // Only has_patch is set: the rest is written before it is read (Evaluate). A value-initialised
    // vector of Samples with member initialisers was zeroed first, 168 bytes a point for every
    // cost made (1% of a FR079 run in memset).
    Sample() {}  // NOLINT: user-provided, so std::vector<Sample>(n) does not zero it
    double f;     // the interpolated sample
    double dfdr;  // its derivatives along rows (y) and columns (x), per cell
    double dfdc;
    // The 4 x 4 cells around the point's last cell (row, col), as the splines along x of its
    // four rows: rows[i] through the grid's values at row - 1 + i, columns col - 1 .. col + 2.
    // Most of a refinement's steps leave a point in its cell (87% of the points' evaluations on
    // Intel, 89% on FR079), and each of the 16 reads is a tile or a cache lookup (the
    // interpolation was ~9% of a FR079 run; the rows' coefficients, computed at every
    // evaluation until session 53, 3% of its instructions).
    bool has_patch = false;
    int row;
    int col;
    SplineCoefficients rows[4];
  };

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
  const double sigma_meters_;                              // > 0: the grid serves d^2
  const Grid grid_;                                        // field values, row = y, col = x
  const std::vector<Eigen::Vector2f> points_robot_;        // robot frame, metres
  const std::vector<double> scaled_weights_;               // w_i / sqrt(N)
  // The last pose evaluated (bit for bit) and each point's sample there.
  mutable std::mutex mutex_;
  mutable bool sampled_ = false;
  mutable double sampled_pose_[3] = {0.0, 0.0, 0.0};
  mutable std::vector<Sample> samples_;
};

template <typename Grid>
ceres::CostFunction* MakeCost(const Grid& grid, double value_scale, double sigma_meters, const LikelihoodField& field,
                              const std::vector<Eigen::Vector2f>& points_robot, const std::vector<float>& weights) {
  return new ScanToLikelihoodFieldCost<Grid>(grid, value_scale, sigma_meters, field.geometry(), points_robot, weights);
}

}  // namespace

bool ParseScanCostInterpolation(const std::string& name, ScanCostInterpolation* interpolation) {
  if (name == "values") {
    *interpolation = ScanCostInterpolation::kValues;
  } else if (name == "distances") {
    *interpolation = ScanCostInterpolation::kDistances;
  } else {
    return false;
  }
  return true;
}

ceres::CostFunction* CreateScanToLikelihoodFieldCost(const LikelihoodField& field,
                                                     const std::vector<Eigen::Vector2f>& points_robot,
                                                     const std::vector<float>& weights,
                                                     ScanCostInterpolation interpolation) {
  CHECK_GT(field.geometry().num_cells(), 0) << "the likelihood field is empty";
  const double sigma = field.options().sigma_meters;
  const double max_distance = field.window_radius_cells() * field.geometry().resolution_meters();
  if (field.frozen()) {
    // The codes are distances: their squares are served as they are (capped at max_distance
    // like SquaredDistanceGrid's), their values from the same table as every other reader's.
    const LikelihoodField::FrozenCodes& codes = field.frozen_codes();
    if (interpolation == ScanCostInterpolation::kDistances) {
      return MakeCost(FrozenFieldGrid<double>(field, codes.squared_distance), 1.0, sigma, field, points_robot,
                      weights);
    }
    return MakeCost(FrozenFieldGrid<float>(field, codes.value), 1.0, 0.0, field, points_robot, weights);
  }
  if (interpolation == ScanCostInterpolation::kDistances) {
    return MakeCost(SquaredDistanceGrid<BuiltFieldGrid>(BuiltFieldGrid(field), 1.0, sigma, max_distance), 1.0, sigma,
                    field, points_robot, weights);
  }
  return MakeCost(BuiltFieldGrid(field), 1.0, 0.0, field, points_robot, weights);
}

}  // namespace hetslam
