// Absolute trajectory error (ATE) of an estimated 2D trajectory against ground truth.
//
// Poses are associated by nearest timestamp within `match_tolerance_seconds`. The estimate
// is aligned to the truth by the rigid SE(2) transform that minimises the summed squared
// position error (closed form: centroids, then the rotation from the 2x2 cross-covariance),
// then per-pose translational and rotational errors are reported.
#ifndef HETSLAM_CORE_TRAJECTORY_METRICS_H_
#define HETSLAM_CORE_TRAJECTORY_METRICS_H_

#include <vector>

#include "core/se2.h"
#include "core/trajectory_io.h"

namespace hetslam {

struct AbsoluteTrajectoryError {
  int matched = 0;
  Pose2 truth_T_estimate;          // the alignment applied to the estimate
  double translation_rmse_meters = 0.0;
  double translation_mean_meters = 0.0;
  double translation_max_meters = 0.0;
  double rotation_rmse_degrees = 0.0;
  double rotation_max_degrees = 0.0;
};

AbsoluteTrajectoryError ComputeAbsoluteTrajectoryError(const std::vector<StampedPose2>& estimate,
                                                       const std::vector<StampedPose2>& truth,
                                                       double match_tolerance_seconds = 1e-3);

}  // namespace hetslam

#endif  // HETSLAM_CORE_TRAJECTORY_METRICS_H_
