// Ground-truth relations and the relations metric of Kümmerle et al. 2009 ("On measuring the
// accuracy of SLAM algorithms", Autonomous Robots 27(4)).
//
// A relations file has one relation per line, `t1 t2 x y z roll pitch yaw` (seconds, metres,
// radians): the pose of the robot at time t2 expressed in the frame of the robot at t1,
// delta = world_T_robot(t1)^-1 * world_T_robot(t2). Only x, y and yaw are used for 2D; z, roll
// and pitch must still be finite numbers. Blank and '#' lines are skipped.
//
// The metric: for relation (t1, t2, delta) and an estimated trajectory, each end is matched to
// the trajectory pose with the nearest timestamp after shifting the relation time into the
// trajectory clock, t_trajectory = t_relation - clock_offset_seconds; a relation counts only
// when both ends match within match_tolerance_seconds and neither end is ambiguous. An end is
// ambiguous when its pose is also the nearest match of another, different relation time stamp
// in the file: the pose then stands for two readings of the original recording and cannot be
// told apart. (The shared Intel log keeps one scan per 10 ms stamp bucket of the original, which
// had pairs of readings 5 ms and up to 0.36 m apart; relations between such a pair would
// otherwise score the identity, and relations to either reading of a pair would score the
// wrong one.) Ambiguous relations are counted in `ambiguous`, not scored; the decision depends
// on time stamps only, never on the trajectory's poses, so every system is scored on the same
// relations.
//
// Exact association (optional, RelationsMetricOptions::readings). A log that keeps only some
// readings of the original recording, with stamps rounded to its print precision (Intel: 10 ms
// above 1000 s), cannot always say which original reading a scan is: nearest-in-time matching
// may pair a relation end with a scan although another reading of the recording lies nearer
// (Intel: a relation end at 1396.4854 s meets the scan printed 1396.48 s, but the reading
// printed 1396.49 s, 5° further into a turn, is nearer). Given every reading of the recording
// (stamp and a pose that tells readings apart, e.g. a CARMEN log's ODOM lines), an end falls
// on a trajectory pose only when the reading nearest to the relation time has that pose's
// stamp; an end whose nearest reading is not a trajectory pose is unmatched (counted in
// `on_other_reading`), and an end whose nearest reading shares its stamp with a reading of a
// different pose is ambiguous (counted in `ambiguous`); the stamp-based ambiguity rule above
// is then not applied (the readings tell the instants apart).
// With est = Between(pose(t1), pose(t2)):
//   translational error  e_t = |t(est) - t(delta)|                 (metres)
//   rotational error     e_r = |WrapAngle(theta(est) - theta(delta))| (reported in degrees)
// The result gives mean and standard deviation of e_t, e_r and of their squares over the
// matched relations (Kümmerle et al. report the absolute and the squared variants). Standard
// deviations are SAMPLE standard deviations (divide by N - 1; 0 when only one relation
// matched), which is what reproduces the published GMapping-on-Intel figure.
#ifndef HETSLAM_CORE_RELATIONS_H_
#define HETSLAM_CORE_RELATIONS_H_

#include <string>
#include <vector>

#include "core/se2.h"
#include "core/status.h"
#include "core/trajectory_io.h"

namespace hetslam {

struct Relation {
  double t1_seconds = 0.0;
  double t2_seconds = 0.0;
  Pose2 delta;          // robot(t1)_T_robot(t2): x, y in metres, yaw in radians
  int line_number = 0;  // in the file it was read from; 0 when built in code
};

// Reads a relations file (see above). A malformed line (not 8 fields, a non-numeric or
// non-finite field) is an error naming file and line; *relations is then empty.
Status ReadRelations(const std::string& path, std::vector<Relation>* relations);

struct RelationsMetricOptions {
  // Relation clock minus trajectory clock: t_trajectory = t_relation - clock_offset_seconds.
  // Intel: 976052857.337284 (see shared/datasets/README.md).
  double clock_offset_seconds = 0.0;
  // An end matches the trajectory pose nearest in time only if |dt| <= this.
  double match_tolerance_seconds = 0.006;
  // Exact association (see above): every reading of the original recording, stamps in the
  // trajectory clock, any order. Empty: nearest-pose association only.
  std::vector<StampedPose2> readings;
  // A reading and a trajectory pose are the same instant when their stamps differ by at most
  // this (well below the log's print precision).
  double same_stamp_tolerance_seconds = 1e-4;

  bool IsValid(std::string* error) const;
};

// Error of one matched relation.
struct RelationError {
  int relation_index = 0;  // into the relations vector given to EvaluateRelations
  int trajectory_index_1 = 0;  // matched poses, indices into the trajectory vector
  int trajectory_index_2 = 0;
  double trans_error_m = 0.0;
  double rot_error_deg = 0.0;  // absolute, >= 0
};

struct RelationsMetricResult {
  int total = 0;    // relations given
  int matched = 0;    // relations with both ends matched and unambiguous (scored)
  int ambiguous = 0;  // relations with both ends matched but one ambiguous (not scored)
  // With readings: relations not scored because an end's nearest reading is not a pose of the
  // trajectory (a reading the log does not keep as a scan).
  int on_other_reading = 0;
  // Statistics over the matched relations; all 0 when matched == 0. Standard deviations are
  // sample standard deviations (N - 1).
  double trans_mean_m = 0.0;
  double trans_std_m = 0.0;
  double rot_mean_deg = 0.0;
  double rot_std_deg = 0.0;
  double trans_sq_mean_m2 = 0.0;
  double trans_sq_std_m2 = 0.0;
  double rot_sq_mean_deg2 = 0.0;
  double rot_sq_std_deg2 = 0.0;
  double trans_median_m = 0.0;
  double rot_median_deg = 0.0;
  double trans_max_m = 0.0;
  double rot_max_deg = 0.0;
  std::vector<RelationError> errors;  // one per matched relation, in relation order
};

// Scores `trajectory` (any order; timestamps need not be sorted) against `relations`.
// CHECK-fails on invalid options (validate them with IsValid first).
RelationsMetricResult EvaluateRelations(const std::vector<StampedPose2>& trajectory,
                                        const std::vector<Relation>& relations,
                                        const RelationsMetricOptions& options);

}  // namespace hetslam

#endif  // HETSLAM_CORE_RELATIONS_H_
