#include "frontends/ekf_state_updater.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <variant>
#include <vector>

#include "Eigen/Cholesky"
#include "core/se2.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace hetslam {
namespace {

using ::testing::HasSubstr;

// ------------------------------------------------------------------------------------------
// Test helpers: a seeded truth + measurement simulation.

using AnyMeasurement =
    std::variant<VelocityCommand, MargMeasurement, ScanMatchPose, AltitudeMeasurement>;

double StampOf(const AnyMeasurement& m) {
  return std::visit([](const auto& x) { return x.stamp_seconds; }, m);
}

Status Feed(const AnyMeasurement& m, EkfStateUpdater* ekf) {
  if (const auto* c = std::get_if<VelocityCommand>(&m)) return ekf->AddCommand(*c);
  if (const auto* g = std::get_if<MargMeasurement>(&m)) return ekf->AddMarg(*g);
  if (const auto* s = std::get_if<ScanMatchPose>(&m)) return ekf->AddScanMatchPose(*s);
  return ekf->AddAltitude(std::get<AltitudeMeasurement>(m));
}

struct SensorNoise {
  double scan_xy_stddev_meters = 0.03;
  double scan_heading_stddev_radians = 0.01;
  double marg_tilt_stddev_radians = 0.01;
  double marg_rate_stddev_radps = 0.02;
  double altitude_stddev_meters = 0.01;
};

struct Simulation {
  std::vector<AnyMeasurement> measurements;  // in stamp order
  std::vector<double> scan_stamps;
  std::vector<EkfVector> truth_at_scans;     // true state at each scan stamp
};

// Simulates the filter's own process model on a 10 ms grid (exact discretisation of the
// continuous noise, so the filter's model is the truth's): MARG (roll, pitch, rates; no
// heading) every step, scan-match (x, y, φ) every 10th step, altitude every 50th. With
// `with_commands`, a random body-velocity command is issued every second and the truth
// follows paper eq. 3 with the command noise densities.
Simulation Simulate(uint32_t seed, double duration_seconds, const EkfStateUpdaterOptions& options,
                    const SensorNoise& noise, bool with_commands, const StateEstimate& initial) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  const double dt = 0.01;

  // Initial truth ~ N(initial.state, initial.covariance).
  const Eigen::LLT<EkfMatrix> llt0(initial.covariance);
  EkfVector w0;
  for (int i = 0; i < kEkfStateSize; ++i) w0[i] = normal(rng);
  EkfVector X = initial.state + llt0.matrixL() * w0;

  // (position, rate) white-acceleration noise sampled with the Cholesky factor of
  // q [dt³/3 dt²/2; dt²/2 dt].
  const auto cv_step = [&](int p, int v, double density) {
    const double q = density * density;
    Eigen::Matrix2d Q;
    Q << q * dt * dt * dt / 3.0, q * dt * dt / 2.0, q * dt * dt / 2.0, q * dt;
    const Eigen::Vector2d w = Eigen::LLT<Eigen::Matrix2d>(Q).matrixL() *
                              Eigen::Vector2d(normal(rng), normal(rng));
    X[p] += dt * X[v] + w[0];
    X[v] += w[1];
  };

  Simulation sim;
  // With commands, the first one is issued at the start so that the whole run follows eq. 3.
  VelocityCommand command;
  command.stamp_seconds = initial.stamp_seconds;
  command.forward_mps = 0.5;
  if (with_commands) sim.measurements.push_back(command);
  const int steps = static_cast<int>(std::lround(duration_seconds / dt));
  for (int k = 1; k <= steps; ++k) {
    const double t = initial.stamp_seconds + k * dt;
    // Truth step over (t - dt, t] with the command that was live at t - dt.
    if (with_commands) {
      const double c = std::cos(X[kYaw]), s = std::sin(X[kYaw]);
      const double sq_dt = std::sqrt(dt);
      X[kX] += dt * (c * command.forward_mps - s * command.left_mps) +
               options.command_position_noise_meters_per_sqrt_second * sq_dt * normal(rng);
      X[kY] += dt * (s * command.forward_mps + c * command.left_mps) +
               options.command_position_noise_meters_per_sqrt_second * sq_dt * normal(rng);
      X[kYaw] += dt * command.yaw_rate_radps +
                 options.command_yaw_noise_radians_per_sqrt_second * sq_dt * normal(rng);
      X[kVx] += options.command_velocity_noise_mps_per_sqrt_second * sq_dt * normal(rng);
      X[kVy] += options.command_velocity_noise_mps_per_sqrt_second * sq_dt * normal(rng);
      X[kYawRate] += options.command_yaw_rate_noise_radps_per_sqrt_second * sq_dt * normal(rng);
    } else {
      cv_step(kX, kVx, options.horizontal_acceleration_noise_mps2_per_sqrt_hz);
      cv_step(kY, kVy, options.horizontal_acceleration_noise_mps2_per_sqrt_hz);
      cv_step(kYaw, kYawRate, options.yaw_acceleration_noise_radps2_per_sqrt_hz);
    }
    cv_step(kZ, kVz, options.vertical_acceleration_noise_mps2_per_sqrt_hz);
    cv_step(kRoll, kRollRate, options.tilt_acceleration_noise_radps2_per_sqrt_hz);
    cv_step(kPitch, kPitchRate, options.tilt_acceleration_noise_radps2_per_sqrt_hz);
    X[kYaw] = WrapAngle(X[kYaw]);

    if (with_commands && k % 100 == 0) {
      command.stamp_seconds = t;
      command.forward_mps = 0.5 + 0.4 * uniform(rng);
      command.left_mps = 0.1 * uniform(rng);
      command.yaw_rate_radps = 0.5 * uniform(rng);
      sim.measurements.push_back(command);
    }
    MargMeasurement marg;
    marg.stamp_seconds = t;
    marg.has_heading = false;
    marg.roll_radians = X[kRoll] + noise.marg_tilt_stddev_radians * normal(rng);
    marg.pitch_radians = X[kPitch] + noise.marg_tilt_stddev_radians * normal(rng);
    marg.heading_radians = 0.0;
    for (int i = 0; i < 3; ++i) {
      marg.euler_rates_radps[i] = X[kRollRate + i] + noise.marg_rate_stddev_radps * normal(rng);
    }
    marg.covariance.setZero();
    marg.covariance.diagonal() << std::pow(noise.marg_tilt_stddev_radians, 2),
        std::pow(noise.marg_tilt_stddev_radians, 2), 1.0,
        Eigen::Vector3d::Constant(std::pow(noise.marg_rate_stddev_radps, 2));
    sim.measurements.push_back(marg);
    if (k % 50 == 0) {
      AltitudeMeasurement altitude;
      altitude.stamp_seconds = t;
      altitude.z_meters = X[kZ] + noise.altitude_stddev_meters * normal(rng);
      altitude.variance_meters2 = std::pow(noise.altitude_stddev_meters, 2);
      sim.measurements.push_back(altitude);
    }
    if (k % 10 == 0) {
      ScanMatchPose scan;
      scan.stamp_seconds = t;
      scan.world_T_robot = Pose2(X[kX] + noise.scan_xy_stddev_meters * normal(rng),
                                 X[kY] + noise.scan_xy_stddev_meters * normal(rng),
                                 X[kYaw] + noise.scan_heading_stddev_radians * normal(rng));
      scan.covariance.setZero();
      scan.covariance.diagonal() << std::pow(noise.scan_xy_stddev_meters, 2),
          std::pow(noise.scan_xy_stddev_meters, 2), std::pow(noise.scan_heading_stddev_radians, 2);
      sim.measurements.push_back(scan);
      sim.scan_stamps.push_back(t);
      sim.truth_at_scans.push_back(X);
    }
  }
  return sim;
}

StateEstimate InitialEstimate() {
  StateEstimate initial;
  initial.stamp_seconds = 100.0;
  initial.state.setZero();
  initial.state[kZ] = 0.5;
  initial.state[kYaw] = 3.0;  // starts near +pi: wrapping is exercised
  initial.covariance.setZero();
  initial.covariance.diagonal() << 0.05 * 0.05, 0.05 * 0.05, 0.02 * 0.02, 0.1 * 0.1, 0.1 * 0.1,
      0.02 * 0.02, 0.02 * 0.02, 0.02 * 0.02, 0.05 * 0.05, 0.05 * 0.05, 0.05 * 0.05, 0.05 * 0.05;
  return initial;
}

double PoseNees(const StateEstimate& estimate, const EkfVector& truth) {
  Eigen::Vector3d error(estimate.state[kX] - truth[kX], estimate.state[kY] - truth[kY],
                        WrapAngle(estimate.state[kYaw] - truth[kYaw]));
  return error.dot(estimate.pose_covariance().ldlt().solve(error));
}

// Chi-square quantile by the Wilson-Hilferty approximation (relative error < 1e-3 for the
// >= 100 degrees of freedom used here).
double ChiSquareQuantile(double dof, double standard_normal_quantile) {
  const double a = 2.0 / (9.0 * dof);
  return dof * std::pow(1.0 - a + standard_normal_quantile * std::sqrt(a), 3);
}

// ------------------------------------------------------------------------------------------
// Options and small functions.

TEST(EkfStateUpdaterOptionsTest, RejectsBadValuesWithMessage) {
  EkfStateUpdaterOptions options;
  std::string error;
  EXPECT_TRUE(options.IsValid(&error)) << error;

  options.history_window_seconds = -1.0;
  EXPECT_FALSE(options.IsValid(&error));
  EXPECT_THAT(error, HasSubstr("history_window_seconds"));

  options = EkfStateUpdaterOptions();
  options.horizontal_acceleration_noise_mps2_per_sqrt_hz = std::nan("");
  EXPECT_FALSE(options.IsValid(&error));
  EXPECT_THAT(error, HasSubstr("horizontal_acceleration_noise_mps2_per_sqrt_hz"));

  options = EkfStateUpdaterOptions();
  options.scan_velocity.min_poses = 1;
  EXPECT_FALSE(options.IsValid(&error));
  EXPECT_THAT(error, HasSubstr("min_poses"));

  options = EkfStateUpdaterOptions();
  options.scan_velocity.min_span_seconds = 2.0;  // longer than the 1 s window
  EXPECT_FALSE(options.IsValid(&error));
  EXPECT_THAT(error, HasSubstr("min_span_seconds"));

  HumanoidHeadOptions head;
  EXPECT_TRUE(head.IsValid(&error)) << error;
  head.neck_height_meters = 0.0;
  EXPECT_FALSE(head.IsValid(&error));
  EXPECT_THAT(error, HasSubstr("neck_height_meters"));
}

TEST(HumanoidAltitudeTest, LaserHeightFromHeadPitch) {
  HumanoidHeadOptions head;
  head.neck_height_meters = 0.5;
  head.neck_to_laser_forward_meters = 0.06;
  head.neck_to_laser_up_meters = 0.08;
  // Level head: the laser is `up` above the neck.
  EXPECT_NEAR(LaserHeightFromHeadPitch(head, 0.0, 0.0), 0.58, 1e-12);
  // Looking straight down: the forward offset points down, the up offset forward.
  EXPECT_NEAR(LaserHeightFromHeadPitch(head, M_PI / 2.0, 0.0), 0.44, 1e-12);
  // 30° nose down split between body and head: 0.5 + 0.08 cos30° - 0.06 sin30°.
  EXPECT_NEAR(LaserHeightFromHeadPitch(head, 20.0 * M_PI / 180.0, 10.0 * M_PI / 180.0),
              0.5 + 0.08 * std::sqrt(3.0) / 2.0 - 0.03, 1e-12);
  // Nose up raises the laser when it sits forward of the neck.
  EXPECT_GT(LaserHeightFromHeadPitch(head, -0.2, 0.0), LaserHeightFromHeadPitch(head, 0.0, 0.0));
}

TEST(ScanVelocityEstimatorTest, LineFitRecoversVelocityAndIgnoresFuturePoses) {
  ScanVelocityOptions options;
  options.window_seconds = 1.0;
  options.min_poses = 3;
  options.min_span_seconds = 0.5;
  options.smoothing_stddev_mps = 0.0;
  ScanVelocityEstimator estimator(options);
  const Eigen::Matrix2d covariance = 0.01 * Eigen::Matrix2d::Identity();
  VelocityObservation observation;
  // Poses on x = 1 + 0.5 t, y = -0.2 t at 10 Hz, inserted in a scrambled order.
  for (int i : {3, 0, 7, 1, 9, 2, 4, 10, 6, 5, 8}) {
    const double t = 0.1 * i;
    estimator.AddPose(t, Eigen::Vector2d(1.0 + 0.5 * t, -0.2 * t), covariance);
  }
  // A pose after the query time, far off the line, must not change the fit.
  estimator.AddPose(1.05, Eigen::Vector2d(100.0, 100.0), covariance);
  ASSERT_TRUE(estimator.VelocityAt(1.0, &observation));
  EXPECT_NEAR(observation.velocity_mps.x(), 0.5, 1e-12);
  EXPECT_NEAR(observation.velocity_mps.y(), -0.2, 1e-12);
  // 11 poses 0.1 s apart: Σ (t - t̄)² = 0.01 Σ_{i=-5..5} i² = 1.1 s², slope variance σ² / 1.1.
  EXPECT_NEAR(observation.covariance(0, 0), 0.01 / 1.1, 1e-12);
  EXPECT_NEAR(observation.covariance(0, 1), 0.0, 1e-15);
  // Only two poses in [-0.9, 0.1]: no observation; a 0.2 s span is below min_span.
  EXPECT_FALSE(estimator.VelocityAt(0.1, &observation));
  EXPECT_FALSE(estimator.VelocityAt(0.2, &observation));
  estimator.DropBefore(0.55);
  EXPECT_EQ(estimator.size(), 6);
}

// ------------------------------------------------------------------------------------------
// Filter behaviour.

TEST(EkfStateUpdaterTest, RequiresInitialisationAndValidatesMeasurements) {
  EkfStateUpdater ekf{EkfStateUpdaterOptions()};
  ScanMatchPose scan;
  scan.stamp_seconds = 1.0;
  EXPECT_FALSE(ekf.AddScanMatchPose(scan).ok());
  ekf.Initialize(InitialEstimate());
  scan.stamp_seconds = 100.1;
  scan.covariance = Eigen::Vector3d(0.01, -0.01, 0.01).asDiagonal();
  const Status not_psd = ekf.AddScanMatchPose(scan);
  EXPECT_FALSE(not_psd.ok());
  EXPECT_THAT(not_psd.message(), HasSubstr("positive semi-definite"));
  scan.covariance = Eigen::Matrix3d::Identity();
  scan.covariance(0, 1) = 0.5;
  EXPECT_THAT(ekf.AddScanMatchPose(scan).message(), HasSubstr("non-symmetric"));
  AltitudeMeasurement altitude;
  altitude.stamp_seconds = 100.1;
  altitude.variance_meters2 = 0.0;
  EXPECT_FALSE(ekf.AddAltitude(altitude).ok());
  EXPECT_EQ(ekf.history_size(), 0);
}

TEST(EkfStateUpdaterTest, ScanUpdateWrapsHeadingAcrossPi) {
  EkfStateUpdater ekf{EkfStateUpdaterOptions()};
  StateEstimate initial = InitialEstimate();
  initial.state[kYaw] = M_PI - 0.02;
  ekf.Initialize(initial);
  ScanMatchPose scan;
  scan.stamp_seconds = initial.stamp_seconds;  // no prediction in between
  scan.world_T_robot = Pose2(0.0, 0.0, -M_PI + 0.02);  // 0.04 rad away across ±pi
  scan.covariance = Eigen::Vector3d(0.01, 0.01, initial.covariance(kYaw, kYaw)).asDiagonal();
  ASSERT_TRUE(ekf.AddScanMatchPose(scan).ok());
  // Equal variances: the estimate lands half-way, on the ±pi seam, not near 0.
  EXPECT_NEAR(std::abs(ekf.latest().state[kYaw]), M_PI, 1e-9);
  EXPECT_NEAR(ekf.latest().covariance(kYaw, kYaw), 0.5 * initial.covariance(kYaw, kYaw), 1e-12);
}

// Issue 6, done-when 1: a stream delivered out of order with random delays gives the same
// final estimate as the same stream in stamp order (to 1e-9).
TEST(EkfStateUpdaterTest, OutOfOrderStreamEqualsInOrderStream) {
  EkfStateUpdaterOptions options;
  options.history_window_seconds = 1.0;
  const StateEstimate initial = InitialEstimate();
  for (bool with_commands : {false, true}) {
    const Simulation sim = Simulate(7u, 20.0, options, SensorNoise(), with_commands, initial);

    EkfStateUpdater in_order(options);
    in_order.Initialize(initial);
    for (const AnyMeasurement& m : sim.measurements) ASSERT_TRUE(Feed(m, &in_order).ok());
    EXPECT_EQ(in_order.num_out_of_sequence(), 0);

    // Arrival = stamp + delay: MARG 0-20 ms, commands 0-50 ms, altitude 0-200 ms, scan
    // matches 50-400 ms (scan matching is slow). All delays are within the 1 s window.
    std::mt19937 rng(11u);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    std::vector<std::pair<double, size_t>> arrivals;
    for (size_t i = 0; i < sim.measurements.size(); ++i) {
      const AnyMeasurement& m = sim.measurements[i];
      double delay = 0.02 * unit(rng);
      if (std::holds_alternative<ScanMatchPose>(m)) delay = 0.05 + 0.35 * unit(rng);
      if (std::holds_alternative<AltitudeMeasurement>(m)) delay = 0.2 * unit(rng);
      if (std::holds_alternative<VelocityCommand>(m)) delay = 0.05 * unit(rng);
      arrivals.emplace_back(StampOf(m) + delay, i);
    }
    std::sort(arrivals.begin(), arrivals.end());
    EkfStateUpdater out_of_order(options);
    out_of_order.Initialize(initial);
    for (const auto& arrival : arrivals) {
      const Status status = Feed(sim.measurements[arrival.second], &out_of_order);
      ASSERT_TRUE(status.ok()) << status.message();
    }
    EXPECT_GT(out_of_order.num_out_of_sequence(), 100);
    EXPECT_GT(out_of_order.num_replayed(), 1000);
    EXPECT_EQ(out_of_order.num_rejected_too_old(), 0);

    const StateEstimate& a = in_order.latest();
    const StateEstimate& b = out_of_order.latest();
    EXPECT_EQ(a.stamp_seconds, b.stamp_seconds);
    EXPECT_LE((a.state - b.state).cwiseAbs().maxCoeff(), 1e-9)
        << "with_commands=" << with_commands << "\n" << a.state.transpose() << "\n"
        << b.state.transpose();
    EXPECT_LE((a.covariance - b.covariance).cwiseAbs().maxCoeff(), 1e-9);
    // The estimate has also moved far from the initial state: the test is not vacuous.
    EXPECT_GT(a.state.head<2>().norm(), 0.5);

    // Outputs at a time inside the history agree too.
    StateEstimate ea, eb;
    ASSERT_TRUE(in_order.EstimateAt(a.stamp_seconds - 0.255, &ea).ok());
    ASSERT_TRUE(out_of_order.EstimateAt(a.stamp_seconds - 0.255, &eb).ok());
    EXPECT_LE((ea.state - eb.state).cwiseAbs().maxCoeff(), 1e-9);
  }
}

// Issue 6, done-when 2: filter consistency. Over N seeded Monte Carlo runs, the average
// pose NEES (x, y, φ) after each scan update must lie in the two-sided 95% interval of
// χ²(3N)/N at (nearly) every step, and its run average must too.
void ExpectConsistentPoseNees(bool with_commands) {
  EkfStateUpdaterOptions options;
  // Velocity observations reuse the scan poses (correlated with them): without commands they
  // would count that information twice, so the consistency test of the constant-velocity
  // model runs without them. With commands x, y are decoupled from ẋ, ẏ (eq. 3) and they
  // stay on.
  options.use_scan_velocity = with_commands;
  options.command_timeout_seconds = 2.0;  // commands come every second
  const StateEstimate initial = InitialEstimate();
  constexpr int kRuns = 50;
  constexpr double kDuration = 30.0;
  std::vector<double> sum_nees;
  for (int run = 0; run < kRuns; ++run) {
    const Simulation sim =
        Simulate(1000u + run, kDuration, options, SensorNoise(), with_commands, initial);
    if (sum_nees.empty()) sum_nees.assign(sim.scan_stamps.size(), 0.0);
    EkfStateUpdater ekf(options);
    ekf.Initialize(initial);
    size_t scan_index = 0;
    for (const AnyMeasurement& m : sim.measurements) {
      ASSERT_TRUE(Feed(m, &ekf).ok());
      if (std::holds_alternative<ScanMatchPose>(m)) {
        sum_nees[scan_index] += PoseNees(ekf.latest(), sim.truth_at_scans[scan_index]);
        ++scan_index;
      }
    }
  }
  const double lower = ChiSquareQuantile(3.0 * kRuns, -1.959964) / kRuns;
  const double upper = ChiSquareQuantile(3.0 * kRuns, 1.959964) / kRuns;
  int inside = 0;
  double run_average = 0.0;
  for (double sum : sum_nees) {
    const double average = sum / kRuns;
    if (average >= lower && average <= upper) ++inside;
    run_average += average / sum_nees.size();
  }
  const double fraction_inside = static_cast<double>(inside) / sum_nees.size();
  // A consistent filter is inside 95% of the time; allow for the steps being few (300).
  EXPECT_GE(fraction_inside, 0.90) << "bounds [" << lower << ", " << upper << "]";
  EXPECT_GE(run_average, lower);
  EXPECT_LE(run_average, upper);
  // Tighter: the mean NEES of a consistent filter is 3.
  EXPECT_NEAR(run_average, 3.0, 0.3);
  ::testing::Test::RecordProperty("pose_nees_run_average", std::to_string(run_average));
  ::testing::Test::RecordProperty("fraction_of_steps_inside", std::to_string(fraction_inside));
}

TEST(EkfStateUpdaterTest, PoseNeesWithinChiSquareBoundsConstantVelocity) {
  ExpectConsistentPoseNees(/*with_commands=*/false);
}

TEST(EkfStateUpdaterTest, PoseNeesWithinChiSquareBoundsWithCommands) {
  ExpectConsistentPoseNees(/*with_commands=*/true);
}

// Issue 6: measurements older than the history window are rejected and counted; the filter
// is unchanged by them.
TEST(EkfStateUpdaterTest, TooOldMeasurementsAreRejectedAndCounted) {
  EkfStateUpdaterOptions options;
  options.history_window_seconds = 0.5;
  options.max_logged_rejections = 1;
  const StateEstimate initial = InitialEstimate();
  const Simulation sim = Simulate(3u, 3.0, options, SensorNoise(), false, initial);
  EkfStateUpdater ekf(options);
  ekf.Initialize(initial);
  for (const AnyMeasurement& m : sim.measurements) ASSERT_TRUE(Feed(m, &ekf).ok());
  const StateEstimate before = ekf.latest();
  const int history_before = ekf.history_size();
  const double newest = before.stamp_seconds;

  ScanMatchPose late;
  late.stamp_seconds = newest - 0.6;
  late.covariance = 0.01 * Eigen::Matrix3d::Identity();
  const Status status = ekf.AddScanMatchPose(late);
  EXPECT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("older than the EKF history"));
  EXPECT_EQ(ekf.num_rejected_too_old(), 1);
  MargMeasurement old_marg;
  old_marg.stamp_seconds = initial.stamp_seconds - 1.0;
  EXPECT_FALSE(ekf.AddMarg(old_marg).ok());
  EXPECT_EQ(ekf.num_rejected_too_old(), 2);
  EXPECT_EQ(ekf.latest().state, before.state);
  EXPECT_EQ(ekf.history_size(), history_before);

  // Just inside the window: accepted out of sequence.
  late.stamp_seconds = newest - 0.45;
  late.world_T_robot = ekf.latest().pose();
  EXPECT_TRUE(ekf.AddScanMatchPose(late).ok());
  EXPECT_EQ(ekf.num_rejected_too_old(), 2);
  EXPECT_EQ(ekf.num_out_of_sequence(), 1);
  // The history stays bounded by the window: [newest - 0.5, newest] holds 51 MARG, 6 scan
  // and 2 altitude stamps (one fewer of each if rounding puts the oldest just outside) plus
  // the late scan.
  EXPECT_LE(ekf.history_size(), 60);
  EXPECT_GE(ekf.history_size(), 57);
}

TEST(EkfStateUpdaterTest, ConstantRateOutputDoesNotAlterTheFilter) {
  EkfStateUpdaterOptions options;
  options.output_period_seconds = 0.02;
  const StateEstimate initial = InitialEstimate();
  const Simulation sim = Simulate(5u, 2.0, options, SensorNoise(), false, initial);
  EkfStateUpdater with_output(options), without_output(options);
  with_output.Initialize(initial);
  without_output.Initialize(initial);
  std::vector<StateEstimate> outputs;
  for (const AnyMeasurement& m : sim.measurements) {
    ASSERT_TRUE(Feed(m, &with_output).ok());
    ASSERT_TRUE(Feed(m, &without_output).ok());
    // Ask at odd times, between measurement stamps.
    for (const StateEstimate& e : with_output.AdvanceTo(StampOf(m) + 0.0037)) outputs.push_back(e);
  }
  EXPECT_EQ(with_output.latest().state, without_output.latest().state);
  EXPECT_EQ(with_output.latest().covariance, without_output.latest().covariance);
  // Every 20 ms tick from 100.02 to the end, once each, in order.
  ASSERT_EQ(outputs.size(), 100u);
  for (size_t i = 0; i < outputs.size(); ++i) {
    EXPECT_NEAR(outputs[i].stamp_seconds, initial.stamp_seconds + 0.02 * (i + 1), 1e-9);
  }
  // A prediction grows the covariance: the output between two scans is less certain than
  // the estimate at the scan before it.
  StateEstimate at_scan, after_scan;
  ASSERT_TRUE(with_output.EstimateAt(sim.scan_stamps.back(), &at_scan).ok());
  ASSERT_TRUE(with_output.EstimateAt(sim.scan_stamps.back() + 0.5, &after_scan).ok());
  EXPECT_GT(after_scan.pose_covariance().trace(), at_scan.pose_covariance().trace());
  EXPECT_FALSE(with_output.EstimateAt(initial.stamp_seconds, &at_scan).ok())
      << "the initial stamp has left the 1 s history";
}

// From `initial`, a command of 1 m/s forward at its stamp and nothing else: the estimate
// `seconds` later.
void CoastOnOneCommand(const EkfStateUpdaterOptions& options, const StateEstimate& initial, double seconds,
                       StateEstimate* after) {
  EkfStateUpdater ekf(options);
  ekf.Initialize(initial);
  VelocityCommand command;
  command.stamp_seconds = initial.stamp_seconds;
  command.forward_mps = 1.0;
  ASSERT_TRUE(ekf.AddCommand(command).ok());
  ASSERT_TRUE(ekf.EstimateAt(initial.stamp_seconds + seconds, after).ok());
}

// Without scan matches (the laser sees the floor) the estimate coasts on the commands and
// its uncertainty grows; the RBPF spreads particles with this covariance.
TEST(EkfStateUpdaterTest, CoastsOnCommandsWhenScanMatchingIsSuspended) {
  EkfStateUpdaterOptions options;
  options.command_timeout_seconds = 5.0;
  StateEstimate initial = InitialEstimate();
  initial.state[kYaw] = M_PI / 2.0;
  StateEstimate after;
  CoastOnOneCommand(options, initial, 2.0, &after);
  ASSERT_FALSE(::testing::Test::HasFatalFailure());
  // Facing +y at 1 m/s for 2 s.
  EXPECT_NEAR(after.state[kX], 0.0, 1e-12);
  EXPECT_NEAR(after.state[kY], 2.0, 1e-12);
  // Heading uncertainty maps into x: σ_x² grows by (2 m)² σ_φ² plus the random walk.
  const double expected_var_x = initial.covariance(kX, kX) + 4.0 * initial.covariance(kYaw, kYaw) +
                                std::pow(options.command_position_noise_meters_per_sqrt_second, 2) * 2.0;
  EXPECT_NEAR(after.covariance(kX, kX), expected_var_x, 1e-4);
}

// A platform whose velocity follows its commands with a lag (command_response_seconds = τ):
// from rest, a step to 1 m/s forward moves it by T - τ (1 - e^(-T/τ)) in T, at 1 - e^(-T/τ) m/s;
// the covariance propagates through the same model (its heading column against a difference
// of two predictions); τ = 0 keeps paper eq. 3.
TEST(EkfStateUpdaterTest, WithACommandResponseTheVelocityFollowsTheCommandWithItsLag) {
  constexpr double kTau = 0.25, kT = 0.5;
  EkfStateUpdaterOptions options;
  options.command_timeout_seconds = 5.0;
  options.command_response_seconds = kTau;
  auto predict = [&](const EkfStateUpdaterOptions& o, double yaw, StateEstimate* after) {
    StateEstimate initial = InitialEstimate();
    initial.state[kYaw] = yaw;
    initial.covariance.setZero();
    initial.covariance(kYaw, kYaw) = 0.01 * 0.01;
    CoastOnOneCommand(o, initial, kT, after);
  };
  StateEstimate after;
  predict(options, M_PI / 2.0, &after);
  ASSERT_FALSE(::testing::Test::HasFatalFailure());
  const double moved = kT - kTau * (1.0 - std::exp(-kT / kTau));  // 0.2838 m
  EXPECT_NEAR(after.state[kX], 0.0, 1e-12);
  EXPECT_NEAR(after.state[kY], moved, 1e-12);
  EXPECT_NEAR(after.state[kVx], 0.0, 1e-12);
  EXPECT_NEAR(after.state[kVy], 1.0 - std::exp(-kT / kTau), 1e-12);
  // ∂x/∂φ from two predictions 1e-6 rad apart; x's variance is that squared times φ's plus the
  // position random walk.
  StateEstimate plus, minus;
  predict(options, M_PI / 2.0 + 1e-6, &plus);
  predict(options, M_PI / 2.0 - 1e-6, &minus);
  const double dx_dphi = (plus.state[kX] - minus.state[kX]) / 2e-6;
  EXPECT_NEAR(dx_dphi, -moved, 1e-6);
  EXPECT_NEAR(after.covariance(kX, kX),
              dx_dphi * dx_dphi * 1e-4 + std::pow(options.command_position_noise_meters_per_sqrt_second, 2) * kT, 1e-9);
  EXPECT_NEAR(after.covariance(kX, kVx), (plus.state[kVx] - minus.state[kVx]) / 2e-6 * dx_dphi * 1e-4, 1e-9);

  options.command_response_seconds = 0.0;
  predict(options, M_PI / 2.0, &after);
  EXPECT_NEAR(after.state[kY], kT, 1e-12);

  options.command_response_seconds = -0.1;
  std::string error;
  EXPECT_FALSE(options.IsValid(&error));
  EXPECT_THAT(error, HasSubstr("command_response_seconds"));
}

// With the lag model one prediction maps the covariance as F P Fᵀ + Q, F the Jacobian of the
// state's prediction: P'(P0) - P'(0) against F P0 Fᵀ with F by central differences of the
// predicted state, for a dense seeded P0 (every coupling exercised, the velocity's into the
// position and the heading's into both).
TEST(EkfStateUpdaterTest, WithACommandResponseTheCovarianceFollowsTheModelsJacobian) {
  EkfStateUpdaterOptions options;
  options.command_timeout_seconds = 5.0;
  options.command_response_seconds = 0.25;
  StateEstimate initial = InitialEstimate();
  initial.state[kYaw] = 1.0;
  initial.state[kVx] = 0.3;
  initial.state[kVy] = -0.2;
  initial.state[kRollRate] = 0.05;
  auto predict = [&](const StateEstimate& from, StateEstimate* after) { CoastOnOneCommand(options, from, 0.4, after); };
  EkfMatrix jacobian;
  for (int k = 0; k < kEkfStateSize; ++k) {
    StateEstimate plus = initial, minus = initial, plus_after, minus_after;
    plus.state[k] += 1e-6;
    minus.state[k] -= 1e-6;
    predict(plus, &plus_after);
    predict(minus, &minus_after);
    ASSERT_FALSE(::testing::Test::HasFatalFailure());
    jacobian.col(k) = (plus_after.state - minus_after.state) / 2e-6;
  }
  std::mt19937 rng(3);
  std::normal_distribution<double> normal(0.0, 0.1);
  EkfMatrix root;
  for (int i = 0; i < kEkfStateSize * kEkfStateSize; ++i) root.data()[i] = normal(rng);
  StateEstimate with_p0 = initial, without = initial, after_p0, after_zero;
  with_p0.covariance = root * root.transpose();
  without.covariance.setZero();
  predict(with_p0, &after_p0);
  predict(without, &after_zero);
  ASSERT_FALSE(::testing::Test::HasFatalFailure());
  const EkfMatrix expected = jacobian * with_p0.covariance * jacobian.transpose();
  EXPECT_LT((after_p0.covariance - after_zero.covariance - expected).cwiseAbs().maxCoeff(), 1e-7)
      << "got\n" << after_p0.covariance - after_zero.covariance << "\nexpected\n" << expected;
}

}  // namespace
}  // namespace hetslam
