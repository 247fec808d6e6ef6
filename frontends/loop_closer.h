// Loop closure search (paper §III-A: "loop closure ... by scan-matching" within a bounded
// window): matches a new node against the finished submaps of its robot and returns the
// closures it finds as candidates; the caller adds them to the submap graph.
//
// Standard search: every finished submap at least `min_node_separation` nodes old whose box
// (grown by the window) holds the node's estimate and that can reach min_score within the gate
// (at most max_submaps_per_search of them, those the node's scan overlaps most), within ±window
// around the graph's estimate,
// narrowed to the drift gate: a closure is accepted only if it moves the node by at most
// base + rate * (distance travelled since the graph was last solved) — drift grows with travel,
// aliases (corridors, repeated rooms) need not. Once a closure to a submap measured how far the
// estimate is off that submap (since the last solve), its gate is base + that offset + rate *
// (distance travelled since), if narrower (issue #15: a robot re-driving mapped space searches
// the submaps it keeps closing against in small windows). Searches run again only after the
// robot moved `search_min_travel_meters` or turned `search_min_turn_radians`.
//
// Wide search (long corridors): once the drift bound exceeds the window and the standard search
// found nothing, the node is also searched over ±min(drift bound, wide_window_meters) and
// ±min(angular bound, wide_angular_window_radians) without motion prior, at most once per
// wide_search_spacing_meters of travel. Each submap's drift bound there is the smaller of
// that and the bound from the travel since the submap began (its estimate is chained to the
// node's over that travel); a submap whose bound is within the standard window is left out
// (the standard search had that window: FR079's wide matches 108 -> 51, the same closures).
// A wide result (score >= wide_min_score, within the bound) is only a candidate until a wide
// result of a later node confirms it: their corrections of the graph's estimate (world frame)
// agree within wide_agreement_*; then both are returned without robust loss, exempt from the
// next consistency check, and the caller is asked to solve at once (a correction of metres must
// reach the next nodes' estimates).
//
// Agreeing search (opt-in, agreeing_min_score): where the wide search would run, the node is
// also matched in the standard window down to a lower score (a revisit seen the other way
// round overlaps the old submap in part); two nodes' results that call for the same correction
// become ordinary closures.
#ifndef HETSLAM_FRONTENDS_LOOP_CLOSER_H_
#define HETSLAM_FRONTENDS_LOOP_CLOSER_H_

#include <cmath>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "frontends/scan_matcher.h"
#include "frontends/submap_graph.h"

namespace hetslam {

struct LoopCloserOptions {
  ScanMatcherOptions matcher = DefaultMatcherOptions();
  double min_score = 0.55;                // mean likelihood at the refined pose
  double search_min_travel_meters = 0.3;  // search again only after moving this far
  double search_min_turn_radians = 0.35;  // ... or turning this much
  // Submaps whose last scan is fewer than this many nodes old are not searched.
  int min_node_separation = 40;
  double gate_base_meters = 0.3;
  double gate_meters_per_meter = 0.1;
  double gate_base_radians = 0.1;
  double gate_radians_per_meter = 0.02;
  bool wide_search = true;
  ScanMatcherOptions wide_matcher = DefaultWideMatcherOptions();
  double wide_window_meters = 8.0;
  double wide_angular_window_radians = M_PI;
  double wide_min_score = 0.6;
  double wide_search_spacing_meters = 1.0;
  double wide_agreement_meters = 0.3;
  double wide_agreement_radians = 0.05;
  // Revisits seen the other way round (issue #14): a robot driving back along its way looks at
  // what its first submaps there had behind them, and its right match overlaps them only in
  // part: it scores below min_score (the simulated office loop's last stretch, mirrored: 0.34 -
  // 0.47 against the first submaps, node after node, every one calling for the same 0.22 m /
  // 0.8 degree correction; nothing closed the loop and the run ended 0.08 m off, ATE). Where
  // the wide search would run (no closure, the drift bound beyond the standard window, once per
  // wide_search_spacing_meters) the node is also searched in the standard window with the
  // branch and bound's floor at agreeing_min_score; its best result scoring at least that
  // (non-degenerate, within the gate) is a candidate until a later node's candidate calls for
  // the same correction of the graph's estimate (world frame, within agreeing_meters /
  // agreeing_radians); then both are closures (robust, checked like any other) and the caller
  // solves at once. 0 = off, the default: with the first beams' refinement (the default until
  // session 51, see LocalSlamOptions::refine_on_all_points) the office loop's seed 1 went 0.030 ->
  // 0.120 m (its closures right, its submaps turned inside); with refine_on_all_points (the
  // default now) the office loop and its mirror image are within 0.048 m on seeds 1-5 (0.084
  // without it; README, "Mirrored worlds"). 0.35: examples/flags/unbiased.flags.
  double agreeing_min_score = 0.0;
  double agreeing_meters = 0.05;
  double agreeing_radians = 0.01;
  // A match whose score drops, along its flattest direction, by less than this fraction of
  // its steepest drop (ScanMatchResult::weak_direction_score_drop: a corridor's walls) places
  // the node poorly along that direction: the closure's information along it shrinks with the
  // drop (ConstraintCandidate::weak_information_fraction = the drop ratio / this, so it is
  // continuous here), and a wide result is not a candidate at all (its correction is along
  // the corridor). Measured (seeds 1-5, worst ATE): wheeled_corridor 0.309 m off (closures at
  // the ends of a 22 m leg were 0.3-0.7 m off along it and tore the graph; the front end
  // alone: 0.07 m), 0.076 m at 0.05, 0.075 m at 0.1, 0.074 m at 0.25; uav_flight (a 20 m
  // corridor whose closures are 0.05-0.6 m off along it but right on average) 0.067 m off,
  // 0.072, 0.074 and 0.079 m. 0 = off.
  double degenerate_max_drop_ratio = 0.1;
  // Each match refined on every point of the node's scan, not only the searched ones
  // (LocalSlamOptions::refine_on_all_points for the front end, on by default too; hetslam_run's
  // --refine_on_all_points sets both).
  bool refine_on_all_points = true;
  // Loop search within a budget (issue #15): each search matches the node against at most this
  // many finished submaps (0 = every one whose box holds the node; a robot re-driving mapped
  // space has more of them each time round), so that a search costs the same however long the
  // run. Submaps no pose within the gate can score min_score against are never searched
  // (ReachableScoreBound: exact); of the rest, those whose structure the node's scan overlaps
  // most at its estimate, then the nearest (distance to the submap's trajectory box), then the
  // older. On by default since session 12 (README, "Loop search: searches that cannot succeed
  // are skipped").
  int max_submaps_per_search = 4;

  // ±2 m / ±45° (paper §III-A), no wider retry.
  static ScanMatcherOptions DefaultMatcherOptions();
  // The same without motion prior, a deeper branch and bound (6).
  static ScanMatcherOptions DefaultWideMatcherOptions();
  bool IsValid(std::string* error) const;
};

struct LoopCloserStats {
  int searches = 0;            // (node, submap) matches attempted
  int submaps_skipped = 0;     // candidate submaps beyond max_submaps_per_search
  // Matches not run: no pose within the gate could reach the minimum score
  // (ReachableScoreBound), so the result would have been rejected.
  int searches_without_overlap = 0;
  int rejected_by_gate = 0;
  int wide_searches = 0;       // (node, submap) matches over the wide window
  int wide_within_standard = 0;  // submaps the wide search left out: their drift bound within the standard window
  int wide_candidates = 0;     // wide results above the score, within the bound
  int wide_accepted = 0;       // confirmed wide candidates
  int agreeing_searches = 0;   // (node, submap) matches with the floor at agreeing_min_score
  int agreeing_candidates = 0; // their results that became candidates
  int agreeing_accepted = 0;   // closures from two agreeing candidates
  int degenerate = 0;          // results flat along a direction (held across it only; wide: dropped)
  double search_seconds = 0.0;
};

struct LoopSearchResult {
  std::vector<ConstraintCandidate> closures;
  bool solve_now = false;  // a confirmed wide correction: solve before the next node
};

class LoopCloser {
 public:
  // CHECK-fails on invalid options.
  explicit LoopCloser(const LoopCloserOptions& options);

  // Distance the robot moved (grows the drift gate) and that a solve happened (resets it).
  void AddTravel(double meters);
  void OnSolve() {
    travel_since_solve_meters_ = 0.0;
    measured_.clear();
    pending_agreeing_.reset();  // its correction was of the estimate before the solve
  }

  // Searches for closures of `node` (just added to `graph`) against its robot's finished submaps.
  LoopSearchResult Search(const SubmapGraph& graph, const NodeId& node);

  const LoopCloserStats& stats() const { return stats_; }
  const LoopCloserOptions& options() const { return options_; }

 private:
  struct WideCandidate {
    ConstraintCandidate closure;
    Pose2 world_correction;  // matched pose relative to the graph's estimate, robot frame
  };
  // Matches the node against every finished, old-enough submap whose box (grown by
  // `margin_meters`) holds its estimate. Appends closures scoring >= min_score within the gate
  // to *closures; with `wide_best`, uses `best_matcher` (agreeing_matcher_; null: wide_matcher_)
  // and keeps only the best result there.
  void SearchSubmaps(const SubmapGraph& graph, const NodeId& node, double linear_window, double angular_window,
                     double gate_meters, double gate_radians, double min_score, double margin_meters,
                     std::vector<ConstraintCandidate>* closures, std::optional<WideCandidate>* wide_best,
                     const ScanMatcher* best_matcher = nullptr);
  void WideSearch(const SubmapGraph& graph, const NodeId& node, double gate_meters, double gate_radians,
                  LoopSearchResult* result);
  // The search of agreeing_min_score (see the option): a candidate, or two agreeing ones as closures.
  void AgreeingSearch(const SubmapGraph& graph, const NodeId& node, double linear_window, double angular_window,
                      double gate_meters, double gate_radians, LoopSearchResult* result);

  LoopCloserOptions options_;
  ScanMatcher matcher_;
  ScanMatcher wide_matcher_;
  ScanMatcher agreeing_matcher_;  // matcher with its floor at agreeing_min_score
  std::optional<Pose2> last_search_pose_;  // local frame
  double travel_since_solve_meters_ = 0.0;
  // Per submap, the estimate's offset from it that a closure measured since the last solve
  // (the correction it made) and the travel since the solve then: the estimate of later nodes
  // is chained from the same unsolved poses, so its offset from that submap is as large plus
  // the drift since, and that submap's gate (and search window) is no wider.
  struct MeasuredOffset {
    double meters = 0.0;
    double radians = 0.0;
    double travel_since_solve_meters = 0.0;
  };
  std::map<int, MeasuredOffset> measured_;
  // The robot's travel since its first node, and at each node searched (index: the node's;
  // -1 for one never searched): the drift between a node and a submap is bounded by the travel
  // from the submap's first node as well as by the travel since the solve (WideSearch).
  double travel_meters_ = 0.0;
  std::vector<double> node_travel_meters_;
  double travel_since_wide_search_meters_ = 0.0;
  std::optional<WideCandidate> pending_wide_;
  std::optional<WideCandidate> pending_agreeing_;
  LoopCloserStats stats_;
};

}  // namespace hetslam

#endif  // HETSLAM_FRONTENDS_LOOP_CLOSER_H_
