// EKF state updater and MARG filter costs (issue 6):
//   BM_EkfPredictAndMargUpdate     one in-order 100 Hz MARG measurement: prediction by 10 ms,
//                                  6-row update, checkpoint into a 1 s history, pruning.
//   BM_EkfScanUpdateWith300msRewind one scan-match pose stamped 300 ms behind the newest
//                                  measurement: rewind, 3-row update (+ velocity
//                                  observation), replay of the ~30 MARG and ~3 scan updates
//                                  after it.
//   BM_MargFilterAdd               one raw gyro/accel/mag sample through the Mahony filter.
// Run: build/tests/bench_ekf_bench
#include <random>

#include "benchmark/benchmark.h"
#include "core/se2.h"
#include "frontends/ekf_state_updater.h"
#include "frontends/marg_filter.h"

namespace hetslam {
namespace {

constexpr double kMargPeriod = 0.01;

MargMeasurement MakeMarg(double t, std::mt19937* rng) {
  std::normal_distribution<double> noise(0.0, 0.01);
  MargMeasurement m;
  m.stamp_seconds = t;
  m.roll_radians = 0.05 * std::sin(t) + noise(*rng);
  m.pitch_radians = 0.03 * std::cos(t) + noise(*rng);
  m.heading_radians = WrapAngle(0.3 * t + noise(*rng));
  m.euler_rates_radps = Eigen::Vector3d(0.05 * std::cos(t), -0.03 * std::sin(t), 0.3);
  m.covariance.setZero();
  m.covariance.diagonal() << 1e-4, 1e-4, 2.5e-3, 1e-4, 1e-4, 1e-4;
  return m;
}

ScanMatchPose MakeScan(double t, std::mt19937* rng) {
  std::normal_distribution<double> noise(0.0, 0.02);
  ScanMatchPose s;
  s.stamp_seconds = t;
  s.world_T_robot = Pose2(0.5 * t + noise(*rng), 0.1 * t + noise(*rng), 0.3 * t);
  s.covariance = Eigen::Vector3d(4e-4, 4e-4, 1e-4).asDiagonal();
  return s;
}

// A filter that has run for 2 s: 100 Hz MARG, 10 Hz scan matches, 1 s history.
struct WarmFilter {
  explicit WarmFilter(std::mt19937* rng) : ekf(EkfStateUpdaterOptions()) {
    StateEstimate initial;
    initial.covariance = 0.01 * EkfMatrix::Identity();
    ekf.Initialize(initial);
    for (step = 1; step <= 200; ++step) AddStep(rng);
  }
  void AddStep(std::mt19937* rng) {
    const double t = step * kMargPeriod;
    ekf.AddMarg(MakeMarg(t, rng));
    // Scans are the late ones in the rewind benchmark; in the warm-up they come in order.
    if (step % 10 == 0) ekf.AddScanMatchPose(MakeScan(t, rng));
  }
  EkfStateUpdater ekf;
  int step = 0;
};

void BM_EkfPredictAndMargUpdate(benchmark::State& state) {
  std::mt19937 rng(1u);
  WarmFilter warm(&rng);
  for (auto _ : state) {
    const double t = warm.step * kMargPeriod;
    benchmark::DoNotOptimize(warm.ekf.AddMarg(MakeMarg(t, &rng)).ok());
    ++warm.step;
  }
  state.counters["history"] = warm.ekf.history_size();
}
BENCHMARK(BM_EkfPredictAndMargUpdate);

void BM_EkfScanUpdateWith300msRewind(benchmark::State& state) {
  std::mt19937 rng(2u);
  WarmFilter warm(&rng);
  for (auto _ : state) {
    state.PauseTiming();
    // 100 ms of in-order MARG, then the scan of 300 ms ago arrives.
    for (int i = 0; i < 10; ++i, ++warm.step) warm.ekf.AddMarg(MakeMarg(warm.step * kMargPeriod, &rng));
    const double newest = (warm.step - 1) * kMargPeriod;
    const ScanMatchPose late = MakeScan(newest - 0.3 + 0.5 * kMargPeriod, &rng);
    state.ResumeTiming();
    benchmark::DoNotOptimize(warm.ekf.AddScanMatchPose(late).ok());
  }
  state.counters["replayed_per_update"] =
      static_cast<double>(warm.ekf.num_replayed()) / warm.ekf.num_out_of_sequence();
}
BENCHMARK(BM_EkfScanUpdateWith300msRewind);

void BM_MargFilterAdd(benchmark::State& state) {
  MargFilter filter{MargFilterOptions()};
  std::mt19937 rng(3u);
  std::normal_distribution<double> noise(0.0, 0.01);
  MargAttitude attitude;
  MargSample sample;
  sample.accel_mps2 = Eigen::Vector3d(0.1, -0.2, 9.8);
  sample.magnetometer = Eigen::Vector3d(0.25, 0.01, -0.43);
  filter.Add(sample, &attitude);
  int64_t k = 0;
  for (auto _ : state) {
    sample.stamp_seconds = (++k) * kMargPeriod;
    sample.gyro_radps = Eigen::Vector3d(noise(rng), noise(rng), 0.1 + noise(rng));
    benchmark::DoNotOptimize(filter.Add(sample, &attitude).ok());
  }
}
BENCHMARK(BM_MargFilterAdd);

}  // namespace
}  // namespace hetslam

BENCHMARK_MAIN();
