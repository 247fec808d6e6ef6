// Scoring a run's map layers against the true layers of a simulated world (paper §III-E: walls,
// other structure, floor obstacles).
//
// Truth: a folder (DIR/truth_layers of a simulated team dataset, datasets/README.md) holding
// map_server maps in the WORLD frame named after the layers below (walls, furniture,
// floor_obstacles), all on one grid. Run: a folder holding map_server maps in the run's MAP
// frame (the frame of its trajectory, a robot's start pose), named after what they contain:
//
//   run file              scored against
//   map.pgm               walls ∪ furniture          (all structure used for localisation)
//   walls.pgm             walls
//   floor_obstacles.pgm   floor_obstacles
//   planner.pgm           walls ∪ furniture ∪ floor_obstacles
//
// Each `X.pgm` is read through its `X.yaml` (core/map_io.h, ReadMapPgmYaml); a run file that is
// absent is reported as absent, not as an error.
//
// A true layer's unknown cells (map_server's 205) lie inside a true footprint (a box's or a
// table top's interior): occupied by the object, but not on its outline, which is all a level
// 2D laser can see; a beam from above (a tilted head, a UAV) hits them. A run cell that falls
// on one is correct; they are not counted for recall.
//
// Metric: occupied cells only, with a tolerance of k cells (default 1). world_T_map maps the
// run's map frame into the world (AlignTrajectory of core/trajectory_metrics.h, the ATE
// alignment of the run's trajectory onto the truth). A run cell is correct when the truth cell
// containing world_T_map * (its centre) has an occupied truth cell within k cells in x and in y
// (its (2k+1)² neighbourhood on the truth grid), or is itself unknown (inside a footprint,
// above); precision = correct run cells / run occupied
// cells. Symmetrically a truth cell is found when the run cell containing map_T_world * (its
// centre) has an occupied run cell in its (2k+1)² neighbourhood on the run grid; recall =
// found truth cells / truth occupied cells. A neighbourhood may reach past the other grid's
// edge (beyond it the other side has no cell). Precision (recall) is NaN when the run (truth)
// has no occupied cell.
#ifndef HETSLAM_CORE_MAP_LAYERS_H_
#define HETSLAM_CORE_MAP_LAYERS_H_

#include <string>
#include <vector>

#include "core/map_io.h"
#include "core/se2.h"
#include "core/status.h"

namespace hetslam {

// File stems (without .pgm / .yaml) of the true layers and of the truth folder of a dataset.
constexpr char kTruthLayersFolder[] = "truth_layers";
// A robot's seen layers (DIR/<robot>/seen_layers of a simulated team dataset): the true layers
// restricted to the cells its laser returned from, same stems and grid.
constexpr char kSeenLayersFolder[] = "seen_layers";
constexpr char kWallsLayer[] = "walls";
constexpr char kFurnitureLayer[] = "furniture";
constexpr char kFloorObstaclesLayer[] = "floor_obstacles";

// One run layer and the true layers whose union it is scored against.
struct RunLayerSpec {
  std::string run_stem;                  // "map" for map.pgm / map.yaml
  std::vector<std::string> truth_stems;  // e.g. {"walls", "furniture"}
};

// The four run layers of the table above, in that order.
const std::vector<RunLayerSpec>& StandardRunLayers();

struct LayerScoreOptions {
  int tolerance_cells = 1;  // k above, in [0, 100]

  bool IsValid(std::string* error) const;
};

struct LayerScore {
  int run_occupied_cells = 0;
  int run_correct_cells = 0;     // run cells with a truth cell within tolerance
  int truth_occupied_cells = 0;
  int truth_found_cells = 0;     // truth cells with a run cell within tolerance

  double precision() const;  // run_correct / run_occupied; NaN without run cells
  double recall() const;     // truth_found / truth_occupied; NaN without truth cells
};

// Scores `run` (map frame) against `truth` (world frame) as described above. Any two
// resolutions work: each side's neighbourhood is taken on its own grid.
LayerScore ScoreLayer(const GridLayer& run, const Pose2& world_T_map, const GridLayer& truth,
                      const LayerScoreOptions& options);

// The occupied cells of `run` (map frame) on a true floor obstacle: within the tolerance of an
// occupied cell of `floor_obstacles` and not within it of an occupied (or inside-footprint) cell
// of `structure` (walls ∪ furniture: an obstacle against a wall cannot be told from the wall at
// that tolerance). Paper §III-E: floor obstacles break the 2.5D assumption and must stay out of
// the map localisation uses (map.pgm), so this should be 0. The two true layers on one grid.
int CountCellsOnFloorObstacles(const GridLayer& run, const Pose2& world_T_map, const GridLayer& floor_obstacles,
                               const GridLayer& structure, const LayerScoreOptions& options);

// The union of layers on one grid: a cell is occupied when it is occupied in any layer, else
// unknown when unknown in any (inside a footprint), free otherwise. An error when `layers` is empty or the grids differ (size, resolution, origin
// beyond 1e-6 of a cell); `names` (one per layer) name them in the message.
Status UnionOfLayers(const std::vector<GridLayer>& layers, const std::vector<std::string>& names,
                     GridLayer* union_layer);

struct RunLayerResult {
  RunLayerSpec spec;
  bool present = false;  // the run folder has <run_stem>.yaml
  std::string run_path;  // <run_dir>/<run_stem>.yaml
  LayerScore score;      // when present
  // When present and seen layers were given: the score against the seen true layers, of which
  // only the recall is reported (the run's cells outside them are not wrong).
  LayerScore seen;
};

struct RunLayersReport {
  std::string run_dir;
  std::string truth_dir;
  std::string seen_dir;  // empty: no seen layers
  Pose2 world_T_map;
  LayerScoreOptions options;
  std::vector<RunLayerResult> layers;  // StandardRunLayers() order, absent ones included
  // map.pgm's occupied cells on a true floor obstacle (CountCellsOnFloorObstacles); -1 when
  // map.pgm or the true floor_obstacles layer is absent.
  int map_on_floor_obstacles = -1;
};

// Scores every layer of StandardRunLayers() present in `run_dir` against the true layers of
// `truth_dir`. The true layers a present run layer needs must exist (an error names the
// missing file); a run folder with none of the run layers is an error naming the files looked
// for. A malformed map is an error naming its file. `seen_dir` non-empty: a robot's seen layers
// (kSeenLayersFolder, same stems), each present run layer is also scored against their union
// (RunLayerResult::seen: recall of what the robot's laser returned from).
Status ScoreRunLayers(const std::string& run_dir, const std::string& truth_dir,
                      const Pose2& world_T_map, const LayerScoreOptions& options,
                      RunLayersReport* report, const std::string& seen_dir = "");

// A fixed-width table, one row per layer (absent layers say so):
//   layer  truth  precision  recall  run_correct/run_occupied  truth_found/truth_occupied
// and, with seen layers, seen recall and seen_found/seen_occupied.
std::string FormatRunLayersTable(const RunLayersReport& report);

// The report as CSV with the header
//   layer,truth,status,precision,recall,run_occupied,run_correct,truth_occupied,truth_found,
//   tolerance_cells,seen_recall,seen_occupied,seen_found
// (the last three empty without seen layers), and, when map.pgm and the true floor obstacles are
// there, a last row `map_on_floor_obstacles,floor_obstacles,counted,,,N,M,,,k,,,`: map.pgm's N
// occupied cells, M of them on a true floor obstacle (RunLayersReport::map_on_floor_obstacles)
// (truth = the true layers joined by '+', status = scored or absent, empty numbers and
// "nan" precision/recall where there is nothing to count). An error names the file.
Status WriteRunLayersCsv(const RunLayersReport& report, const std::string& path);

}  // namespace hetslam

#endif  // HETSLAM_CORE_MAP_LAYERS_H_
