// Square-root information matrices for least-squares residuals.
//
// A Gaussian error e ~ N(0, Sigma) enters Ceres as the residual r = S e with S^T S = Sigma^-1,
// so that ||r||^2 = e^T Sigma^-1 e (squared Mahalanobis distance; Ceres minimises 1/2 of the
// sum of these). Convert once, when a factor is constructed, never inside operator().
//
// Convention: S is UPPER triangular, S = L^T where Sigma^-1 = L L^T is the (lower) Cholesky
// factorisation of the information matrix. Any S with S^T S = Sigma^-1 gives the same cost; the
// upper-triangular one is unique (positive diagonal) and cheap to apply.
//
// Units: S has the inverse units of the error: 1/m for translation rows, 1/rad for yaw rows.
#ifndef HETSLAM_FACTORS_SQRT_INFORMATION_H_
#define HETSLAM_FACTORS_SQRT_INFORMATION_H_

#include "Eigen/Core"

namespace hetslam {

// S (upper triangular) with S^T S = covariance^-1. CHECK-fails unless `covariance` is finite,
// symmetric (to 1e-9 relative) and positive definite: a programmer error here, since inputs
// from files are validated by their readers (core/g2o_io.h).
Eigen::Matrix3d SqrtInformationFromCovariance(const Eigen::Matrix3d& covariance);

// S (upper triangular) with S^T S = information. Same checks as above.
Eigen::Matrix3d SqrtInformationFromInformation(const Eigen::Matrix3d& information);

// Diagonal S for independent errors: diag(1/sigma_x, 1/sigma_y, 1/sigma_yaw), sigmas in metres,
// metres, radians. CHECK-fails unless every sigma is finite and > 0.
Eigen::Matrix3d SqrtInformationFromStddev(double sigma_x_meters, double sigma_y_meters,
                                          double sigma_yaw_radians);

}  // namespace hetslam

#endif  // HETSLAM_FACTORS_SQRT_INFORMATION_H_
