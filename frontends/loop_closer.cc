#include "frontends/loop_closer.h"

#include <algorithm>
#include <chrono>
#include <sstream>
#include <utility>
#include <vector>

#include "glog/logging.h"

namespace hetslam {

ScanMatcherOptions LoopCloserOptions::DefaultMatcherOptions() {
  ScanMatcherOptions options;
  options.linear_search_window_meters = 2.0;                    // paper §III-A: 2 m radius
  options.angular_search_window_radians = 45.0 * M_PI / 180.0;  // paper §III-A: ±45°
  options.min_correlative_score = 0.5;
  // The front end's depth (ScanMatcherOptions' default): the matchers of a thread share
  // their tables (ScanMatcher::ReleaseScratch), and a deeper loop search added an 8-bit level
  // that every front-end search then freed and every loop search allocated again. Depth 5
  // found the same closures (the four real logs, the 55 scenario runs and the teams' runs
  // byte-identical).
  options.branch_and_bound_depth = 4;
  // The window is the whole loop-closure search: no wider retry.
  options.fallback_linear_search_window_meters = 0.0;
  options.fallback_angular_search_window_radians = 0.0;
  // A degenerate closure (a corridor) lies up to metres off along its flat direction, where it
  // weighs little; across it, it claims sin(error of that direction) of the offset. The
  // profile's direction is good to several degrees (its directions are 11.25° apart), the
  // scan's walls to a fraction of one: on wheeled_corridor (seeds 1-5, default) the largest
  // error a degenerate closure claimed across went 0.065-0.178 -> 0.018-0.063 m against the
  // truth (README, "Degenerate closures along the walls").
  options.weak_direction_snap_radians = 11.25 * M_PI / 180.0;
  return options;
}

ScanMatcherOptions LoopCloserOptions::DefaultWideMatcherOptions() {
  ScanMatcherOptions options = DefaultMatcherOptions();
  // No motion prior: the point of the wide search is a pose far from the estimate.
  options.translation_penalty_per_square_meter = 0.0;
  options.rotation_penalty_per_square_radian = 0.0;
  options.branch_and_bound_depth = 6;
  return options;
}

bool LoopCloserOptions::IsValid(std::string* error) const {
  std::ostringstream msg;
  std::string sub;
  if (!matcher.IsValid(&sub)) msg << "matcher: " << sub;
  if (!wide_matcher.IsValid(&sub)) msg << "wide_matcher: " << sub;
  if (!(wide_window_meters <= 50)) msg << "wide_window_meters must be <= 50 (got " << wide_window_meters << "); ";
  if (!(wide_window_meters > 0 && wide_angular_window_radians > 0 && wide_search_spacing_meters >= 0 &&
        wide_agreement_meters > 0 && wide_agreement_radians > 0))
    msg << "wide search windows and agreement bounds must be > 0, its spacing >= 0; ";
  if (!(wide_min_score >= 0 && wide_min_score < 1)) msg << "wide_min_score must be in [0, 1); ";
  if (!(agreeing_min_score >= 0 && agreeing_min_score < 1 && agreeing_meters >= 0 && agreeing_radians >= 0))
    msg << "agreeing_min_score must be in [0, 1), agreeing_meters and agreeing_radians >= 0; ";
  if (!(min_score >= 0 && min_score < 1)) msg << "min_score must be in [0, 1); ";
  if (!(degenerate_max_drop_ratio >= 0 && degenerate_max_drop_ratio < 1))
    msg << "degenerate_max_drop_ratio must be in [0, 1); ";
  if (!(search_min_travel_meters >= 0 && search_min_turn_radians >= 0))
    msg << "search travel/turn thresholds must be >= 0; ";
  if (min_node_separation < 0) msg << "min_node_separation must be >= 0; ";
  if (max_submaps_per_search < 0) msg << "max_submaps_per_search must be >= 0; ";
  if (!(gate_base_meters >= 0 && gate_meters_per_meter >= 0 && gate_base_radians >= 0 && gate_radians_per_meter >= 0))
    msg << "gate parameters must be >= 0; ";
  if (error != nullptr) *error = msg.str();
  return msg.str().empty();
}

namespace {

// The standard search's matcher with its branch and bound's floor at `floor` (the agreeing search).
ScanMatcherOptions WithFloor(ScanMatcherOptions options, double floor) {
  if (floor > 0) options.min_correlative_score = std::min(options.min_correlative_score, floor);
  return options;
}

// Two nodes' corrections of the graph's estimate (world frame) agree within the bounds.
bool SameCorrection(const Pose2& a, const Pose2& b, double meters, double radians) {
  const Pose2 disagreement = Between(a, b);
  return disagreement.translation().norm() <= meters && std::abs(disagreement.theta()) <= radians;
}

}  // namespace

LoopCloser::LoopCloser(const LoopCloserOptions& options)
    : options_(options),
      matcher_(options.matcher),
      wide_matcher_(options.wide_matcher),
      agreeing_matcher_(WithFloor(options.matcher, options.agreeing_min_score)) {
  std::string error;
  CHECK(options_.IsValid(&error)) << "invalid LoopCloserOptions: " << error;
}

void LoopCloser::AddTravel(double meters) {
  travel_since_solve_meters_ += meters;
  travel_since_wide_search_meters_ += meters;
  travel_meters_ += meters;
}

LoopSearchResult LoopCloser::Search(const SubmapGraph& graph, const NodeId& node) {
  LoopSearchResult result;
  if (node.index >= 0) {
    if (static_cast<size_t>(node.index) >= node_travel_meters_.size()) node_travel_meters_.resize(node.index + 1, -1.0);
    node_travel_meters_[node.index] = travel_meters_;
  }
  const Pose2& local_pose = graph.NodeLocalPose(node);
  if (last_search_pose_.has_value()) {
    const Pose2 moved = Between(*last_search_pose_, local_pose);
    if (moved.translation().norm() < options_.search_min_travel_meters &&
        std::abs(moved.theta()) < options_.search_min_turn_radians) {
      return result;
    }
  }
  last_search_pose_ = local_pose;
  const auto start = std::chrono::steady_clock::now();
  // The gate rejects any closure farther from the estimate than the drift since the last
  // solve allows, so the search window need not reach beyond it (same result, less work).
  const double travel = travel_since_solve_meters_;
  const double gate_meters = options_.gate_base_meters + options_.gate_meters_per_meter * travel;
  const double gate_radians = options_.gate_base_radians + options_.gate_radians_per_meter * travel;
  const double linear_window = std::min(options_.matcher.linear_search_window_meters, gate_meters);
  const double angular_window = std::min(options_.matcher.angular_search_window_radians, gate_radians);
  SearchSubmaps(graph, node, linear_window, angular_window, gate_meters, gate_radians, options_.min_score,
                options_.matcher.linear_search_window_meters, &result.closures, nullptr);
  if (!result.closures.empty()) {
    pending_wide_.reset();
  } else if (gate_meters > options_.matcher.linear_search_window_meters &&
             travel_since_wide_search_meters_ >= options_.wide_search_spacing_meters &&
             (options_.wide_search || options_.agreeing_min_score > 0)) {
    travel_since_wide_search_meters_ = 0.0;
    if (options_.agreeing_min_score > 0) {
      AgreeingSearch(graph, node, linear_window, angular_window, gate_meters, gate_radians, &result);
    }
    if (options_.wide_search && result.closures.empty()) WideSearch(graph, node, gate_meters, gate_radians, &result);
  }
  stats_.search_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

void LoopCloser::AgreeingSearch(const SubmapGraph& graph, const NodeId& node, double linear_window,
                                double angular_window, double gate_meters, double gate_radians,
                                LoopSearchResult* result) {
  std::optional<WideCandidate> best;
  const int searches_before = stats_.searches;
  SearchSubmaps(graph, node, linear_window, angular_window, gate_meters, gate_radians, options_.agreeing_min_score,
                options_.matcher.linear_search_window_meters, nullptr, &best, &agreeing_matcher_);
  stats_.agreeing_searches += stats_.searches - searches_before;
  stats_.searches = searches_before;
  if (!best.has_value()) return;
  ++stats_.agreeing_candidates;
  if (pending_agreeing_.has_value() && pending_agreeing_->closure.node != node &&
      SameCorrection(pending_agreeing_->world_correction, best->world_correction, options_.agreeing_meters,
                     options_.agreeing_radians)) {
    result->closures.push_back(pending_agreeing_->closure);
    result->closures.push_back(best->closure);
    stats_.agreeing_accepted += 2;
    pending_agreeing_.reset();
    result->solve_now = true;
    return;
  }
  pending_agreeing_ = best;
}

void LoopCloser::WideSearch(const SubmapGraph& graph, const NodeId& node, double gate_meters, double gate_radians,
                            LoopSearchResult* result) {
  std::optional<WideCandidate> best;
  const double window = std::min(gate_meters, options_.wide_window_meters);
  // The wide search grows the matchers' tables (one set per thread, frontends/scan_matcher.h
  // ReleaseScratch) to its ±8 m window; they are kept until the next solve frees them, as the
  // standard search's are. Freeing them after each wide search that grew them made the front
  // end's next search fault its tables in again, at ~11 us a page on this machine's VM (session
  // 37: without that release, page faults Intel 68 -> 57 thousand, FR079 94 -> 66, MIT CSAIL
  // 100 -> 66, ACES 84 -> 71; peak RSS +0.5 MiB on Intel, ACES and MIT CSAIL, -0.2 on FR079).
  SearchSubmaps(graph, node, window, std::min(gate_radians, options_.wide_angular_window_radians), gate_meters,
                gate_radians, options_.wide_min_score, window, nullptr, &best);
  if (!best.has_value()) return;
  ++stats_.wide_candidates;
  // One wide match may be an alias (a corridor, a repeated room); two matches of different
  // nodes that call for the same correction of the drifting estimate are taken as real.
  if (pending_wide_.has_value() && pending_wide_->closure.node != node) {
    if (SameCorrection(pending_wide_->world_correction, best->world_correction, options_.wide_agreement_meters,
                       options_.wide_agreement_radians)) {
      // Confirmed closures enter without robust loss: they are metres from the estimate, where
      // the Huber loss of ordinary closures would leave them almost no pull. Alone against
      // the whole chain they leave a few degrees of residual, so the solve that brings them in
      // does not check them; the ordinary closures the corrected estimate then finds decide.
      for (ConstraintCandidate closure : {pending_wide_->closure, best->closure}) {
        closure.robust = false;
        closure.exempt_from_next_check = true;
        result->closures.push_back(closure);
      }
      stats_.wide_accepted += 2;
      pending_wide_.reset();
      result->solve_now = true;
      return;
    }
  }
  pending_wide_ = best;
}

void LoopCloser::SearchSubmaps(const SubmapGraph& graph, const NodeId& node, double linear_window,
                               double angular_window, double gate_meters, double gate_radians, double min_score,
                               double margin_meters, std::vector<ConstraintCandidate>* closures,
                               std::optional<WideCandidate>* wide_best, const ScanMatcher* best_matcher) {
  const Pose2 robot_T_node = graph.NodePose(node);
  const SubmapGraph::MatchingPoints matching = graph.NodeMatchingPoints(node, options_.refine_on_all_points);
  const std::vector<Eigen::Vector2f>& points = matching.points;
  const std::vector<float>& weights = matching.weights;
  const int num_submaps = graph.num_submaps(node.robot);
  // The candidates, best first: the most overlap (the node's points near the submap's
  // structure at the estimate), then the node's estimate nearest the submap's trajectory box,
  // then the older submap.
  struct Gate {
    double meters, radians;                 // accepted correction
    double linear_window, angular_window;  // searched
  };
  // The submap's gate: narrower than the drift since the solve when a closure since then
  // measured the estimate's offset from it (standard search only; degenerate closures do not
  // measure it). The wide search's: narrower when the submap began after the solve, its
  // estimate chained to the node's over less travel than that since the solve.
  const bool wide = wide_best != nullptr && best_matcher == nullptr;
  auto gate_for = [&](int s) {
    Gate gate{gate_meters, gate_radians, linear_window, angular_window};
    if (wide) {
      const int first = graph.SubmapFirstNode({node.robot, s});
      const bool searched = first >= 0 && static_cast<size_t>(first) < node_travel_meters_.size() &&
                            node_travel_meters_[first] >= 0;
      if (!searched) return gate;
      const double travel = std::min(travel_since_solve_meters_, travel_meters_ - node_travel_meters_[first]);
      gate.meters = std::min(gate_meters, options_.gate_base_meters + options_.gate_meters_per_meter * travel);
      gate.radians = std::min(gate_radians, options_.gate_base_radians + options_.gate_radians_per_meter * travel);
      gate.linear_window = std::min(linear_window, gate.meters);
      gate.angular_window = std::min(angular_window, gate.radians);
      return gate;
    }
    const auto it = measured_.find(s);
    if (wide_best != nullptr || it == measured_.end()) return gate;
    const double travel = travel_since_solve_meters_ - it->second.travel_since_solve_meters;
    gate.meters = std::min(gate_meters, options_.gate_base_meters + it->second.meters + options_.gate_meters_per_meter * travel);
    gate.radians =
        std::min(gate_radians, options_.gate_base_radians + it->second.radians + options_.gate_radians_per_meter * travel);
    gate.linear_window = std::min(linear_window, gate.meters);
    gate.angular_window = std::min(angular_window, gate.radians);
    return gate;
  };
  struct Candidate {
    double overlap;  // computed only when the budget must choose
    double distance;
    int index;
    Pose2 predicted;  // submap_T_node
    Gate gate;
    bool operator<(const Candidate& o) const {
      if (overlap != o.overlap) return overlap > o.overlap;
      if (distance != o.distance) return distance < o.distance;
      return index < o.index;
    }
  };
  std::vector<Candidate> candidates;
  for (int s = 0; s < num_submaps; ++s) {
    const SubmapId submap{node.robot, s};
    if (graph.FinishedSubmapMap(submap) == nullptr) continue;
    // The front end built this submap moments ago: the intra-submap chain already ties the
    // node to it, a closure would add little but cost a search.
    if (node.index - graph.SubmapLastNode(submap) < options_.min_node_separation) continue;
    const Gate gate = gate_for(s);
    // A wide search of a submap whose drift bound is within the standard window: the standard
    // search (which found nothing) had that window.
    if (wide && gate.meters <= options_.matcher.linear_search_window_meters) {
      ++stats_.wide_within_standard;
      continue;
    }
    // Only submaps the node could be inside: its estimated position within the box of the
    // submap's own trajectory, grown by the search window (the wide search: the submap's).
    const double margin = wide ? std::min(margin_meters, gate.linear_window) : margin_meters;
    const Eigen::Vector2d p = (graph.SubmapPose(submap).inverse() * robot_T_node).translation();
    Eigen::Vector2d box_min, box_max;
    graph.SubmapBox(submap, &box_min, &box_max);
    if ((p.array() < box_min.array() - margin).any() || (p.array() > box_max.array() + margin).any()) {
      continue;
    }
    // No pose the gate admits can score min_score (the node's scan does not reach enough of
    // the submap's structure): no search; its result would be rejected (exact). Before the
    // budget, so that the budget goes to submaps that can give a closure.
    const Pose2 predicted = graph.SubmapPose(submap).inverse() * robot_T_node;
    if (ReachableScoreBound(*graph.FinishedSubmapMap(submap), predicted, points, weights, gate.meters, gate.radians,
                            min_score) < min_score) {
      ++stats_.searches_without_overlap;
      continue;
    }
    const Eigen::Vector2d outside = (box_min - p).cwiseMax(p - box_max).cwiseMax(0.0);
    candidates.push_back({0.0, outside.norm(), s, predicted, gate});
  }
  const size_t budget = static_cast<size_t>(options_.max_submaps_per_search);
  if (budget > 0 && candidates.size() > budget) {
    // The overlap: the share of the points within a tile (8 cells) of the submap's structure,
    // unmoved.
    for (Candidate& c : candidates) {
      c.overlap = ReachableScoreBound(*graph.FinishedSubmapMap({node.robot, c.index}), c.predicted, points, weights,
                                      0.0, 0.0);
    }
    std::sort(candidates.begin(), candidates.end());
    stats_.submaps_skipped += static_cast<int>(candidates.size() - budget);
    candidates.resize(budget);
    std::sort(candidates.begin(), candidates.end(),
              [](const Candidate& a, const Candidate& b) { return a.index < b.index; });
  }
  for (const Candidate& candidate : candidates) {
    const int s = candidate.index;
    const SubmapId submap{node.robot, s};
    const LaserMap* map = graph.FinishedSubmapMap(submap);
    const Pose2 robot_T_submap = graph.SubmapPose(submap);
    const Pose2& predicted = candidate.predicted;
    const ScanMatcher& matcher =
        wide_best == nullptr ? matcher_ : best_matcher != nullptr ? *best_matcher : wide_matcher_;
    ++(wide_best != nullptr && best_matcher == nullptr ? stats_.wide_searches : stats_.searches);
    const Gate& gate = candidate.gate;
    const ScanMatchResult match =
        matcher.MatchWithinWindow(*map, predicted, points, gate.linear_window, gate.angular_window, weights, min_score,
                                  matching.all.empty() ? nullptr : &matching.all);
    if (!match.converged || match.score < min_score) continue;
    const Pose2 correction = Between(predicted, match.pose);
    if (correction.translation().norm() > gate.meters || std::abs(correction.theta()) > gate.radians) {
      ++stats_.rejected_by_gate;
      continue;
    }
    const bool degenerate = options_.degenerate_max_drop_ratio > 0 && match.strong_direction_score_drop > 0 &&
                            match.weak_direction_score_drop <
                                options_.degenerate_max_drop_ratio * match.strong_direction_score_drop;
    ConstraintCandidate closure;
    closure.submap = submap;
    closure.node = node;
    closure.submap_T_node = match.pose;
    closure.score = match.score;
    if (degenerate) {
      ++stats_.degenerate;
      if (wide_best != nullptr) continue;
      closure.weak_direction = match.weak_direction;
      // Continuous at the threshold: a result just flat enough to be degenerate keeps nearly
      // the full information.
      closure.weak_information_fraction = match.weak_direction_score_drop /
                                          (options_.degenerate_max_drop_ratio * match.strong_direction_score_drop);
    }
    if (wide_best != nullptr) {
      if (!wide_best->has_value() || match.score > (*wide_best)->closure.score) {
        const Pose2 matched = robot_T_submap * match.pose;
        *wide_best = WideCandidate{closure, matched * robot_T_node.inverse()};
      }
      continue;
    }
    if (!degenerate) {
      measured_[s] = {correction.translation().norm(), std::abs(correction.theta()), travel_since_solve_meters_};
    }
    closures->push_back(closure);
  }
}

}  // namespace hetslam
