// Scan-to-likelihood-field cost: how badly a scan's points, placed by a candidate pose,
// miss the map's likelihood field (paper §III-C, eq. 1).
//
// For N points p_i (robot frame, metres) with weights w_i and a pose block
// world_T_robot = [x, y, yaw] (metres, metres, radians):
//   r_i = w_i / sqrt(N) * (1 - L(R(yaw) p_i + [x y]^T)),
// where L is the likelihood field (core/likelihood_field.h) interpolated bicubically between
// cell centres (Catmull-Rom, C1, exact at cell centres: ceres::BiCubicInterpolator's arithmetic). Outside
// the grid L takes the nearest border cell's value, which is 0 on a LaserMap's grid (its border
// margin exceeds the likelihood window). Maximising the summed likelihood (eq. 1) is
// minimising sum r_i^2. The 1/sqrt(N) keeps a scan's pull independent of its beam count. A
// point with w_i = 0 (a floor obstacle) contributes nothing itself but still counts in N.
// Walls weigh more (paper §III-E) through a second cost of this kind over the same points and
// the map's wall field (core/laser_map.h wall_field), weights sqrt(wall_weight - 1): both
// fields are read where the candidate pose puts each point (frontends/scan_matcher.cc).
//
// No robust loss: the field is already bounded in [0, 1].
//
// A frozen field (core/likelihood_field.h) is read in its quantised form (8-bit distance codes:
// the squared distances, or the values, from its code table), without a copy.
//
// Lifetime: the cost keeps a pointer to `field.values()` (to `field` itself when frozen) and
// a copy of `field.geometry()` —
// the field must outlive the cost function and must not be modified or resized (no scan
// insertion) while the cost is used. The points and weights are copied.
#ifndef HETSLAM_FACTORS_SCAN_COST_H_
#define HETSLAM_FACTORS_SCAN_COST_H_

#include <string>
#include <vector>

#include "Eigen/Core"
#include "ceres/cost_function.h"
#include "core/likelihood_field.h"

namespace hetslam {

// What is interpolated between cell centres:
//  - kValues: the field's values L (as above). L = exp(-d / sigma) has a cusp on a surface,
//    and an interpolant of a cusp peaks at its samples: a wall is pulled towards the nearest
//    cell centre, by up to half a cell.
//  - kDistances: the squared distance d^2 = (-sigma ln L)^2 of each cell centre to the nearest
//    surface (the window radius where L is 0), and then L = exp(-d / sigma). Near a straight
//    wall d^2 is quadratic in the position and the interpolation reproduces it exactly: the
//    kernel peaks on the wall, not on the cell grid. Same values at the cell centres.
enum class ScanCostInterpolation { kValues, kDistances };
// "values" / "distances" (the programs' --refine_interpolation flag); false for anything else.
bool ParseScanCostInterpolation(const std::string& name, ScanCostInterpolation* interpolation);

// Returns a cost over one [x, y, yaw] parameter block with N residuals. `weights` is empty
// (all 1) or one weight per point. The caller owns the returned cost function (or passes
// ownership to a ceres::Problem).
ceres::CostFunction* CreateScanToLikelihoodFieldCost(const LikelihoodField& field,
                                                     const std::vector<Eigen::Vector2f>& points_robot,
                                                     const std::vector<float>& weights = {},
                                                     ScanCostInterpolation interpolation = ScanCostInterpolation::kValues);

}  // namespace hetslam

#endif  // HETSLAM_FACTORS_SCAN_COST_H_
