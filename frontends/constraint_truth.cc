#include "frontends/constraint_truth.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "core/file_io.h"

namespace hetslam {
namespace {

// The truth pose nearest `stamp` within `tolerance` (truth in stamp order); null when none.
const StampedPose2* TruthAt(const std::vector<StampedPose2>& truth, double stamp, double tolerance) {
  auto it = std::lower_bound(truth.begin(), truth.end(), stamp,
                             [](const StampedPose2& p, double t) { return p.stamp_seconds < t; });
  const StampedPose2* best = nullptr;
  if (it != truth.end()) best = &*it;
  if (it != truth.begin() && (best == nullptr || stamp - (it - 1)->stamp_seconds < best->stamp_seconds - stamp)) {
    best = &*(it - 1);
  }
  if (best == nullptr || std::abs(best->stamp_seconds - stamp) > tolerance) return nullptr;
  return best;
}

double Median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  const size_t mid = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + mid, values.end());
  if (values.size() % 2 == 1) return values[mid];
  const double upper = values[mid];
  return 0.5 * (upper + *std::max_element(values.begin(), values.begin() + mid));
}

}  // namespace

std::vector<ConstraintTruthError> ConstraintTruthErrors(const SubmapGraph& graph,
                                                        const std::map<int, std::vector<StampedPose2>>& truth_by_robot,
                                                        double match_tolerance_seconds) {
  std::vector<ConstraintTruthError> errors;
  // Each submap is placed once, whatever number of constraints it holds.
  struct Placed {
    bool ok = false;
    Pose2 world_T_submap;
    int aligned = 0;
    double rmse = 0.0;
  };
  std::map<std::pair<int, int>, Placed> placed;
  auto place = [&](const SubmapId& submap) -> const Placed& {
    const auto key = std::make_pair(submap.robot, submap.index);
    const auto found = placed.find(key);
    if (found != placed.end()) return found->second;
    Placed& p = placed[key];
    const auto truth = truth_by_robot.find(submap.robot);
    if (truth == truth_by_robot.end() || truth->second.empty()) return p;
    // The submap's nodes in its frame as the front end put them, and their truth. The rotation is
    // the circular mean of the heading differences (a submap spans a few metres at most, a
    // standing humanoid's a few centimetres: its positions fix a rotation poorly, its headings
    // well), then the translation that brings the positions' centroids together.
    std::vector<std::pair<Pose2, Pose2>> pairs;  // (submap_T_node inserted, world_T_node truth)
    for (int k = graph.SubmapFirstNode(submap); k >= 0 && k <= graph.SubmapLastNode(submap); ++k) {
      Pose2 submap_T_node;
      if (!graph.IntraSubmapPose({submap.robot, k}, submap, &submap_T_node)) continue;
      const StampedPose2* world_T_node = TruthAt(truth->second, graph.NodeStamp({submap.robot, k}), match_tolerance_seconds);
      if (world_T_node != nullptr) pairs.emplace_back(submap_T_node, world_T_node->pose);
    }
    if (pairs.size() < 2) return p;
    double sin_sum = 0.0, cos_sum = 0.0;
    for (const auto& [inserted, truth_pose] : pairs) {
      const double d = truth_pose.theta() - inserted.theta();
      sin_sum += std::sin(d);
      cos_sum += std::cos(d);
    }
    const double rotation = std::atan2(sin_sum, cos_sum);
    const Eigen::Rotation2Dd r(rotation);
    Eigen::Vector2d shift = Eigen::Vector2d::Zero();
    for (const auto& [inserted, truth_pose] : pairs) shift += truth_pose.translation() - r * inserted.translation();
    shift /= static_cast<double>(pairs.size());
    const Pose2 world_T_submap(shift, rotation);
    double squared = 0.0;
    for (const auto& [inserted, truth_pose] : pairs) {
      squared += ((world_T_submap * inserted).translation() - truth_pose.translation()).squaredNorm();
    }
    p.world_T_submap = world_T_submap;
    p.aligned = static_cast<int>(pairs.size());
    p.rmse = std::sqrt(squared / static_cast<double>(pairs.size()));
    p.ok = true;
    return p;
  };
  for (const LoopClosureReport& report : graph.LoopClosures()) {
    const auto truth = truth_by_robot.find(report.node.robot);
    if (truth == truth_by_robot.end()) continue;
    const double stamp = graph.NodeStamp(report.node);
    const StampedPose2* world_T_node = TruthAt(truth->second, stamp, match_tolerance_seconds);
    if (world_T_node == nullptr) continue;
    const Placed& submap = place(report.submap);
    if (!submap.ok) continue;
    ConstraintTruthError e;
    e.submap = report.submap;
    e.node = report.node;
    e.kind = report.kind;
    e.score = report.score;
    e.removed = report.removed;
    e.stamp_seconds = stamp;
    const Pose2 true_submap_T_node = submap.world_T_submap.inverse() * world_T_node->pose;
    e.error = Between(true_submap_T_node, report.measured_submap_T_node);
    e.weak_direction = report.weak_direction;
    Eigen::Vector2d offset = report.measured_submap_T_node.translation() - true_submap_T_node.translation();
    if (e.weak_direction.squaredNorm() > 0) offset -= offset.dot(e.weak_direction) * e.weak_direction;
    e.claimed_translation_meters = offset.norm();
    e.submap_nodes_aligned = submap.aligned;
    e.submap_fit_rmse_meters = submap.rmse;
    errors.push_back(e);
  }
  return errors;
}

ConstraintTruthSummary SummarizeConstraintTruth(const std::vector<ConstraintTruthError>& errors) {
  ConstraintTruthSummary summary;
  summary.count = static_cast<int>(errors.size());
  if (errors.empty()) return summary;
  std::vector<double> translations, rotations;
  double signed_sum = 0.0;
  for (const ConstraintTruthError& e : errors) {
    const double t = e.claimed_translation_meters, r = std::abs(e.error.theta()) * 180.0 / M_PI;
    translations.push_back(t);
    rotations.push_back(r);
    summary.max_translation_meters = std::max(summary.max_translation_meters, t);
    summary.max_rotation_degrees = std::max(summary.max_rotation_degrees, r);
    signed_sum += e.error.theta() * 180.0 / M_PI;
  }
  summary.median_translation_meters = Median(translations);
  summary.median_rotation_degrees = Median(rotations);
  summary.mean_signed_rotation_degrees = signed_sum / static_cast<double>(errors.size());
  return summary;
}

Status WriteConstraintTruthErrors(const std::string& path, const std::vector<ConstraintTruthError>& errors,
                                  const std::vector<std::string>& robot_names) {
  auto name = [&robot_names](int robot) {
    return robot >= 0 && robot < static_cast<int>(robot_names.size()) ? robot_names[robot] : std::to_string(robot);
  };
  std::ostringstream out;
  out << "# submap_robot node_robot kind submap node stamp score error_x error_y error_theta submap_nodes "
         "submap_fit_rmse removed weak_x weak_y claimed_error\n"
         "# each constraint's measured submap_T_node against the truth: the submap placed in the world by its own\n"
         "# nodes (their poses in it as inserted, SE(2)-aligned to their truth), the node at its truth; error =\n"
         "# true^-1 * measured in the node's frame (metres, radians); submap_nodes aligned, their fit rmse (m);\n"
         "# removed = 1 when a solve's consistency check or a withdrawal took it out; weak = the direction\n"
         "# (submap frame) a degenerate constraint measured little along, 0 0 for none; claimed_error = the\n"
         "# translation error across it (m), what the constraint claims\n";
  out.precision(6);
  for (const ConstraintTruthError& e : errors) {
    std::string kind = EdgeKindName(e.kind);
    std::replace(kind.begin(), kind.end(), ' ', '_');
    out << name(e.submap.robot) << ' ' << name(e.node.robot) << ' ' << kind << ' ' << e.submap.index << ' '
        << e.node.index << ' ' << e.stamp_seconds << ' ' << e.score << ' ' << e.error.x() << ' ' << e.error.y() << ' '
        << e.error.theta() << ' ' << e.submap_nodes_aligned << ' ' << e.submap_fit_rmse_meters << ' '
        << (e.removed ? 1 : 0) << ' ' << e.weak_direction.x() << ' ' << e.weak_direction.y() << ' '
        << e.claimed_translation_meters << '\n';
  }
  const std::string text = out.str();
  return WriteFileBytes(path, text.data(), text.size());
}

}  // namespace hetslam
