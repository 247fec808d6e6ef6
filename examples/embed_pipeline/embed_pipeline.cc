// The whole single-robot pipeline from an INSTALLED hetslam, the way an embedder calls it:
// read a log (CARMEN or hetslam robot log) into a measurement stream, feed the online estimator
// one measurement at a time, print the trajectory. With a truth file (`t x y theta` per line)
// it also reports the trajectory error and fails above a bound (a CI check of the package).
//
//   embed_pipeline LOG [TRUTH [MAX_ATE_METERS]]
#include <cstdio>
#include <cstdlib>

#include "core/measurement_log.h"
#include "core/trajectory_io.h"
#include "core/trajectory_metrics.h"
#include "frontends/online_estimator.h"

int main(int argc, char** argv) {
  if (argc < 2 || argc > 4) {
    std::fprintf(stderr, "usage: %s LOG [TRUTH [MAX_ATE_METERS]]\n", argv[0]);
    return 2;
  }
  hetslam::MeasurementLog log;
  const hetslam::Status read = hetslam::ReadMeasurementLog(argv[1], hetslam::MeasurementLogOptions(), &log);
  if (!read.ok()) return std::fprintf(stderr, "%s\n", read.message().c_str()), 1;

  hetslam::OnlineEstimator estimator{hetslam::OnlineEstimatorOptions()};
  for (const hetslam::Measurement& measurement : log.measurements) {
    const hetslam::Status status = estimator.Add(measurement);  // bad data: an error, never an abort
    if (!status.ok()) std::fprintf(stderr, "skipped: %s\n", status.message().c_str());
  }
  estimator.Finish();
  const std::vector<hetslam::StampedPose2> trajectory = estimator.Trajectory();
  std::printf("%zu poses, %d submaps, %d loop closures; last pose %.3f %.3f %.3f\n", trajectory.size(),
              estimator.graph().stats().submaps, estimator.graph().stats().loop_closures_accepted,
              trajectory.empty() ? 0.0 : trajectory.back().pose.x(), trajectory.empty() ? 0.0 : trajectory.back().pose.y(),
              trajectory.empty() ? 0.0 : trajectory.back().pose.theta());

  std::vector<hetslam::StampedPose2> truth = log.truth;
  if (argc >= 3) {
    const hetslam::Status status = hetslam::ReadTrajectory(argv[2], &truth);
    if (!status.ok()) return std::fprintf(stderr, "%s\n", status.message().c_str()), 1;
  }
  if (truth.empty()) return trajectory.empty() ? 1 : 0;
  const hetslam::AbsoluteTrajectoryError ate = hetslam::ComputeAbsoluteTrajectoryError(trajectory, truth);
  std::printf("ATE rmse %.3f m over %d poses\n", ate.translation_rmse_meters, ate.matched);
  const double bound = argc == 4 ? std::atof(argv[3]) : 0.2;
  return ate.matched > 0 && ate.translation_rmse_meters <= bound ? 0 : 1;
}
