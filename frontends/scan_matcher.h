// Scan-to-map matching (paper §III-C): a branch-and-bound correlative search around a
// predicted pose over the likelihood-field lookup table, followed by a Ceres refinement
// with the scan-to-likelihood-field cost (factors/scan_cost.h).
//
// Correlative search. Candidate poses are (yaw_k, t + (dx, dy) * r) for yaw steps k and whole
// cell offsets (dx, dy) within the windows; a candidate's score is the weighted mean over its
// points of T(c), where T = L (the likelihood field) except that cells of known free space
// with L = 0 hold -free_space_penalty, minus a weak motion prior
// a |t - t_pred|^2 + b (yaw - yaw_pred)^2. Branch and bound over a pyramid of max-pooled
// tables M_h(c) = max_{0 <= a, b < 2^h} T(c + (a, b)) finds the best-scoring candidate exactly
// (the mean over M_h, less the prior of the block's offset nearest the prediction, bounds
// every candidate of a 2^h × 2^h block), visiting a small fraction of the candidates. The
// search is exact with respect to that discretisation; Ceres then removes the discretisation
// error. A failed, weak or window-border result is searched again over wider windows.
//
// Walls weigh more (paper §III-E, ScanMatcherOptions::wall_weight = w > 1, on a map that keeps
// a wall field, core/laser_map.h): L above becomes L + (w - 1) L_wall in the tables T, with
// L_wall the likelihood field of the map's wall cells alone read at the same cell, so a point
// placed on a wall scores w, on other structure 1, at whatever pose the candidate puts it;
// correlative_score is in those units. With wall_weight_in_refinement the refinement weighs
// walls too: a second Ceres cost over the wall field (residual weights sqrt(w - 1), read at the
// same interpolated position), and the acceptance test, `information` and the score profile
// use the weighted objective (bilinear). `score` is always the mean of L, so the thresholds on
// it (narrow_accept_score, fallback_below_score, the callers') keep their calibration. With
// w = 1, or a map without a wall field, nothing changes.
#ifndef HETSLAM_FRONTENDS_SCAN_MATCHER_H_
#define HETSLAM_FRONTENDS_SCAN_MATCHER_H_

#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "Eigen/Core"
#include "core/laser_map.h"
#include "core/se2.h"
#include "factors/scan_cost.h"

namespace hetslam {

struct ScanMatcherOptions {
  double linear_search_window_meters = 1.2;     // ± around the prediction, in x and y
  double angular_search_window_radians = 0.70;  // ± around the predicted yaw (≈ 40°)
  // Yaw step of the search; 0 picks it from the scan so that the 90th-percentile point
  // moves by at most one cell per step, clamped to [min, max] below.
  double angular_step_radians = 0.0;
  double min_angular_step_radians = 0.0025;
  double max_angular_step_radians = 0.0175;
  int branch_and_bound_depth = 4;               // coarsest block is 2^depth cells
  double min_correlative_score = 0.10;          // below: the match failed
  // Subtracted from the score for each point that lands in known free space away from any
  // hit: scans shifted along a corridor put their end-wall points into free space.
  double free_space_penalty = 0.5;
  // Weak motion prior: score -= a * |t - t_pred|^2 + b * (yaw - yaw_pred)^2.
  double translation_penalty_per_square_meter = 0.05;
  double rotation_penalty_per_square_radian = 0.0;
  // A match that fails, scores below `fallback_below_score` or lands on the border of the
  // window is searched again over these wider windows (sharp turns of sparse logs without
  // odometry); the better-scoring result is kept.
  double fallback_below_score = 0.35;
  double fallback_linear_search_window_meters = 2.0;
  double fallback_angular_search_window_radians = 1.6;  // ≈ 92°
  // Narrow first try (0 disables): search these smaller windows first and keep the result
  // when it scores at least `narrow_accept_score` and lies inside the narrow window (not on
  // its border); otherwise search the full windows. Dense logs, whose predictions are good,
  // then skip most of the full search. Pitfall: after a large unpredicted motion (sparse logs)
  // a wrong pose inside the narrow window can score well, so the caller enables the narrow
  // try only while recent motion is small (see Match).
  double narrow_linear_search_window_meters = 0.0;
  double narrow_angular_search_window_radians = 0.0;
  double narrow_accept_score = 0.5;
  // Second mode (0 disables): after the best candidate, the best discrete candidate farther
  // than second_mode_exclusion_meters (in x or y) or second_mode_exclusion_radians from it is
  // searched too (ScanMatchResult::second_mode_*): a scan that fits two places of the map
  // about equally (a symmetric room, a repeated corridor) is ambiguous there. Doubles the search.
  double second_mode_exclusion_meters = 0.0;
  double second_mode_exclusion_radians = 0.0;
  // The same for Match's full-window and fallback searches only (0 disables; when set, these
  // replace the exclusions above there): the front end's wide searches, run where the
  // prediction was not trusted (a gap between scans, a sharp turn without odometry), are where a
  // scan can fit two places; the narrow try, and MatchWithinWindow, do not search for one.
  double wide_second_mode_exclusion_meters = 0.0;
  double wide_second_mode_exclusion_radians = 0.0;
  // ... and only a second mode scoring at least this fraction of the best is looked for there
  // (0: any above min_correlative_score): the search then prunes every block that cannot reach
  // it (measured: without it, the second search doubled the front end's matching time on Intel
  // and MIT CSAIL, most of whose scans are matched by a wide search).
  double wide_second_mode_min_score_ratio = 0.0;
  bool refine_with_ceres = true;
  // What the Ceres refinement interpolates between cell centres (factors/scan_cost.h): the
  // field's values, or its distances (the kernel then peaks on each wall, not on the cell grid).
  // Distances by default (issue #12): the standing humanoid meets its 2 cm / 0.5° and Intel,
  // FR079, ACES improve; MIT CSAIL's two-mode match at scan 325, which used to decide it (12.2 m
  // against GMapping), is left to the particle filter (ParticleFilterOptions::spawn_on_second_mode).
  ScanCostInterpolation refine_interpolation = ScanCostInterpolation::kDistances;
  // Paper §III-E: the weight of the map's wall channel, w in [1, 100] (see the top of this
  // file); 1 = off. Needs a map built with LaserMap's keep_wall_field.
  double wall_weight = 1.0;
  // ... also in the refinement. Off: measured on the simulated team (seeds 1-5, w = 2), the
  // wall field's pull in the refinement cost team_overlap's drone 0.018 -> 0.024 m (worst
  // seed; every seed worse), with it in the search alone 0.019 m. Likely cause (not proven):
  // the labelled wall cells are a patchy subset of a wall (a cell is a wall once hit across a
  // height span), and the refinement's smooth kernel of a patchy field pulls along the wall
  // towards the labelled patches, where the search's cell-wise scores barely do.
  bool wall_weight_in_refinement = false;
  double profile_step_meters = 0.1;  // see ScanMatchResult::weak_direction_score_drop
  // The score profile's flat direction (ScanMatchResult::weak_direction) replaced by the
  // direction of the scan's surfaces (WallAxis) when the two are within this angle: the
  // profile's sixteen directions are 11.25° apart, and a degenerate loop closure 1 m off along
  // a corridor claims sin(error) of it across. 0 = off.
  double weak_direction_snap_radians = 0.0;
  // The refinement's stopping rule (Ceres' max_num_iterations and function_tolerance: it stops
  // when a step changes the cost by less than this fraction). On Intel a fifth of the
  // refinements run to the iteration limit, their last steps moving the pose by well under a
  // millimetre, yet the real logs' figures move when these change (README, "How far the
  // real-log figures move"): they are the knobs of tests/bench/run_sensitivity.sh.
  int max_ceres_iterations = 20;
  double refine_function_tolerance = 1e-6;

  bool IsValid(std::string* error) const;
};

struct ScanMatchResult {
  Pose2 pose;                    // world_T_robot after matching
  bool converged = false;        // the search found a pose scoring >= min_correlative_score
  // Weighted mean of the search's objective (L, or with a wall weight L + (w - 1) L_wall) at
  // the best discrete candidate.
  double correlative_score = 0;
  double score = 0;              // weighted mean field value L (bilinear) at `pose`, no wall weight
  int iterations = 0;            // Ceres iterations
  double final_cost = 0;         // Ceres final cost
  int candidates_scored = 0;     // branch-and-bound work
  Eigen::Matrix3d information = Eigen::Matrix3d::Zero();  // J^T J of the scan cost at `pose`
  // The score's profile around `pose` (with a refinement; zero without), in the refinement's
  // units (with wall_weight_in_refinement, L + (w - 1) L_wall), on the refinement's points
  // (every k-th of them when they outnumber the searched ones, see Match): the drop of a
  // direction is the objective (bilinear) at `pose` minus its best at shifts of ±1 to ±3 profile steps
  // (ScanMatcherOptions::profile_step_meters) along it; of sixteen directions 11.25° apart, the
  // one with the smallest drop (unit, map frame; its angle refined by a parabola through its
  // neighbours' drops), that drop and the largest. A weak drop near
  // 0, or small next to the strong one: the map cannot place the scan along that direction (a
  // featureless corridor, where the weak drop is the noise of the wall hits). The profile, not
  // `information`: in a corridor the latter is mostly that noise, and its least-informed
  // direction is sometimes the one across the walls.
  Eigen::Vector2d weak_direction = Eigen::Vector2d::Zero();
  double weak_direction_score_drop = 0.0;
  double strong_direction_score_drop = 0.0;
  // With ScanMatcherOptions::second_mode_exclusion_* (or wide_second_mode_exclusion_* for a
  // wide search of Match): the best discrete candidate outside the exclusion around the best
  // one (score 0 and the prediction when none scores >= min_correlative_score there, or for a
  // wide search >= wide_second_mode_min_score_ratio of the best).
  // `wide_search`: the result comes from Match's full-window or fallback search.
  double second_mode_correlative_score = 0.0;
  Pose2 second_mode_pose;
  bool wide_search = false;
  std::string message;           // why it did not converge
};

// The weighted mean likelihood-field value (bilinear) of `points_robot` placed by `pose` in the
// map: ScanMatchResult::score without a search (no wall weight). `weights` empty or one per point.
double ScoreAt(const LaserMap& map, const Pose2& pose, const std::vector<Eigen::Vector2f>& points_robot,
               const std::vector<float>& weights = {});
// An upper bound on ScoreAt at every pose whose offset from `pose` (in `pose`'s frame) is at
// most `max_translation_meters` and `max_rotation_radians`: the weighted share of the points
// that could meet a non-zero field value there (LikelihoodField::MayBeNonZeroNear, to the 8 × 8
// tile), taken per sector of yaws 0.04 rad wide, the best sector's. Stops at the first sector
// that reaches `enough` (then returns its bound, >= enough). 1 for a field not yet frozen. A
// loop search whose bound is below its minimum score cannot succeed and is skipped (issue #15).
double ReachableScoreBound(const LaserMap& map, const Pose2& pose, const std::vector<Eigen::Vector2f>& points_robot,
                           const std::vector<float>& weights, double max_translation_meters,
                           double max_rotation_radians, double enough = 1.0);

// Not thread-safe: searches reuse per-thread buffers (see ReleaseScratch), so use one
// ScanMatcher per thread, and a search must not start another.
class ScanMatcher {
 public:
  explicit ScanMatcher(const ScanMatcherOptions& options);

  // Matches `points_robot` (robot frame, metres) against the map's likelihood field (and its
  // free space, for the penalty) around `predicted` (world_T_robot). `weights` empty or one
  // per point. The map must not change during the call.
  // `try_narrow_first`: allow the narrow first try (when its windows are set); callers pass
  // false when the prediction is not trusted to be that close (large recent motion).
  // `refinement_points` (non-empty, with empty `weights`): the same scan thinned otherwise
  // (LocalSlamOptions::refine_on_middle_beams) or not at all (refine_on_all_points), for the
  // refinement of the pose the search found and its `information` and score profile (the
  // profile on every k-th of them when they outnumber `points_robot`, as many as those at
  // most); `score` stays on `points_robot`.
  ScanMatchResult Match(const LaserMap& map, const Pose2& predicted,
                        const std::vector<Eigen::Vector2f>& points_robot,
                        const std::vector<float>& weights = {}, bool try_narrow_first = true,
                        const std::vector<Eigen::Vector2f>* refinement_points = nullptr) const;

  // One search within the given windows (instead of the options' windows), without the wider
  // fallback search. A refined result whose score is below `min_score` (a caller that rejects
  // such results: the loop closer) is returned as soon as its score is known, without
  // `information` and the score profile (weak/strong direction); its pose and score are the same.
  // `refinement_points` as for Match.
  ScanMatchResult MatchWithinWindow(const LaserMap& map, const Pose2& predicted,
                                    const std::vector<Eigen::Vector2f>& points_robot,
                                    double linear_window_meters, double angular_window_radians,
                                    const std::vector<float>& weights = {}, double min_score = 0.0,
                                    const std::vector<Eigen::Vector2f>* refinement_points = nullptr) const;

  // Refines `start` (world_T_robot) by the likelihood field's cost (L alone: the wall channel
  // is not weighed here, whatever wall_weight_in_refinement says) with the translation along
  // `held_direction` (map frame, non-zero) kept at `start`'s: across it and in yaw the scan
  // decides (factors/se2_manifold.h Se2HeldDirectionManifold). For a match that is flat along
  // that direction while a motion source knows the position there (LocalSlam's degeneracy
  // handling): a search's pull along the flat direction cannot leak into the other two. The
  // refined pose is returned only when it scores (bilinear) at least as well as `start` and
  // moved less than four cells; otherwise `start`.
  Pose2 RefineHoldingDirection(const LaserMap& map, const Pose2& start, const Eigen::Vector2d& held_direction,
                               const std::vector<Eigen::Vector2f>& points_robot,
                               const std::vector<float>& weights = {}) const;

  // Refines `start` (world_T_robot) by the likelihood field's cost (L alone) with no
  // acceptance test: the refined pose when Ceres' solution is usable and moved less than four
  // cells and `max_rotation_radians` from `start`; nullopt otherwise (no points, no field).
  std::optional<Pose2> Refine(const LaserMap& map, const Pose2& start, const std::vector<Eigen::Vector2f>& points_robot,
                              const std::vector<float>& weights, double max_rotation_radians) const;

  // Exhaustive evaluation of every discrete candidate (for tests of the branch and bound);
  // returns the best as `pose` with its correlative score.
  ScanMatchResult BruteForceSearch(const LaserMap& map, const Pose2& predicted,
                                   const std::vector<Eigen::Vector2f>& points_robot,
                                   const std::vector<float>& weights = {}) const;

  const ScanMatcherOptions& options() const { return options_; }

  // The search's table buffers are shared by every ScanMatcher of the calling thread (a front
  // end and a loop closer, or a team's robots, never search at once) and keep the size of the
  // largest search so far (region cells × (3 + branch_and_bound_depth) bytes: 16 bits for the
  // leaves and for level 1, 8 for each coarser level; MBs for a loop closer's wide window). This
  // frees them; the next search of any matcher of the thread allocates them again, at once at
  // the largest size they have had (unwritten cells of a large buffer take no memory). After a
  // rare search over a large window, and before a solve (which does not read them). Tables of
  // 8 MiB or more (a wide search's) are also given back to the system at once (glibc:
  // malloc_trim), not left resident in the heap.
  static void ReleaseScratch();
  // Keeps resident the pages of the calling thread's tables up to the largest table the
  // searches since the last trim (or release) asked for, gives the rest back to the system
  // (madvise) and frees the scratch vectors; returns ScratchBytes() after it.
  static size_t TrimScratch();
  // Before a solve, which reads no table: with `keep_recent_pages`, TrimScratch, so that the
  // next searches do not fault the pages in again (9-12 µs a page on the VMs measured: Intel's
  // page faults 28.8 -> 20.2 thousand) -- unless the process's resident memory is within the
  // kept bytes of its peak so far (core/process_memory.h; the solver's scratch could then raise
  // the peak next to them) or cannot be read: then, and without `keep_recent_pages`,
  // ReleaseScratch. Returns whether pages were kept.
  static bool ShrinkScratchForSolve(bool keep_recent_pages);
  // Bytes the calling thread's tables may hold resident: the cells searches asked for since
  // their buffers were allocated, and the scratch vectors.
  size_t ScratchBytes() const;

 private:
  // Whether `pose` lies on the border of a window around `predicted` (within 0.1 m or two
  // maximum yaw steps of its edge): then the best may be the clipped side of a peak outside.
  bool OnWindowBorder(const Pose2& predicted, const Pose2& pose, double linear_window_meters,
                      double angular_window_radians) const;
  // `to_beat`: only a discrete best scoring above it less one code step of the search tables
  // counts (else the result is not converged): the fallback search after a converged full
  // search, whose best no pose scoring less can displace.
  ScanMatchResult MatchOnce(const LaserMap& map, const Pose2& predicted,
                            const std::vector<Eigen::Vector2f>& points_robot, const std::vector<float>& weights,
                            const std::vector<Eigen::Vector2f>* refinement_points, double linear_window_meters, double angular_window_radians,
                            double second_mode_exclusion_meters, double second_mode_exclusion_radians,
                            double second_mode_min_score_ratio = 0.0, double min_score = 0.0,
                            double to_beat = -std::numeric_limits<double>::infinity()) const;

  ScanMatcherOptions options_;
};

}  // namespace hetslam

#endif  // HETSLAM_FRONTENDS_SCAN_MATCHER_H_
