#include "core/trajectory_metrics.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <utility>

#include "core/file_io.h"

namespace hetslam {
namespace {

struct MatchedPose {
  double stamp_seconds;  // the estimate's
  Pose2 estimate;
  Pose2 truth;
};

// Each estimate pose (in input order) with the truth pose nearest in time, when within the
// tolerance.
std::vector<MatchedPose> MatchPosesByStamp(const std::vector<StampedPose2>& estimate,
                                           const std::vector<StampedPose2>& truth, double match_tolerance_seconds) {
  // Truth sorted by time for nearest-stamp lookups (input order is kept elsewhere).
  std::vector<StampedPose2> sorted_truth = truth;
  std::stable_sort(sorted_truth.begin(), sorted_truth.end(),
                   [](const StampedPose2& a, const StampedPose2& b) { return a.stamp_seconds < b.stamp_seconds; });
  std::vector<MatchedPose> pairs;
  for (const StampedPose2& e : estimate) {
    auto it = std::lower_bound(sorted_truth.begin(), sorted_truth.end(), e.stamp_seconds,
                               [](const StampedPose2& a, double t) { return a.stamp_seconds < t; });
    const StampedPose2* best = nullptr;
    for (auto candidate : {it, it == sorted_truth.begin() ? it : it - 1}) {
      if (candidate == sorted_truth.end()) continue;
      if (best == nullptr || std::abs(candidate->stamp_seconds - e.stamp_seconds) <
                                 std::abs(best->stamp_seconds - e.stamp_seconds)) {
        best = &*candidate;
      }
    }
    if (best != nullptr && std::abs(best->stamp_seconds - e.stamp_seconds) <= match_tolerance_seconds) {
      pairs.push_back({e.stamp_seconds, e.pose, best->pose});
    }
  }
  return pairs;
}

// (estimate, truth) pose pairs of MatchPosesByStamp.
std::vector<std::pair<Pose2, Pose2>> MatchByStamp(const std::vector<StampedPose2>& estimate,
                                                  const std::vector<StampedPose2>& truth,
                                                  double match_tolerance_seconds) {
  std::vector<std::pair<Pose2, Pose2>> pairs;
  for (const MatchedPose& m : MatchPosesByStamp(estimate, truth, match_tolerance_seconds)) {
    pairs.emplace_back(m.estimate, m.truth);
  }
  return pairs;
}

TrajectoryAlignment AlignPairs(const std::vector<std::pair<Pose2, Pose2>>& pairs) {
  TrajectoryAlignment alignment;
  alignment.matched = static_cast<int>(pairs.size());
  if (pairs.empty()) return alignment;
  Eigen::Vector2d mean_e = Eigen::Vector2d::Zero(), mean_t = Eigen::Vector2d::Zero();
  for (const auto& [e, t] : pairs) {
    mean_e += e.translation();
    mean_t += t.translation();
  }
  mean_e /= pairs.size();
  mean_t /= pairs.size();
  double sxx = 0, sxy = 0;  // cross terms of the rotation that best maps estimate onto truth
  double truth_spread_sq = 0;
  double heading_cos = 0, heading_sin = 0;
  for (const auto& [e, t] : pairs) {
    const Eigen::Vector2d a = e.translation() - mean_e, b = t.translation() - mean_t;
    sxx += a.dot(b);
    sxy += a.x() * b.y() - a.y() * b.x();
    truth_spread_sq += b.squaredNorm();
    const double d = t.theta() - e.theta();
    heading_cos += std::cos(d);
    heading_sin += std::sin(d);
  }
  const double spread = std::sqrt(truth_spread_sq / pairs.size());
  alignment.rotation_from_headings = pairs.size() < 2 || spread < kMinAlignmentSpreadMeters;
  const double yaw = alignment.rotation_from_headings ? std::atan2(heading_sin, heading_cos)
                                                      : std::atan2(sxy, sxx);
  const Pose2 rotation(0.0, 0.0, yaw);
  alignment.truth_T_estimate = Pose2(mean_t - rotation * mean_e, yaw);
  return alignment;
}

}  // namespace

TrajectoryAlignment AlignTrajectory(const std::vector<StampedPose2>& estimate,
                                    const std::vector<StampedPose2>& truth,
                                    double match_tolerance_seconds) {
  return AlignPairs(MatchByStamp(estimate, truth, match_tolerance_seconds));
}

AbsoluteTrajectoryError ComputeAbsoluteTrajectoryError(const std::vector<StampedPose2>& estimate,
                                                       const std::vector<StampedPose2>& truth,
                                                       double match_tolerance_seconds) {
  AbsoluteTrajectoryError ate;
  const std::vector<std::pair<Pose2, Pose2>> pairs =
      MatchByStamp(estimate, truth, match_tolerance_seconds);
  ate.matched = static_cast<int>(pairs.size());
  if (pairs.empty()) return ate;
  ate.truth_T_estimate = AlignPairs(pairs).truth_T_estimate;

  double sum_sq_t = 0, sum_t = 0, sum_sq_r = 0;
  for (const auto& [e, t] : pairs) {
    const Pose2 aligned = ate.truth_T_estimate * e;
    const double dt = (aligned.translation() - t.translation()).norm();
    const double dr = std::abs(WrapAngle(aligned.theta() - t.theta())) * 180.0 / M_PI;
    sum_sq_t += dt * dt;
    sum_t += dt;
    sum_sq_r += dr * dr;
    ate.translation_max_meters = std::max(ate.translation_max_meters, dt);
    ate.rotation_max_degrees = std::max(ate.rotation_max_degrees, dr);
  }
  ate.translation_rmse_meters = std::sqrt(sum_sq_t / pairs.size());
  ate.translation_mean_meters = sum_t / pairs.size();
  ate.rotation_rmse_degrees = std::sqrt(sum_sq_r / pairs.size());
  return ate;
}

StartFrameDrift ComputeStartFrameDrift(const std::vector<StampedPose2>& estimate,
                                       const std::vector<StampedPose2>& truth, double match_tolerance_seconds) {
  StartFrameDrift drift;
  std::vector<MatchedPose> pairs = MatchPosesByStamp(estimate, truth, match_tolerance_seconds);
  drift.matched = static_cast<int>(pairs.size());
  if (pairs.empty()) return drift;
  std::stable_sort(pairs.begin(), pairs.end(),
                   [](const MatchedPose& a, const MatchedPose& b) { return a.stamp_seconds < b.stamp_seconds; });
  const Pose2 estimate_start_inverse = pairs.front().estimate.inverse();
  const Pose2 truth_start_inverse = pairs.front().truth.inverse();
  for (const MatchedPose& m : pairs) {
    const Pose2 e = estimate_start_inverse * m.estimate;
    const Pose2 t = truth_start_inverse * m.truth;
    const double translation = (e.translation() - t.translation()).norm();
    const double rotation = WrapAngle(e.theta() - t.theta()) * 180.0 / M_PI;
    if (translation > drift.max_translation_meters) {
      drift.max_translation_meters = translation;
      drift.max_translation_stamp_seconds = m.stamp_seconds;
    }
    if (std::abs(rotation) > drift.max_rotation_degrees) {
      drift.max_rotation_degrees = std::abs(rotation);
      drift.max_rotation_stamp_seconds = m.stamp_seconds;
    }
    drift.final_translation_meters = translation;
    drift.final_rotation_degrees = rotation;
  }
  return drift;
}

std::vector<PoseError> ComputePoseErrors(const std::vector<StampedPose2>& estimate,
                                         const std::vector<StampedPose2>& truth, double match_tolerance_seconds) {
  std::vector<MatchedPose> pairs = MatchPosesByStamp(estimate, truth, match_tolerance_seconds);
  std::vector<PoseError> errors;
  if (pairs.empty()) return errors;
  std::vector<std::pair<Pose2, Pose2>> aligned_pairs;
  aligned_pairs.reserve(pairs.size());
  for (const MatchedPose& m : pairs) aligned_pairs.emplace_back(m.estimate, m.truth);
  const Pose2 truth_T_estimate = AlignPairs(aligned_pairs).truth_T_estimate;
  std::stable_sort(pairs.begin(), pairs.end(),
                   [](const MatchedPose& a, const MatchedPose& b) { return a.stamp_seconds < b.stamp_seconds; });
  errors.reserve(pairs.size());
  for (size_t i = 0; i < pairs.size(); ++i) {
    const MatchedPose& m = pairs[i];
    PoseError error;
    error.stamp_seconds = m.stamp_seconds;
    const Pose2 aligned = truth_T_estimate * m.estimate;
    error.translation_meters = (aligned.translation() - m.truth.translation()).norm();
    error.rotation_degrees = WrapAngle(aligned.theta() - m.truth.theta()) * 180.0 / M_PI;
    if (i > 0) {
      const Pose2 step_estimate = Between(pairs[i - 1].estimate, m.estimate);
      const Pose2 step_truth = Between(pairs[i - 1].truth, m.truth);
      const Eigen::Vector2d difference = step_estimate.translation() - step_truth.translation();
      error.has_step = true;
      error.step_reference_meters = step_truth.translation().norm();
      error.step_translation_meters = difference.norm();
      error.step_along_meters = error.step_reference_meters > 0.0
                                    ? difference.dot(step_truth.translation()) / error.step_reference_meters
                                    : 0.0;
      error.step_rotation_degrees = WrapAngle(step_estimate.theta() - step_truth.theta()) * 180.0 / M_PI;
    }
    errors.push_back(error);
  }
  return errors;
}

std::vector<size_t> LargestStepErrors(const std::vector<PoseError>& errors, size_t count) {
  std::vector<size_t> steps;
  for (size_t i = 0; i < errors.size(); ++i) {
    if (errors[i].has_step) steps.push_back(i);
  }
  std::stable_sort(steps.begin(), steps.end(), [&errors](size_t a, size_t b) {
    return errors[a].step_translation_meters > errors[b].step_translation_meters;
  });
  if (steps.size() > count) steps.resize(count);
  return steps;
}

Status WritePoseErrors(const std::string& path, const std::vector<PoseError>& errors) {
  std::FILE* file = nullptr;
  HETSLAM_RETURN_IF_ERROR(OpenForWriting(path, "w", &file));
  std::fprintf(file,
               "# stamp translation_m rotation_deg step_reference_m step_translation_m step_along_m "
               "step_rotation_deg has_step\n"
               "# translation and rotation after the SE(2) alignment (the ATE's), estimate minus reference; the\n"
               "# step from the previous line's pose: the reference's length, the estimate's step minus the\n"
               "# reference's (its size, and its part along the reference's step: negative = short), the\n"
               "# heading's change minus the reference's; has_step is 0 on the first line (no step)\n");
  for (const PoseError& e : errors) {
    std::fprintf(file, "%.6f %.6f %.4f %.6f %.6f %.6f %.4f %d\n", e.stamp_seconds, e.translation_meters,
                 e.rotation_degrees, e.step_reference_meters, e.step_translation_meters, e.step_along_meters,
                 e.step_rotation_degrees, e.has_step ? 1 : 0);
  }
  return CommitWrittenFile(file, path);
}

}  // namespace hetslam
