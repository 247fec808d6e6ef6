// A tall cost over one small parameter block, handed to Ceres as k + 1 residuals that give the
// same cost, gradient and Gauss-Newton Hessian at every point.
//
// For a cost with N residuals r(x) over one block x of k parameters (N >> k: a scan's points
// over a pose), with Jacobian J = dr/dx, Ceres' trust-region solvers use r and J only through
//   the cost  F = 1/2 r^T r,   the gradient  g = J^T r,   the Hessian's model  H = J^T J
// (the Levenberg-Marquardt step solves (H + mu D^T D) dx = -g, D^T D = diag(H) clamped; the
// model's change and the Jacobi scaling, sqrt(diag(H)), are made of the same three). With
// H = P^T L Dg L^T P (pivoted LDL^T), the compressed residuals and Jacobian
//   J' = [ sqrt(Dg) L^T P ]        r' = [ sqrt(Dg)^-1 L^-1 P g       ]
//        [ 0 ... 0        ]             [ sqrt(r^T r - |that|^2)     ]
// have J'^T J' = H, J'^T r' = g and r'^T r' = r^T r, so a Ceres solve over them takes the same
// steps as over the N residuals, up to rounding; Ceres' own work per evaluation (checking,
// copying and factorising an N x k Jacobian) shrinks to a (k + 1) x k one. Where H is singular
// (Dg_i = 0) the component of g along it is 0 too and r'_i is 0. A manifold on the block is
// applied by Ceres to J' as to J, so the same holds in its tangent space.
//
// Evaluations without a Jacobian return r' = [sqrt(r^T r), 0, ..., 0]: only the cost is read
// from those. The compressed residuals mean nothing one by one: no loss function on them (a
// robust loss of the N residuals is not the loss of their sum); use it where the tall cost's
// residuals are already bounded (a scan cost against a likelihood field, factors/scan_cost.h).
//
// Ownership: CreateCompressedCost takes `tall_cost` (deleted with the returned cost, which the
// caller owns until it is handed to ceres::Problem::AddResidualBlock). Evaluations take a lock,
// as a scan cost does: one at a time.
#ifndef HETSLAM_FACTORS_COMPRESSED_COST_H_
#define HETSLAM_FACTORS_COMPRESSED_COST_H_

#include "ceres/cost_function.h"

namespace hetslam {

// The largest parameter block CreateCompressedCost takes.
inline constexpr int kMaxCompressedParameters = 6;

// `tall_cost` must have exactly one parameter block of 1..kMaxCompressedParameters parameters
// and at least one residual (CHECKed: a programmer error). The returned cost has one residual
// more than that block has parameters.
ceres::CostFunction* CreateCompressedCost(ceres::CostFunction* tall_cost);

}  // namespace hetslam

#endif  // HETSLAM_FACTORS_COMPRESSED_COST_H_
