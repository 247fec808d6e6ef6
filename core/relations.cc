#include "core/relations.h"

#include <sys/stat.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <numeric>
#include <sstream>

#include "core/numeric_table.h"
#include "glog/logging.h"

namespace hetslam {
namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

struct MeanStd {
  double mean = 0.0;
  double std = 0.0;
};

// Mean and SAMPLE standard deviation (divides by N - 1; 0 for a single value), two passes
// for accuracy. The sample version is the one that reproduces the published figure of
// shared/datasets/README.md (GMapping on Intel: 4.61 deg; the population version gives 4.59).
MeanStd ComputeMeanStd(const std::vector<double>& values) {
  MeanStd out;
  if (values.empty()) return out;
  const double n = static_cast<double>(values.size());
  out.mean = std::accumulate(values.begin(), values.end(), 0.0) / n;
  if (values.size() < 2) return out;
  double sum_sq = 0.0;
  for (double v : values) sum_sq += (v - out.mean) * (v - out.mean);
  out.std = std::sqrt(sum_sq / (n - 1.0));
  return out;
}

double Median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const size_t n = values.size();
  return n % 2 == 1 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

// Index (into the trajectory) of the pose nearest in time to `t`, or -1 when none lies
// within `tolerance`. `order` sorts the trajectory by timestamp. On a tie the earlier pose
// wins.
int NearestPose(const std::vector<StampedPose2>& trajectory, const std::vector<int>& order,
                double t, double tolerance) {
  auto it = std::lower_bound(order.begin(), order.end(), t, [&](int index, double value) {
    return trajectory[index].stamp_seconds < value;
  });
  int best = -1;
  double best_dt = tolerance;
  if (it != order.begin()) {
    const int k = *std::prev(it);
    const double dt = t - trajectory[k].stamp_seconds;
    if (dt <= best_dt) {
      best = k;
      best_dt = dt;
    }
  }
  if (it != order.end()) {
    const int k = *it;
    const double dt = trajectory[k].stamp_seconds - t;
    if (dt <= best_dt && (best < 0 || dt < best_dt)) best = k;
  }
  return best;
}

// Exact association of a relation end at trajectory time `t` (see the header): the index of
// the trajectory pose whose stamp is that of the reading nearest to `t`; `unmatched` when no
// reading lies within `tolerance`, `other_reading` when the nearest reading is no trajectory
// pose, `tied_reading` when a reading with another pose shares the nearest reading's stamp.
int MatchThroughReadings(const std::vector<StampedPose2>& trajectory, const std::vector<int>& order,
                         const std::vector<StampedPose2>& readings, const std::vector<int>& reading_order,
                         double t, double tolerance, double same_stamp_tolerance, int unmatched,
                         int other_reading, int tied_reading) {
  const int nearest = NearestPose(readings, reading_order, t, tolerance);
  if (nearest < 0) return unmatched;
  const StampedPose2& reading = readings[nearest];
  auto it = std::lower_bound(reading_order.begin(), reading_order.end(),
                             reading.stamp_seconds - same_stamp_tolerance,
                             [&](int index, double value) { return readings[index].stamp_seconds < value; });
  for (; it != reading_order.end() &&
         readings[*it].stamp_seconds <= reading.stamp_seconds + same_stamp_tolerance;
       ++it) {
    const Pose2& other = readings[*it].pose;
    if (other.x() != reading.pose.x() || other.y() != reading.pose.y() || other.theta() != reading.pose.theta()) {
      return tied_reading;
    }
  }
  const int pose = NearestPose(trajectory, order, reading.stamp_seconds, same_stamp_tolerance);
  return pose >= 0 ? pose : other_reading;
}

}  // namespace

Status ReadRelations(const std::string& path, std::vector<Relation>* relations) {
  CHECK(relations != nullptr) << "ReadRelations: relations is null";
  relations->clear();
  std::vector<NumericRow> rows;
  HETSLAM_RETURN_IF_ERROR(
      ReadNumericTable(path, {"t1", "t2", "x", "y", "z", "roll", "pitch", "yaw"}, &rows));
  relations->reserve(rows.size());
  for (const NumericRow& row : rows) {
    const std::vector<double>& v = row.values;
    Relation r;
    r.t1_seconds = v[0];
    r.t2_seconds = v[1];
    r.delta = Pose2(v[2], v[3], v[7]);  // planar part of the 6D relation
    r.line_number = row.line_number;
    relations->push_back(r);
  }
  return Status::Ok();
}

bool RelationsMetricOptions::IsValid(std::string* error) const {
  std::ostringstream msg;
  if (!std::isfinite(clock_offset_seconds)) {
    msg << "clock_offset_seconds must be finite (got " << clock_offset_seconds << "); ";
  }
  if (!(match_tolerance_seconds >= 0.0 && std::isfinite(match_tolerance_seconds))) {
    msg << "match_tolerance_seconds must be finite and >= 0 (got " << match_tolerance_seconds
        << "); ";
  }
  if (!(same_stamp_tolerance_seconds >= 0.0 && std::isfinite(same_stamp_tolerance_seconds))) {
    msg << "same_stamp_tolerance_seconds must be finite and >= 0 (got " << same_stamp_tolerance_seconds << "); ";
  }
  for (const StampedPose2& reading : readings) {
    if (!std::isfinite(reading.stamp_seconds)) {
      msg << "readings must have finite stamps; ";
      break;
    }
  }
  if (error != nullptr) *error = msg.str();
  return msg.str().empty();
}

RelationsMetricResult EvaluateRelations(const std::vector<StampedPose2>& trajectory,
                                        const std::vector<Relation>& relations,
                                        const RelationsMetricOptions& options) {
  std::string error;
  CHECK(options.IsValid(&error)) << "invalid RelationsMetricOptions: " << error;
  RelationsMetricResult result;
  result.total = static_cast<int>(relations.size());

  std::vector<int> order(trajectory.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return trajectory[a].stamp_seconds < trajectory[b].stamp_seconds;
  });

  std::vector<int> reading_order(options.readings.size());
  std::iota(reading_order.begin(), reading_order.end(), 0);
  std::stable_sort(reading_order.begin(), reading_order.end(), [&](int a, int b) {
    return options.readings[a].stamp_seconds < options.readings[b].stamp_seconds;
  });

  // Nearest poses of both ends, and for every pose the distinct relation stamps it matched.
  // With readings, an end is first matched to its nearest reading (see the header).
  constexpr int kUnmatched = -1, kOtherReading = -2, kTiedReading = -3;
  std::vector<std::array<int, 2>> ends(relations.size());
  std::vector<std::vector<double>> stamps_of_pose(trajectory.size());
  for (size_t r = 0; r < relations.size(); ++r) {
    const double t[2] = {relations[r].t1_seconds, relations[r].t2_seconds};
    for (int e = 0; e < 2; ++e) {
      const double t_trajectory = t[e] - options.clock_offset_seconds;
      if (options.readings.empty()) {
        ends[r][e] = NearestPose(trajectory, order, t_trajectory, options.match_tolerance_seconds);
      } else {
        ends[r][e] = MatchThroughReadings(trajectory, order, options.readings, reading_order, t_trajectory,
                                          options.match_tolerance_seconds, options.same_stamp_tolerance_seconds,
                                          kUnmatched, kOtherReading, kTiedReading);
      }
      if (ends[r][e] >= 0) stamps_of_pose[ends[r][e]].push_back(t[e]);
    }
  }
  // (With readings, two relation stamps nearest to one reading name the same reading: the
  // readings already resolved which instant each end is, so the stamp rule below is moot.)
  if (!options.readings.empty()) stamps_of_pose.assign(trajectory.size(), {});
  std::vector<bool> ambiguous_pose(trajectory.size(), false);
  for (size_t i = 0; i < trajectory.size(); ++i) {
    const auto [lo, hi] = std::minmax_element(stamps_of_pose[i].begin(), stamps_of_pose[i].end());
    ambiguous_pose[i] = lo != stamps_of_pose[i].end() && *lo != *hi;
  }

  std::vector<double> trans, rot, trans_sq, rot_sq;
  for (size_t r = 0; r < relations.size(); ++r) {
    const Relation& relation = relations[r];
    const int i1 = ends[r][0], i2 = ends[r][1];
    if (i1 == kUnmatched || i2 == kUnmatched) continue;
    if (i1 == kOtherReading || i2 == kOtherReading) {
      ++result.on_other_reading;
      continue;
    }
    if (i1 == kTiedReading || i2 == kTiedReading || ambiguous_pose[i1] || ambiguous_pose[i2]) {
      ++result.ambiguous;
      continue;
    }
    const Pose2 estimate = Between(trajectory[i1].pose, trajectory[i2].pose);
    RelationError e;
    e.relation_index = static_cast<int>(r);
    e.trajectory_index_1 = i1;
    e.trajectory_index_2 = i2;
    e.trans_error_m = (estimate.translation() - relation.delta.translation()).norm();
    e.rot_error_deg = std::abs(WrapAngle(estimate.theta() - relation.delta.theta())) * kRadToDeg;
    result.errors.push_back(e);
    trans.push_back(e.trans_error_m);
    rot.push_back(e.rot_error_deg);
    trans_sq.push_back(e.trans_error_m * e.trans_error_m);
    rot_sq.push_back(e.rot_error_deg * e.rot_error_deg);
  }
  result.matched = static_cast<int>(result.errors.size());
  if (result.matched == 0) return result;

  const MeanStd t = ComputeMeanStd(trans), a = ComputeMeanStd(rot);
  const MeanStd t2 = ComputeMeanStd(trans_sq), a2 = ComputeMeanStd(rot_sq);
  result.trans_mean_m = t.mean;
  result.trans_std_m = t.std;
  result.rot_mean_deg = a.mean;
  result.rot_std_deg = a.std;
  result.trans_sq_mean_m2 = t2.mean;
  result.trans_sq_std_m2 = t2.std;
  result.rot_sq_mean_deg2 = a2.mean;
  result.rot_sq_std_deg2 = a2.std;
  result.trans_median_m = Median(trans);
  result.rot_median_deg = Median(rot);
  result.trans_max_m = *std::max_element(trans.begin(), trans.end());
  result.rot_max_deg = *std::max_element(rot.begin(), rot.end());
  return result;
}

}  // namespace hetslam
