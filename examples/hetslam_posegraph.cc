// hetslam_posegraph: optimise a 2D g2o pose graph (VERTEX_SE2 / EDGE_SE2 / FIX) with the
// hetslam factor library and write the optimised graph.
//
//   hetslam_posegraph --g2o=in.g2o --out=out.g2o
//   hetslam_posegraph --g2o=in.g2o --out=out.g2o --robust_loss=huber --linear_solver=sparse_schur
//
// It can also write a seeded synthetic Manhattan-world graph (core/synthetic_pose_graph.h) and
// its ground truth, to have a standard-style benchmark graph with a known answer:
//   hetslam_posegraph --generate_manhattan=m3500.g2o --generate_truth_out=m3500_truth.g2o
//   hetslam_posegraph --g2o=m3500.g2o --out=m3500_opt.g2o --truth=m3500_truth.g2o
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <string>
#include <unordered_map>

#include "ceres/types.h"
#include "core/g2o_io.h"
#include "core/synthetic_pose_graph.h"
#include "examples/flag_help.h"
#include "factors/pose_graph_2d.h"
#include "gflags/gflags.h"
#include "glog/logging.h"

DEFINE_string(g2o, "", "Input 2D g2o pose graph (VERTEX_SE2, EDGE_SE2 with upper-triangular information, "
              "FIX). Required unless only --generate_manhattan is given.");
DEFINE_string(out, "", "Output g2o file: the input graph with optimised vertex poses. Required with --g2o.");
DEFINE_int32(max_iterations, 100, "Maximum number of Levenberg-Marquardt iterations (>= 1).");
DEFINE_string(linear_solver, "sparse_normal_cholesky",
              "Ceres linear solver: sparse_normal_cholesky, dense_qr, dense_normal_cholesky, sparse_schur, "
              "iterative_schur or cgnr.");
DEFINE_string(sparse_library, "suite_sparse",
              "Sparse linear algebra library for the sparse solvers: suite_sparse, eigen_sparse or cx_sparse.");
DEFINE_string(robust_loss, "none",
              "Robust loss on loop-closure edges (g2o files name no edge kinds: the reader takes edges whose "
              "vertex ids differ by more than 1 as loop closures; sequential edges never get a loss): none or "
              "huber.");
DEFINE_double(robust_loss_scale, 1.0, "Scale of --robust_loss in standard deviations of the whitened residual (> 0).");
DEFINE_double(function_tolerance, 1e-8, "Ceres relative cost-change tolerance for convergence (> 0).");
DEFINE_bool(progress, false, "Print Ceres' per-iteration table.");
DEFINE_bool(full_report, false, "Print Ceres' full solver report.");
DEFINE_string(truth, "", "Optional g2o file whose VERTEX_SE2 poses are the ground truth (same ids): prints the "
              "RMS and maximum position/heading error of the input and of the result.");
DEFINE_string(generate_manhattan, "", "Write a seeded synthetic Manhattan-world graph (noisy odometry and loop "
              "closures, dead-reckoned initial poses) to this g2o file, then continue (or stop if no --g2o).");
DEFINE_string(generate_truth_out, "", "With --generate_manhattan: also write the ground-truth graph (same edges, "
              "true vertex poses) to this g2o file.");
DEFINE_int32(generate_num_poses, 3500, "With --generate_manhattan: number of poses (>= 2).");
DEFINE_int32(generate_half_extent_blocks, 4, "With --generate_manhattan: the walk stays within this many city "
             "blocks (5 m each) of the start, in x and y (>= 1).");
DEFINE_uint32(generate_seed, 1, "With --generate_manhattan: random seed; equal seeds give equal graphs.");

namespace hetslam {
namespace {

int Fail(const std::string& message) {
  std::cerr << "hetslam_posegraph: " << message << "\n";
  return 1;
}

std::string Upper(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::toupper(c); });
  return s;
}

bool OptionsFromFlags(PoseGraph2dOptions* options, std::string* error) {
  options->max_num_iterations = FLAGS_max_iterations;
  if (!ceres::StringToLinearSolverType(Upper(FLAGS_linear_solver), &options->linear_solver_type)) {
    *error = "unknown --linear_solver '" + FLAGS_linear_solver + "'";
    return false;
  }
  if (!ceres::StringToSparseLinearAlgebraLibraryType(
          Upper(FLAGS_sparse_library), &options->sparse_linear_algebra_library_type)) {
    *error = "unknown --sparse_library '" + FLAGS_sparse_library + "'";
    return false;
  }
  if (!ParseRobustLossType(FLAGS_robust_loss, &options->loop_closure_loss)) {
    *error = "unknown --robust_loss '" + FLAGS_robust_loss + "' (none or huber)";
    return false;
  }
  options->loop_closure_loss_scale = FLAGS_robust_loss_scale;
  options->function_tolerance = FLAGS_function_tolerance;
  options->log_progress = FLAGS_progress;
  std::string invalid;
  if (!options->IsValid(&invalid)) {
    *error = "bad solver flags: " + invalid;
    return false;
  }
  return true;
}

int Generate() {
  ManhattanGraphOptions options;
  options.num_poses = FLAGS_generate_num_poses;
  options.half_extent_blocks = FLAGS_generate_half_extent_blocks;
  std::string error;
  if (!options.IsValid(&error)) return Fail("bad --generate_* flags: " + error);
  const SyntheticPoseGraph2d synthetic = GenerateManhattanPoseGraph2d(options, FLAGS_generate_seed);
  Status status = WriteG2oPoseGraph2d(FLAGS_generate_manhattan, synthetic.graph);
  if (!status.ok()) return Fail(status.message());
  std::cout << "wrote " << FLAGS_generate_manhattan << ": " << synthetic.graph.vertices.size()
            << " vertices, " << synthetic.graph.edges.size() << " edges (seed "
            << FLAGS_generate_seed << ")\n";
  if (!FLAGS_generate_truth_out.empty()) {
    PoseGraph2d truth = synthetic.graph;
    for (PoseGraph2dVertex& v : truth.vertices) v.world_T_vertex = synthetic.world_T_vertex_true[v.id];
    status = WriteG2oPoseGraph2d(FLAGS_generate_truth_out, truth);
    if (!status.ok()) return Fail(status.message());
    std::cout << "wrote " << FLAGS_generate_truth_out << " (ground truth)\n";
  }
  return 0;
}

// RMS / max position (m) and heading (deg) error of `graph` against `truth` (matched by id).
bool PrintErrors(const std::string& label, const PoseGraph2d& graph, const PoseGraph2d& truth,
                 std::string* error) {
  std::unordered_map<int, Pose2> true_pose;
  for (const PoseGraph2dVertex& v : truth.vertices) true_pose[v.id] = v.world_T_vertex;
  double sum_sq_t = 0.0, sum_sq_r = 0.0, max_t = 0.0, max_r = 0.0;
  for (const PoseGraph2dVertex& v : graph.vertices) {
    const auto it = true_pose.find(v.id);
    if (it == true_pose.end()) {
      *error = "--truth has no vertex " + std::to_string(v.id);
      return false;
    }
    const double t = (v.world_T_vertex.translation() - it->second.translation()).norm();
    const double r = std::abs(WrapAngle(v.world_T_vertex.theta() - it->second.theta()));
    sum_sq_t += t * t;
    sum_sq_r += r * r;
    max_t = std::max(max_t, t);
    max_r = std::max(max_r, r);
  }
  const double n = static_cast<double>(graph.vertices.size());
  std::printf("%s error vs truth: position RMS %.4f m (max %.4f m), heading RMS %.4f deg (max %.4f deg)\n",
              label.c_str(), std::sqrt(sum_sq_t / n), max_t, std::sqrt(sum_sq_r / n) * 180.0 / M_PI,
              max_r * 180.0 / M_PI);
  return true;
}

int Run() {
  if (!FLAGS_generate_manhattan.empty()) {
    const int result = Generate();
    if (result != 0 || FLAGS_g2o.empty()) return result;
  } else if (!FLAGS_generate_truth_out.empty()) {
    return Fail("--generate_truth_out needs --generate_manhattan");
  }
  if (FLAGS_g2o.empty()) return Fail("--g2o is required (an input 2D g2o file); see --help");
  if (FLAGS_out.empty()) return Fail("--out is required (the output g2o file); see --help");
  PoseGraph2dOptions options;
  std::string error;
  if (!OptionsFromFlags(&options, &error)) return Fail(error);

  PoseGraph2d graph;
  Status status = ReadG2oPoseGraph2d(FLAGS_g2o, &graph);
  if (!status.ok()) return Fail(status.message());
  PoseGraph2d truth;
  if (!FLAGS_truth.empty()) {
    status = ReadG2oPoseGraph2d(FLAGS_truth, &truth);
    if (!status.ok()) return Fail(status.message());
    if (!PrintErrors("initial", graph, truth, &error)) return Fail(error);
  }
  int loop_closures = 0;
  for (const PoseGraph2dEdge& e : graph.edges) loop_closures += e.kind == EdgeKind::kLoopClosure;
  std::printf("%s: %zu vertices, %zu edges (%d loop closures)\n", FLAGS_g2o.c_str(),
              graph.vertices.size(), graph.edges.size(), loop_closures);

  PoseGraph2dSummary summary;
  status = OptimizePoseGraph2d(options, &graph, &summary);
  if (FLAGS_full_report && !summary.full_report.empty()) std::cout << summary.full_report << "\n";
  if (!status.ok()) return Fail(status.message());
  std::printf("linear solver: %s (%s), robust loss on loop closures: %s\n",
              ceres::LinearSolverTypeToString(options.linear_solver_type),
              ceres::SparseLinearAlgebraLibraryTypeToString(options.sparse_linear_algebra_library_type),
              RobustLossTypeName(options.loop_closure_loss).c_str());
  std::printf("initial cost: %.6g\nfinal cost:   %.6g\niterations:   %d\nsolve time:   %.3f s\n"
              "converged:    %s (%s)\n",
              summary.initial_cost, summary.final_cost, summary.num_iterations,
              summary.solve_time_seconds, summary.converged ? "yes" : "no", summary.message.c_str());
  if (!FLAGS_truth.empty() && !PrintErrors("final", graph, truth, &error)) return Fail(error);
  status = WriteG2oPoseGraph2d(FLAGS_out, graph);
  if (!status.ok()) return Fail(status.message());
  std::printf("wrote %s\n", FLAGS_out.c_str());
  return 0;
}

}  // namespace
}  // namespace hetslam

int main(int argc, char** argv) {
  gflags::SetUsageMessage(
      "Optimise a 2D g2o pose graph with hetslam's Ceres factors.\n"
      "  hetslam_posegraph --g2o=IN.g2o --out=OUT.g2o [--max_iterations=N] [--linear_solver=...] "
      "[--robust_loss=none|huber]\n"
      "  hetslam_posegraph --generate_manhattan=G.g2o [--generate_truth_out=T.g2o] [--generate_num_poses=N]");
  hetslam::PrintProgramHelpIfAsked(argc, argv, __FILE__);
  gflags::ParseCommandLineFlags(&argc, &argv, true);
  google::InitGoogleLogging(argv[0]);
  if (argc > 1) return hetslam::Fail(std::string("unexpected argument '") + argv[1] + "'; see --help");
  return hetslam::Run();
}
