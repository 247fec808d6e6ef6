#include "factors/sqrt_information.h"

#include <algorithm>
#include <cmath>

#include "Eigen/Cholesky"
#include "Eigen/LU"
#include "glog/logging.h"

namespace hetslam {
namespace {

void CheckSymmetricFinite(const Eigen::Matrix3d& m, const char* what) {
  CHECK(m.allFinite()) << what << " has non-finite entries:\n" << m;
  const double scale = std::max(1.0, m.cwiseAbs().maxCoeff());
  CHECK_LE((m - m.transpose()).cwiseAbs().maxCoeff(), 1e-9 * scale)
      << what << " is not symmetric:\n"
      << m;
}

}  // namespace

Eigen::Matrix3d SqrtInformationFromInformation(const Eigen::Matrix3d& information) {
  CheckSymmetricFinite(information, "information matrix");
  const Eigen::LLT<Eigen::Matrix3d> llt(information);
  CHECK(llt.info() == Eigen::Success) << "information matrix is not positive definite:\n"
                                      << information;
  // information = L L^T  =>  S = L^T satisfies S^T S = information.
  return llt.matrixU();
}

Eigen::Matrix3d SqrtInformationFromCovariance(const Eigen::Matrix3d& covariance) {
  CheckSymmetricFinite(covariance, "covariance");
  const Eigen::LLT<Eigen::Matrix3d> llt(covariance);
  CHECK(llt.info() == Eigen::Success) << "covariance is not positive definite:\n" << covariance;
  // Invert through the Cholesky factor (stable for a PD matrix) and re-symmetrise.
  Eigen::Matrix3d information = llt.solve(Eigen::Matrix3d::Identity());
  information = 0.5 * (information + information.transpose()).eval();
  return SqrtInformationFromInformation(information);
}

Eigen::Matrix3d SqrtInformationFromStddev(double sigma_x_meters, double sigma_y_meters,
                                          double sigma_yaw_radians) {
  for (const double sigma : {sigma_x_meters, sigma_y_meters, sigma_yaw_radians}) {
    CHECK(std::isfinite(sigma) && sigma > 0.0) << "standard deviation must be > 0, got " << sigma;
  }
  return Eigen::Vector3d(1.0 / sigma_x_meters, 1.0 / sigma_y_meters, 1.0 / sigma_yaw_radians)
      .asDiagonal();
}

}  // namespace hetslam
