#include "factors/compressed_cost.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <mutex>
#include <vector>

#include "Eigen/Cholesky"
#include "Eigen/Core"
#include "glog/logging.h"

namespace hetslam {
namespace {

// The compressed residuals and Jacobian (the header's formulas) of a tall cost with n residuals
// `r` and row-major n x K Jacobian `j` over a block of K parameters.
template <int K>
void Compress(const double* r, const double* j, int n, double* residuals, double* jacobian) {
  // H = J^T J (its upper triangle), g = J^T r, r^T r, row by row.
  double h[K][K] = {};
  double g[K] = {};
  double rtr = 0.0;
  for (int row = 0; row < n; ++row) {
    const double* jr = j + static_cast<size_t>(row) * K;
    for (int a = 0; a < K; ++a) {
      for (int b = a; b < K; ++b) h[a][b] += jr[a] * jr[b];
      g[a] += jr[a] * r[row];
    }
    rtr += r[row] * r[row];
  }
  Eigen::Matrix<double, K, K> hessian;
  Eigen::Matrix<double, K, 1> gradient;
  for (int a = 0; a < K; ++a) {
    gradient(a) = g[a];
    for (int b = a; b < K; ++b) hessian(a, b) = hessian(b, a) = h[a][b];
  }
  Eigen::Map<Eigen::Matrix<double, K + 1, 1>> out_r(residuals);
  // Row-major (Ceres' layout); a one-column matrix is stored alike either way, and Eigen wants it column-major.
  Eigen::Map<Eigen::Matrix<double, K + 1, K, K == 1 ? Eigen::ColMajor : Eigen::RowMajor>> out_j(jacobian);
  // A non-finite Jacobian or residual: handed on as such, for Ceres to reject the evaluation.
  if (!hessian.allFinite() || !gradient.allFinite() || !std::isfinite(rtr)) {
    out_r.setConstant(std::numeric_limits<double>::quiet_NaN());
    out_j.setConstant(std::numeric_limits<double>::quiet_NaN());
    return;
  }
  const Eigen::LDLT<Eigen::Matrix<double, K, K>> ldlt(hessian);
  const Eigen::Matrix<double, K, 1> d = ldlt.vectorD();
  const Eigen::Matrix<double, K, 1> y = ldlt.matrixL().solve(ldlt.transpositionsP() * gradient);
  // J' = sqrt(Dg) L^T P: the rows of sqrt(Dg) L^T, their columns permuted (times P on the right).
  Eigen::Matrix<double, K, K> root = ldlt.matrixL().transpose();
  double compressed_squared = 0.0;
  for (int i = 0; i < K; ++i) {
    const double root_d = d(i) > 0.0 ? std::sqrt(d(i)) : 0.0;
    root.row(i) *= root_d;
    out_r(i) = root_d > 0.0 ? y(i) / root_d : 0.0;
    compressed_squared += out_r(i) * out_r(i);
  }
  out_r(K) = std::sqrt(std::max(0.0, rtr - compressed_squared));
  const Eigen::Matrix<double, K, K> permutation = ldlt.transpositionsP() * Eigen::Matrix<double, K, K>::Identity();
  out_j.template topRows<K>() = root * permutation;
  out_j.row(K).setZero();
}

class CompressedCost final : public ceres::CostFunction {
 public:
  explicit CompressedCost(ceres::CostFunction* tall_cost) : tall_(tall_cost) {
    CHECK(tall_ != nullptr) << "CreateCompressedCost needs a cost";
    CHECK_EQ(tall_->parameter_block_sizes().size(), 1u)
        << "CreateCompressedCost takes a cost over one parameter block, got "
        << tall_->parameter_block_sizes().size();
    k_ = tall_->parameter_block_sizes()[0];
    CHECK(k_ >= 1 && k_ <= kMaxCompressedParameters)
        << "CreateCompressedCost takes a block of 1.." << kMaxCompressedParameters << " parameters, got " << k_;
    CHECK_GE(tall_->num_residuals(), 1) << "CreateCompressedCost needs a cost with residuals";
    set_num_residuals(k_ + 1);
    mutable_parameter_block_sizes()->push_back(k_);
    residuals_.resize(static_cast<size_t>(tall_->num_residuals()));
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    std::lock_guard<std::mutex> lock(mutex_);
    const int n = tall_->num_residuals();
    const bool with_jacobian = jacobians != nullptr && jacobians[0] != nullptr;
    if (with_jacobian) jacobian_.resize(static_cast<size_t>(n) * k_);
    double* tall_jacobians[1] = {with_jacobian ? jacobian_.data() : nullptr};
    if (!tall_->Evaluate(parameters, residuals_.data(), with_jacobian ? tall_jacobians : nullptr)) return false;
    if (!with_jacobian) {
      double rtr = 0.0;
      for (const double r : residuals_) rtr += r * r;
      std::fill(residuals, residuals + k_ + 1, 0.0);
      residuals[0] = std::sqrt(rtr);
      return true;
    }
    switch (k_) {
      case 1: Compress<1>(residuals_.data(), jacobian_.data(), n, residuals, jacobians[0]); break;
      case 2: Compress<2>(residuals_.data(), jacobian_.data(), n, residuals, jacobians[0]); break;
      case 3: Compress<3>(residuals_.data(), jacobian_.data(), n, residuals, jacobians[0]); break;
      case 4: Compress<4>(residuals_.data(), jacobian_.data(), n, residuals, jacobians[0]); break;
      case 5: Compress<5>(residuals_.data(), jacobian_.data(), n, residuals, jacobians[0]); break;
      default: Compress<6>(residuals_.data(), jacobian_.data(), n, residuals, jacobians[0]); break;
    }
    return true;
  }

 private:
  const std::unique_ptr<ceres::CostFunction> tall_;
  int k_ = 0;
  // The tall cost's residuals and row-major Jacobian, reused between evaluations.
  mutable std::mutex mutex_;
  mutable std::vector<double> residuals_;
  mutable std::vector<double> jacobian_;
};

}  // namespace

ceres::CostFunction* CreateCompressedCost(ceres::CostFunction* tall_cost) { return new CompressedCost(tall_cost); }

}  // namespace hetslam
