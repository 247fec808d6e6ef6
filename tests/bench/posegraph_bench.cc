// Solving seeded synthetic Manhattan-style pose graphs (core/synthetic_pose_graph.h) with the
// factor library, per linear solver. Each iteration solves from the same dead-reckoned start.
//   ./bench_posegraph_bench --benchmark_filter=.
#include <string>

#include "benchmark/benchmark.h"
#include "core/synthetic_pose_graph.h"
#include "factors/pose_graph_2d.h"
#include "glog/logging.h"

namespace hetslam {
namespace {

void SolveManhattan(benchmark::State& state, ceres::LinearSolverType linear_solver) {
  ManhattanGraphOptions generator;
  generator.num_poses = static_cast<int>(state.range(0));
  const SyntheticPoseGraph2d synthetic = GenerateManhattanPoseGraph2d(generator, 1000);
  PoseGraph2dOptions options;
  options.linear_solver_type = linear_solver;
  PoseGraph2dSummary summary;
  for (auto _ : state) {
    PoseGraph2d graph = synthetic.graph;
    const Status status = OptimizePoseGraph2d(options, &graph, &summary);
    CHECK(status.ok()) << status.message();
    benchmark::DoNotOptimize(graph.vertices.data());
  }
  state.counters["edges"] = static_cast<double>(synthetic.graph.edges.size());
  state.counters["iterations"] = summary.num_iterations;
  state.counters["initial_cost"] = summary.initial_cost;
  state.counters["final_cost"] = summary.final_cost;
  state.counters["converged"] = summary.converged ? 1.0 : 0.0;
}

void BM_PoseGraphSparseNormalCholesky(benchmark::State& state) {
  SolveManhattan(state, ceres::SPARSE_NORMAL_CHOLESKY);
}
BENCHMARK(BM_PoseGraphSparseNormalCholesky)->Arg(250)->Arg(1000)->Arg(3500)->Unit(benchmark::kMillisecond);

void BM_PoseGraphDenseQr(benchmark::State& state) { SolveManhattan(state, ceres::DENSE_QR); }
BENCHMARK(BM_PoseGraphDenseQr)->Arg(100)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace hetslam

BENCHMARK_MAIN();
