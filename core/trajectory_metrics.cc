#include "core/trajectory_metrics.h"

#include <algorithm>
#include <cmath>
#include <utility>

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

}  // namespace hetslam
