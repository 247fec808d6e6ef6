// hetslam_layers: scores a run's map layers against the true layers of a simulated dataset
// (per-layer cell precision and recall with a one-cell tolerance; core/map_layers.h).
//
//   hetslam_sim --scenario=datasets/scenarios/humanoid_explore.scenario --out=/tmp/explore
//   hetslam_run --log=/tmp/explore/nao/log.txt --out=/tmp/run
//   hetslam_layers --run_dir=/tmp/run --truth_layers=/tmp/explore/truth_layers
//                  --truth=/tmp/explore/nao/log.txt [--out_csv=/tmp/run/layers.csv]
//
// The run's maps are in its map frame (the robot's start pose); they are brought into the
// world by the SE(2) transform that best maps the run's trajectory onto the truth (the ATE
// alignment, core/trajectory_metrics.h).
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include "core/map_layers.h"
#include "core/measurement_log.h"
#include "core/trajectory_io.h"
#include "core/trajectory_metrics.h"
#include "examples/flag_help.h"
#include "gflags/gflags.h"
#include "glog/logging.h"

DEFINE_string(run_dir, "",
              "The run's output folder (hetslam_run --out). Its map layers are scored when "
              "present, each as X.pgm + X.yaml (map_server): map (all structure used for "
              "localisation; scored against walls + furniture), walls (against walls), "
              "floor_obstacles (against floor_obstacles), planner (against all three true "
              "layers). Also counts map.pgm's cells on a true floor obstacle (not next to walls or "
              "furniture): the localisation map should hold none. Required.");
DEFINE_string(truth_layers, "",
              "Folder of the true layers, world frame: a simulated team dataset's "
              "DIR/truth_layers (walls, furniture, floor_obstacles .pgm + .yaml). Required.");
DEFINE_string(seen_layers, "",
              "Optional folder of the robot's seen layers (a simulated team dataset's "
              "DIR/<robot>/seen_layers: the true layers restricted to the cells its laser "
              "returned from). Adds the recall against them: what could be mapped from that "
              "log. Default: none.");
DEFINE_string(trajectory, "",
              "The run's trajectory, `timestamp x y theta` per line in its map frame; aligned to "
              "--truth to place the maps in the world. Default: <run_dir>/trajectory.txt.");
DEFINE_string(truth, "",
              "Ground truth of the same robot: its hetslam robot log (TRUTH lines, e.g. "
              "DIR/nao/log.txt) or a `timestamp x y theta` file (e.g. truth.txt). Required.");
DEFINE_double(match_tolerance, 1e-3,
              "A trajectory pose is paired with the truth pose nearest in time only within this "
              "many seconds (>= 0), as for the ATE of hetslam_run.");
DEFINE_int32(tolerance_cells, 1,
              "A run cell counts as correct when an occupied true cell lies within this many "
              "cells (in x and in y) of where it falls, and a true cell as found likewise; in "
              "[0, 100].");
DEFINE_string(out_csv, "",
              "Optional CSV file receiving one row per run layer (absent ones too): layer, truth, "
              "status, precision, recall, run_occupied, run_correct, truth_occupied, truth_found, "
              "tolerance_cells, seen_recall, seen_occupied, seen_found (the last three empty "
              "without --seen_layers); then, with map.pgm and a true floor_obstacles layer, a row "
              "map_on_floor_obstacles whose run_occupied and run_correct columns are map.pgm's "
              "occupied cells and those on a true floor obstacle.");

namespace hetslam {
namespace {

int Fail(const std::string& message) {
  std::cerr << "hetslam_layers: " << message << "\n";
  return 1;
}

bool OptionsFromFlags(LayerScoreOptions* options, std::string* error) {
  if (FLAGS_run_dir.empty()) {
    *error = "--run_dir is required (a hetslam_run output folder)";
  } else if (FLAGS_truth_layers.empty()) {
    *error = "--truth_layers is required (a dataset's truth_layers folder)";
  } else if (FLAGS_truth.empty()) {
    *error = "--truth is required (a robot log with TRUTH lines or a truth.txt file)";
  } else if (!(FLAGS_match_tolerance >= 0.0) || !std::isfinite(FLAGS_match_tolerance)) {
    *error = "--match_tolerance must be finite and >= 0, got " + std::to_string(FLAGS_match_tolerance);
  } else {
    options->tolerance_cells = FLAGS_tolerance_cells;
    std::string invalid;
    if (options->IsValid(&invalid)) return true;
    *error = "bad --tolerance_cells: " + invalid;
  }
  return false;
}

int Run() {
  LayerScoreOptions options;
  std::string error;
  if (!OptionsFromFlags(&options, &error)) return Fail(error + "; see --help");
  const std::string trajectory_path =
      FLAGS_trajectory.empty() ? (std::filesystem::path(FLAGS_run_dir) / "trajectory.txt").string()
                               : FLAGS_trajectory;
  std::vector<StampedPose2> trajectory, truth;
  Status status = ReadTrajectory(trajectory_path, &trajectory);
  if (!status.ok()) return Fail(status.message());
  status = ReadTruthTrajectory(FLAGS_truth, &truth);
  if (!status.ok()) return Fail(status.message());
  const TrajectoryAlignment alignment =
      AlignTrajectory(trajectory, truth, FLAGS_match_tolerance);
  if (alignment.matched == 0) {
    return Fail("no pose of '" + trajectory_path + "' has a truth pose of '" + FLAGS_truth +
                "' within " + std::to_string(FLAGS_match_tolerance) +
                " s: is it the same robot? (--match_tolerance)");
  }

  RunLayersReport report;
  status = ScoreRunLayers(FLAGS_run_dir, FLAGS_truth_layers, alignment.truth_T_estimate, options,
                          &report, FLAGS_seen_layers);
  if (!status.ok()) return Fail(status.message());

  const Pose2& w = alignment.truth_T_estimate;
  std::printf("hetslam_layers: %s against %s\n", FLAGS_run_dir.c_str(), FLAGS_truth_layers.c_str());
  std::printf("alignment world_T_map: x %.3f m, y %.3f m, yaw %.2f deg from %d of %zu trajectory "
              "poses%s\n",
              w.x(), w.y(), w.theta() * 180.0 / M_PI, alignment.matched, trajectory.size(),
              alignment.rotation_from_headings ? " (rotation from the headings: the robot hardly "
                                                 "moved)"
                                               : "");
  const AbsoluteTrajectoryError ate =
      ComputeAbsoluteTrajectoryError(trajectory, truth, FLAGS_match_tolerance);
  std::printf("trajectory after alignment: ATE rmse %.3f m, max %.3f m\n",
              ate.translation_rmse_meters, ate.translation_max_meters);
  // Over about five 5 cm cells of trajectory error the maps cannot score well within a cell;
  // say why before the table does.
  if (ate.translation_rmse_meters > 0.25) {
    std::printf("warning: a large trajectory error: the run drifted, or --truth is another "
                "robot's\n");
  }
  std::printf("tolerance %d cell(s)\n\n%s", options.tolerance_cells,
              FormatRunLayersTable(report).c_str());
  std::string absent;
  for (const RunLayerResult& layer : report.layers) {
    if (!layer.present) absent += (absent.empty() ? "" : ", ") + layer.spec.run_stem + ".pgm";
  }
  if (!absent.empty()) std::printf("\nabsent from %s: %s\n", FLAGS_run_dir.c_str(), absent.c_str());
  if (!FLAGS_out_csv.empty()) {
    status = WriteRunLayersCsv(report, FLAGS_out_csv);
    if (!status.ok()) return Fail(status.message());
    std::printf("wrote %s\n", FLAGS_out_csv.c_str());
  }
  return 0;
}

}  // namespace
}  // namespace hetslam

int main(int argc, char** argv) {
  gflags::SetUsageMessage(
      "score a run's map layers against the true layers of a simulated dataset\n"
      "  hetslam_layers --run_dir=OUT --truth_layers=DIR/truth_layers --truth=DIR/ROBOT/log.txt\n"
      "                 [--trajectory=OUT/trajectory.txt] [--out_csv=FILE]\n"
      "per layer: cell precision (run cells with a true cell within --tolerance_cells) and\n"
      "recall (true cells with a run cell within it), after aligning the run's trajectory to\n"
      "the truth; map.pgm vs walls+furniture, walls.pgm vs walls, floor_obstacles.pgm vs\n"
      "floor_obstacles, planner.pgm vs all three (core/map_layers.h)");
  hetslam::PrintProgramHelpIfAsked(argc, argv, __FILE__);
  gflags::ParseCommandLineFlags(&argc, &argv, true);
  google::InitGoogleLogging(argv[0]);
  return hetslam::Run();
}
