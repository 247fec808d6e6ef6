// hetslam_compare: agreement of a trajectory with a REFERENCE trajectory (e.g. GMapping's
// `.gmapping.txt` for a shared log). A reference is another system's answer, not ground truth:
// the figures say how far two estimates are apart, not which one is right.
//
//   hetslam_compare --trajectory=out/aces/trajectory.txt
//                   --reference=../shared/datasets/aces/aces.gmapping.txt
//
// Poses are associated by nearest timestamp within --match_tolerance (core/trajectory_metrics.h
// for the ATE; the same rule in core/relations.h for the relative errors). Printed:
//  (a) absolute trajectory error after the rigid SE(2) alignment that best maps the trajectory
//      onto the reference (ComputeAbsoluteTrajectoryError);
//  (b) relative pose error: every pair of matched reference poses (i, j) gives a relation
//      delta = ref_i^-1 * ref_j, scored on the trajectory with the relations metric of
//      Kümmerle et al. 2009 (EvaluateRelations: |t(est) - t(delta)| in m,
//      |wrap(theta(est) - theta(delta))| in deg, mean ± sample std), for j = the next matched
//      pose, and for j = the first matched pose at least --rpe_gap seconds after i;
//  (c) the --worst_steps largest step errors (ComputePoseErrors, LargestStepErrors): where the
//      trajectory departs from the reference; --errors_out writes every pose's errors.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "core/relations.h"
#include "core/se2.h"
#include "core/trajectory_io.h"
#include "core/trajectory_metrics.h"
#include "examples/flag_help.h"
#include "gflags/gflags.h"

DEFINE_string(trajectory, "",
              "Trajectory to compare: one pose per line, `timestamp x y theta` (s, m, m, rad), '#' "
              "comments (the format hetslam_run writes). Required.");
DEFINE_string(reference, "",
              "Reference trajectory in the same format, on the same clock (e.g. a shared log's "
              "<name>.gmapping.txt: GMapping's output, a reference, not ground truth). Required.");
DEFINE_double(match_tolerance, 0.001,
              "A trajectory pose and a reference pose are associated (nearest timestamp) only when "
              "their timestamps differ by at most this many seconds (>= 0).");
DEFINE_string(errors_out, "",
              "Optional: write every matched pose's errors to this file, one line a pose in time order: the "
              "aligned position and heading errors (as the ATE aligns) and the step from the previous pose "
              "against the reference's step (its length, the error's size, its part along the step: negative "
              "= the trajectory stepped short, the heading change's error). Finds where a trajectory departs "
              "from the reference.");
DEFINE_int32(worst_steps, 5,
             "Print this many steps with the largest step errors (when, the reference's step, the error and "
             "its part along the step, the aligned error after it); 0 = none.");
DEFINE_double(rpe_gap, 10.0,
              "Second relative-pose-error set: each matched pose is paired with the first matched "
              "pose at least this many seconds later (> 0).");

namespace hetslam {
namespace {

int Fail(const std::string& message) {
  std::cerr << "hetslam_compare: " << message << "\n";
  return 1;
}

bool ValidateFlags(std::string* error) {
  if (FLAGS_trajectory.empty()) return (*error = "--trajectory is required (a `timestamp x y theta` file)"), false;
  if (FLAGS_reference.empty()) return (*error = "--reference is required (a `timestamp x y theta` file)"), false;
  if (!(FLAGS_match_tolerance >= 0.0) || !std::isfinite(FLAGS_match_tolerance)) {
    return (*error = "--match_tolerance must be a finite number >= 0 (got " + std::to_string(FLAGS_match_tolerance) +
                     ")"), false;
  }
  if (FLAGS_worst_steps < 0) {
    return (*error = "--worst_steps must be >= 0 (got " + std::to_string(FLAGS_worst_steps) + ")"), false;
  }
  if (!(FLAGS_rpe_gap > 0.0) || !std::isfinite(FLAGS_rpe_gap)) {
    return (*error = "--rpe_gap must be a finite number > 0 (got " + std::to_string(FLAGS_rpe_gap) + ")"), false;
  }
  return true;
}

std::vector<StampedPose2> SortedByTime(std::vector<StampedPose2> poses) {
  std::stable_sort(poses.begin(), poses.end(),
                   [](const StampedPose2& a, const StampedPose2& b) { return a.stamp_seconds < b.stamp_seconds; });
  return poses;
}

// True when some pose of `sorted` lies within `tolerance` seconds of `t`.
bool HasPoseNear(const std::vector<StampedPose2>& sorted, double t, double tolerance) {
  auto it = std::lower_bound(sorted.begin(), sorted.end(), t,
                             [](const StampedPose2& a, double time) { return a.stamp_seconds < time; });
  if (it != sorted.end() && it->stamp_seconds - t <= tolerance) return true;
  return it != sorted.begin() && t - (it - 1)->stamp_seconds <= tolerance;
}

Relation MakeRelation(const StampedPose2& a, const StampedPose2& b) {
  Relation relation;
  relation.t1_seconds = a.stamp_seconds;
  relation.t2_seconds = b.stamp_seconds;
  relation.delta = Between(a.pose, b.pose);
  return relation;
}

void PrintRelativeError(const std::string& label, const RelationsMetricResult& r) {
  if (r.matched == 0) {
    std::printf("%s: no pairs\n", label.c_str());
    return;
  }
  std::printf("%s (%d pairs): translation %.4f +- %.4f m (median %.4f, max %.4f), rotation %.3f +- %.3f deg "
              "(median %.3f, max %.3f)\n",
              label.c_str(), r.matched, r.trans_mean_m, r.trans_std_m, r.trans_median_m, r.trans_max_m,
              r.rot_mean_deg, r.rot_std_deg, r.rot_median_deg, r.rot_max_deg);
}

int Run() {
  std::string error;
  if (!ValidateFlags(&error)) return Fail(error + "; see --help");
  std::vector<StampedPose2> trajectory, reference;
  Status status = ReadTrajectory(FLAGS_trajectory, &trajectory);
  if (!status.ok()) return Fail(status.message());
  status = ReadTrajectory(FLAGS_reference, &reference);
  if (!status.ok()) return Fail(status.message());
  if (trajectory.empty()) return Fail("'" + FLAGS_trajectory + "' holds no pose");
  if (reference.empty()) return Fail("'" + FLAGS_reference + "' holds no pose");

  const std::vector<StampedPose2> sorted_trajectory = SortedByTime(trajectory);
  const std::vector<StampedPose2> sorted_reference = SortedByTime(reference);
  // Reference poses with a trajectory pose within the tolerance, in time order.
  std::vector<StampedPose2> matched;
  for (const StampedPose2& r : sorted_reference) {
    if (HasPoseNear(sorted_trajectory, r.stamp_seconds, FLAGS_match_tolerance)) matched.push_back(r);
  }

  std::printf("hetslam_compare: agreement with reference (not ground truth)\n");
  std::printf("trajectory: %s (%zu poses)\n", FLAGS_trajectory.c_str(), trajectory.size());
  std::printf("reference:  %s (%zu poses)\n", FLAGS_reference.c_str(), reference.size());
  std::printf("matched: %zu reference poses within %.6f s\n", matched.size(), FLAGS_match_tolerance);
  if (matched.empty()) {
    return Fail("no reference pose lies within " + std::to_string(FLAGS_match_tolerance) +
                " s of a trajectory pose: trajectory spans " + std::to_string(sorted_trajectory.front().stamp_seconds) +
                " .. " + std::to_string(sorted_trajectory.back().stamp_seconds) + " s, reference " +
                std::to_string(sorted_reference.front().stamp_seconds) + " .. " +
                std::to_string(sorted_reference.back().stamp_seconds) + " s. Same clock? Check --match_tolerance.");
  }

  const AbsoluteTrajectoryError ate = ComputeAbsoluteTrajectoryError(trajectory, reference, FLAGS_match_tolerance);
  std::printf("ATE after SE(2) alignment (%d poses): translation rmse %.4f m, mean %.4f m, max %.4f m; "
              "rotation rmse %.3f deg, max %.3f deg\n",
              ate.matched, ate.translation_rmse_meters, ate.translation_mean_meters, ate.translation_max_meters,
              ate.rotation_rmse_degrees, ate.rotation_max_degrees);

  std::vector<Relation> consecutive, gapped;
  for (size_t i = 0; i + 1 < matched.size(); ++i) consecutive.push_back(MakeRelation(matched[i], matched[i + 1]));
  for (size_t i = 0, j = 0; i < matched.size(); ++i) {
    j = std::max(j, i + 1);
    while (j < matched.size() && matched[j].stamp_seconds - matched[i].stamp_seconds < FLAGS_rpe_gap) ++j;
    if (j == matched.size()) break;
    gapped.push_back(MakeRelation(matched[i], matched[j]));
  }
  RelationsMetricOptions options;
  options.clock_offset_seconds = 0.0;
  options.match_tolerance_seconds = FLAGS_match_tolerance;
  PrintRelativeError("RPE consecutive matched poses", EvaluateRelations(trajectory, consecutive, options));
  char label[64];
  std::snprintf(label, sizeof(label), "RPE over >= %g s", FLAGS_rpe_gap);
  PrintRelativeError(label, EvaluateRelations(trajectory, gapped, options));

  if (FLAGS_worst_steps == 0 && FLAGS_errors_out.empty()) return 0;
  const std::vector<PoseError> errors = ComputePoseErrors(trajectory, reference, FLAGS_match_tolerance);
  const std::vector<size_t> worst = LargestStepErrors(errors, static_cast<size_t>(FLAGS_worst_steps));
  if (!worst.empty()) std::printf("largest step errors (from the previous matched pose):\n");
  for (const size_t i : worst) {
    const PoseError& e = errors[i];
    std::printf("  t = %.3f -> %.3f s: reference step %.3f m, error %.3f m (%+.3f m along the step), "
                "heading %+.3f deg; aligned error there %.3f m\n",
                errors[i - 1].stamp_seconds, e.stamp_seconds, e.step_reference_meters, e.step_translation_meters,
                e.step_along_meters, e.step_rotation_degrees, e.translation_meters);
  }
  if (!FLAGS_errors_out.empty()) {
    status = WritePoseErrors(FLAGS_errors_out, errors);
    if (!status.ok()) return Fail(status.message());
    std::printf("wrote %s (%zu poses)\n", FLAGS_errors_out.c_str(), errors.size());
  }
  return 0;
}

}  // namespace
}  // namespace hetslam

int main(int argc, char** argv) {
  gflags::SetUsageMessage(
      "agreement of a trajectory with a reference trajectory (not ground truth): ATE after SE(2)\n"
      "alignment and relative pose errors.\n"
      "  hetslam_compare --trajectory=FILE --reference=FILE [--match_tolerance=SECONDS] [--rpe_gap=SECONDS]\n"
      "                  [--worst_steps=N] [--errors_out=FILE]");
  hetslam::PrintProgramHelpIfAsked(argc, argv, __FILE__);
  gflags::ParseCommandLineFlags(&argc, &argv, /*remove_flags=*/true);
  if (argc > 1) {
    return hetslam::Fail(std::string("unexpected argument '") + argv[1] + "': every input is a --flag; see --help");
  }
  return hetslam::Run();
}
