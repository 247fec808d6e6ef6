// hetslam_eval: scores a trajectory against ground-truth relations with the metric of
// Kümmerle et al. 2009 ("On measuring the accuracy of SLAM algorithms"); see core/relations.h.
//
//   hetslam_eval --trajectory=out/intel/trajectory.txt
//                --relations=../shared/datasets/intel/intel.relations
//                --clock_offset=976052857.337284 --match_tolerance=0.006
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "core/carmen_log.h"
#include "core/file_io.h"
#include "core/relations.h"
#include "core/trajectory_io.h"
#include "examples/flag_help.h"
#include "gflags/gflags.h"

DEFINE_string(trajectory, "",
              "Estimated trajectory to score: one pose per line, `timestamp x y theta` (s, m, m, "
              "rad), '#' comments (the format hetslam_run writes). Required.");
DEFINE_string(relations, "",
              "Ground-truth relations: `t1 t2 x y z roll pitch yaw` per line, the pose at t2 in the "
              "frame of the pose at t1 (e.g. intel.relations). Required.");
DEFINE_double(clock_offset, 0.0,
              "Relation clock minus trajectory clock, in seconds: a relation time t is matched to "
              "trajectory time t - clock_offset. Intel: 976052857.337284.");
DEFINE_double(match_tolerance, 0.006,
              "A relation end matches the trajectory pose nearest in time only within this many "
              "seconds (>= 0); relations with an unmatched end, or with an ambiguous end (core/relations.h), are not scored.");
DEFINE_string(readings_log, "",
              "Optional CARMEN log whose ODOM lines are every reading of the original recording "
              "(stamps in the trajectory clock; the shared logs keep them all). Turns on exact "
              "association: a relation end falls on a trajectory pose only when the reading nearest "
              "to it is that pose's own reading, not a neighbouring reading the log printed with a "
              "nearby or the same stamp (see core/relations.h). Default: nearest-pose association.");
DEFINE_string(errors_out, "",
              "Optional file receiving one line per scored relation: `t1 t2 trans_error_m "
              "rot_error_deg`.");

namespace hetslam {
namespace {

int Fail(const std::string& message) {
  std::cerr << "hetslam_eval: " << message << "\n";
  return 1;
}

bool OptionsFromFlags(RelationsMetricOptions* options, std::string* error) {
  if (FLAGS_trajectory.empty()) {
    *error = "--trajectory is required (a `timestamp x y theta` file)";
    return false;
  }
  if (FLAGS_relations.empty()) {
    *error = "--relations is required (a `t1 t2 x y z roll pitch yaw` file)";
    return false;
  }
  options->clock_offset_seconds = FLAGS_clock_offset;
  options->match_tolerance_seconds = FLAGS_match_tolerance;
  std::string invalid;
  if (!options->IsValid(&invalid)) {
    while (!invalid.empty() && (invalid.back() == ' ' || invalid.back() == ';')) invalid.pop_back();
    *error = "bad flag value: " + invalid + " (flags --clock_offset, --match_tolerance)";
    return false;
  }
  return true;
}

int Run() {
  RelationsMetricOptions options;
  std::string error;
  if (!OptionsFromFlags(&options, &error)) return Fail(error + "; see --help");

  std::vector<StampedPose2> trajectory;
  TrajectoryStampReport stamps;
  Status status = ReadTrajectoryChecked(FLAGS_trajectory, &trajectory, &stamps);
  if (!status.ok()) return Fail(status.message());
  // Stamp disorder changes which poses are nearest matches: said before any figure.
  for (const std::string& warning : stamps.warnings) std::cerr << "warning: " << warning << "\n";
  if (stamps.duplicate_rows_dropped > 0) {
    std::cerr << "warning: " << stamps.duplicate_rows_dropped << " rows of '" << FLAGS_trajectory
              << "' repeat the row before them exactly and were dropped\n";
  }
  if (stamps.repeated_stamps > 0 || stamps.stamps_backwards > 0) {
    std::cerr << "warning: '" << FLAGS_trajectory << "' has " << stamps.repeated_stamps
              << " repeated stamps with another pose and " << stamps.stamps_backwards
              << " stamps going backwards: relation ends near them may match the wrong pose or be "
                 "counted ambiguous\n";
  }
  std::vector<Relation> relations;
  status = ReadRelations(FLAGS_relations, &relations);
  if (!status.ok()) return Fail(status.message());
  if (trajectory.empty()) return Fail("'" + FLAGS_trajectory + "' holds no pose");
  if (!FLAGS_readings_log.empty()) {
    CarmenLog log;
    status = ReadCarmenLog(FLAGS_readings_log, CarmenReadOptions(), &log);
    if (!status.ok()) return Fail(status.message());
    if (log.odometry.empty()) return Fail("--readings_log '" + FLAGS_readings_log + "' holds no ODOM line");
    for (const OdometryReading& odometry : log.odometry) {
      options.readings.push_back({odometry.stamp_seconds, odometry.pose});
    }
  }
  if (relations.empty()) return Fail("'" + FLAGS_relations + "' holds no relation");

  const RelationsMetricResult result = EvaluateRelations(trajectory, relations, options);
  std::printf("trajectory: %s (%zu poses)\n", FLAGS_trajectory.c_str(), trajectory.size());
  std::printf("relations:  %s (%zu relations)\n", FLAGS_relations.c_str(), relations.size());
  std::printf("clock offset %.6f s, match tolerance %.6f s\n", options.clock_offset_seconds,
              options.match_tolerance_seconds);
  if (!options.readings.empty()) {
    std::printf("exact association through %zu readings of %s\n", options.readings.size(),
                FLAGS_readings_log.c_str());
  }
  std::printf("matched: %d / %d relations\n", result.matched, result.total);
  if (stamps.duplicate_rows_dropped + stamps.repeated_stamps + stamps.stamps_backwards > 0) {
    std::printf("trajectory stamps: %d exact duplicate rows dropped, %d repeated stamps, %d backwards\n",
                stamps.duplicate_rows_dropped, stamps.repeated_stamps, stamps.stamps_backwards);
  }
  if (result.on_other_reading > 0) {
    std::printf("not scored: %d relations with an end whose nearest reading is not a trajectory pose\n",
                result.on_other_reading);
  }
  if (result.ambiguous > 0) {
    std::printf("not scored: %d relations with an ambiguous end (a pose that is the nearest match "
                "of two different relation time stamps, or a reading printed with the stamp of a reading "
                "of another pose; see core/relations.h)\n", result.ambiguous);
  }
  if (result.matched == 0) {
    auto [min_pose, max_pose] = std::minmax_element(
        trajectory.begin(), trajectory.end(),
        [](const StampedPose2& a, const StampedPose2& b) { return a.stamp_seconds < b.stamp_seconds; });
    double min_rel = relations[0].t1_seconds, max_rel = relations[0].t1_seconds;
    for (const Relation& r : relations) {
      min_rel = std::min({min_rel, r.t1_seconds, r.t2_seconds});
      max_rel = std::max({max_rel, r.t1_seconds, r.t2_seconds});
    }
    return Fail("no relation has both ends within the tolerance of a trajectory pose. Trajectory "
                "times span " + std::to_string(min_pose->stamp_seconds) + " .. " +
                std::to_string(max_pose->stamp_seconds) + " s; relation times minus the offset "
                "span " + std::to_string(min_rel - options.clock_offset_seconds) + " .. " +
                std::to_string(max_rel - options.clock_offset_seconds) +
                " s. Check --clock_offset.");
  }
  std::printf("mean +- std (sample std, N - 1), median, max over the matched relations:\n");
  std::printf("  translation error:   %.4f +- %.4f m      (median %.4f, max %.4f)\n",
              result.trans_mean_m, result.trans_std_m, result.trans_median_m, result.trans_max_m);
  std::printf("  rotation error:      %.3f +- %.3f deg     (median %.3f, max %.3f)\n",
              result.rot_mean_deg, result.rot_std_deg, result.rot_median_deg, result.rot_max_deg);
  std::printf("  squared translation: %.5f +- %.5f m^2\n", result.trans_sq_mean_m2,
              result.trans_sq_std_m2);
  std::printf("  squared rotation:    %.3f +- %.3f deg^2\n", result.rot_sq_mean_deg2,
              result.rot_sq_std_deg2);

  if (!FLAGS_errors_out.empty()) {
    FILE* file = nullptr;
    const Status opened = OpenForWriting(FLAGS_errors_out, "w", &file);
    if (!opened.ok()) return Fail(opened.message());
    std::fprintf(file, "# t1 t2 trans_error_m rot_error_deg\n");
    for (const RelationError& e : result.errors) {
      const Relation& r = relations[e.relation_index];
      std::fprintf(file, "%.6f %.6f %.9f %.9f\n", r.t1_seconds, r.t2_seconds, e.trans_error_m,
                   e.rot_error_deg);
    }
    const Status written = CommitWrittenFile(file, FLAGS_errors_out);
    if (!written.ok()) return Fail(written.message());
    std::printf("per-relation errors written to %s\n", FLAGS_errors_out.c_str());
  }
  return 0;
}

}  // namespace
}  // namespace hetslam

int main(int argc, char** argv) {
  gflags::SetUsageMessage(
      "scores a trajectory against ground-truth relations (Kümmerle et al. 2009).\n"
      "  hetslam_eval --trajectory=FILE --relations=FILE [--clock_offset=SECONDS] "
      "[--match_tolerance=SECONDS] [--readings_log=FILE] [--errors_out=FILE]");
  hetslam::PrintProgramHelpIfAsked(argc, argv, __FILE__);
  gflags::ParseCommandLineFlags(&argc, &argv, /*remove_flags=*/true);
  if (argc > 1) {
    return hetslam::Fail(std::string("unexpected argument '") + argv[1] +
                         "': every input is a --flag; see --help");
  }
  return hetslam::Run();
}
