// Absolute trajectory error (ATE) of an estimated 2D trajectory against ground truth.
//
// Poses are associated by nearest timestamp within `match_tolerance_seconds`. The estimate
// is aligned to the truth by the rigid SE(2) transform that minimises the summed squared
// position error (closed form: centroids, then the rotation from the 2x2 cross-covariance),
// then per-pose translational and rotational errors are reported.
#ifndef HETSLAM_CORE_TRAJECTORY_METRICS_H_
#define HETSLAM_CORE_TRAJECTORY_METRICS_H_

#include <string>
#include <vector>

#include "core/se2.h"
#include "core/status.h"
#include "core/trajectory_io.h"

namespace hetslam {

// The alignment of an estimate (in its own frame, e.g. a robot's start frame) to the truth.
struct TrajectoryAlignment {
  int matched = 0;        // pose pairs found; 0: no alignment (truth_T_estimate is identity)
  Pose2 truth_T_estimate;  // maps estimate-frame points (trajectory, map) into the truth frame
  // True when the rotation came from the headings instead of the positions: a single pair, or
  // truth positions within kMinAlignmentSpreadMeters (RMS) of their centroid (a robot that
  // stood still), where the positions do not fix a rotation.
  bool rotation_from_headings = false;
};

// Below this RMS distance of the matched truth positions from their centroid the alignment
// takes its rotation from the headings (see TrajectoryAlignment).
constexpr double kMinAlignmentSpreadMeters = 0.1;

// The rigid SE(2) transform truth_T_estimate that minimises sum |truth_T_estimate * e_i - t_i|²
// over the position pairs (e_i, t_i) matched by nearest stamp within match_tolerance_seconds:
// t = mean_t - R mean_e, R from the 2x2 cross-covariance of the centred positions. When the
// positions cannot fix the rotation (see TrajectoryAlignment) the rotation is the circular
// mean of the heading differences theta_t - theta_e instead. The alignment ATE uses.
TrajectoryAlignment AlignTrajectory(const std::vector<StampedPose2>& estimate,
                                    const std::vector<StampedPose2>& truth,
                                    double match_tolerance_seconds = 1e-3);

struct AbsoluteTrajectoryError {
  int matched = 0;
  Pose2 truth_T_estimate;          // the alignment applied to the estimate (AlignTrajectory)
  double translation_rmse_meters = 0.0;
  double translation_mean_meters = 0.0;
  double translation_max_meters = 0.0;
  double rotation_rmse_degrees = 0.0;
  double rotation_max_degrees = 0.0;
};

AbsoluteTrajectoryError ComputeAbsoluteTrajectoryError(const std::vector<StampedPose2>& estimate,
                                                       const std::vector<StampedPose2>& truth,
                                                       double match_tolerance_seconds = 1e-3);

// Drift from the start frame: the estimate and the truth each expressed in the frame of its own
// first matched pose, with no alignment. A robot's map frame is its first pose, so this is the
// error a team's relative pose between two robot frames inherits from each robot (issue #14):
// a heading error the robot picked up early turns its whole map, which the ATE's alignment
// hides. Poses are matched by nearest stamp as for the ATE; the first matched pose in time is
// the start (its error is 0).
struct StartFrameDrift {
  int matched = 0;
  // At the last matched pose in time.
  double final_translation_meters = 0.0;
  double final_rotation_degrees = 0.0;  // signed: estimate heading minus true heading
  // The largest over the matched poses, and when.
  double max_translation_meters = 0.0;
  double max_translation_stamp_seconds = 0.0;
  double max_rotation_degrees = 0.0;  // absolute
  double max_rotation_stamp_seconds = 0.0;
};

StartFrameDrift ComputeStartFrameDrift(const std::vector<StampedPose2>& estimate,
                                       const std::vector<StampedPose2>& truth,
                                       double match_tolerance_seconds = 1e-3);

// One matched pose's errors against a reference or the truth (ComputePoseErrors): where a
// trajectory departs from it, pose by pose, which the ATE's summary hides (a single short step
// along a corridor, and everything after it shifted).
struct PoseError {
  double stamp_seconds = 0.0;  // the estimate's
  // After the ATE's alignment (AlignTrajectory of the whole trajectory): the position's distance
  // (m) and the heading, estimate minus reference (degrees, signed).
  double translation_meters = 0.0;
  double rotation_degrees = 0.0;
  // The step from the previous matched pose in time (none for the first): the reference's
  // length (m), and the estimate's relative motion against the reference's as the relations
  // metric scores it (core/relations.h): |t_est - t_ref| (m) of the two steps, each in its
  // own start pose's frame, and wrap(theta_est - theta_ref) (degrees, signed). A step's
  // `step_along_meters` is the part of t_est - t_ref along the reference's step: negative when
  // the estimate stepped short of it.
  bool has_step = false;
  double step_reference_meters = 0.0;
  double step_translation_meters = 0.0;
  double step_along_meters = 0.0;
  double step_rotation_degrees = 0.0;
};

// Every pose of `estimate` matched to `truth` as for the ATE (nearest stamp within the
// tolerance), in time order, with its aligned errors and its step's errors. Empty when no pose
// matches.
std::vector<PoseError> ComputePoseErrors(const std::vector<StampedPose2>& estimate,
                                         const std::vector<StampedPose2>& truth,
                                         double match_tolerance_seconds = 1e-3);

// The indices of the `count` steps of `errors` with the largest step_translation_meters (ties
// by time), largest first: where to look first.
std::vector<size_t> LargestStepErrors(const std::vector<PoseError>& errors, size_t count);

// Writes `errors` as a table: '#' lines naming and explaining the columns, then one line a pose,
// `stamp translation_m rotation_deg step_reference_m step_translation_m step_along_m
// step_rotation_deg has_step` (the step columns 0 and has_step 0 where there is no step: the
// first pose). An error names the file.
Status WritePoseErrors(const std::string& path, const std::vector<PoseError>& errors);

}  // namespace hetslam

#endif  // HETSLAM_CORE_TRAJECTORY_METRICS_H_
