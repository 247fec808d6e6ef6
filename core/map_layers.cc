#include "core/map_layers.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <sstream>

#include "core/file_io.h"
#include "glog/logging.h"

namespace hetslam {
namespace {

// Whether `to` has an occupied cell within k cells (in x and in y) of cell c of its grid. The
// neighbourhood may reach past the edge of `to`: a cell just outside still matches the occupied
// cell on the edge. `inside_matches`: c on an unknown cell of `to` (inside a true footprint)
// matches.
bool NearOccupied(const GridLayer& to, const CellIndex& c, int k, bool inside_matches) {
  const GridGeometry& h = to.geometry;
  if (inside_matches && h.Contains(c) && to.at(c) == CellState::kUnknown) return true;
  for (int ny = std::max(0, c.y - k); ny <= std::min(h.height() - 1, c.y + k); ++ny) {
    for (int nx = std::max(0, c.x - k); nx <= std::min(h.width() - 1, c.x + k); ++nx) {
      if (to.at({nx, ny}) == CellState::kOccupied) return true;
    }
  }
  return false;
}

// Calls f(cell of `to` under its centre) for every occupied cell of `from`, with from's frame
// at to_T_from in to's.
template <typename F>
void ForEachOccupied(const GridLayer& from, const Pose2& to_T_from, const GridLayer& to, F f) {
  const GridGeometry& g = from.geometry;
  for (int y = 0; y < g.height(); ++y) {
    for (int x = 0; x < g.width(); ++x) {
      if (from.at({x, y}) == CellState::kOccupied) f(to.geometry.WorldToCell(to_T_from * g.CellCenter({x, y})));
    }
  }
}

// Counts the occupied cells of `from` and those whose centre, mapped by `to_T_from` into the
// frame of `to`, falls within k cells of an occupied cell of `to` (NearOccupied).
void CountMatches(const GridLayer& from, const Pose2& to_T_from, const GridLayer& to, int k, bool inside_matches,
                  int* occupied, int* matched) {
  *occupied = 0;
  *matched = 0;
  ForEachOccupied(from, to_T_from, to, [&](const CellIndex& c) {
    ++*occupied;
    if (NearOccupied(to, c, k, inside_matches)) ++*matched;
  });
}

double Ratio(int numerator, int denominator) {
  return denominator > 0 ? static_cast<double>(numerator) / denominator
                         : std::numeric_limits<double>::quiet_NaN();
}

std::string JoinTruth(const RunLayerSpec& spec, const char* separator) {
  std::string joined;
  for (size_t i = 0; i < spec.truth_stems.size(); ++i) {
    joined += (i > 0 ? separator : "") + spec.truth_stems[i];
  }
  return joined;
}

std::string FormatNumber(const char* format, double value) {
  if (std::isnan(value)) return "nan";
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), format, value);
  return buffer;
}

}  // namespace

const std::vector<RunLayerSpec>& StandardRunLayers() {
  static const std::vector<RunLayerSpec> layers = {
      {"map", {kWallsLayer, kFurnitureLayer}},
      {"walls", {kWallsLayer}},
      {"floor_obstacles", {kFloorObstaclesLayer}},
      {"planner", {kWallsLayer, kFurnitureLayer, kFloorObstaclesLayer}},
  };
  return layers;
}

bool LayerScoreOptions::IsValid(std::string* error) const {
  if (tolerance_cells < 0 || tolerance_cells > 100) {
    if (error != nullptr) {
      *error = "tolerance_cells must be in [0, 100] (got " + std::to_string(tolerance_cells) + ")";
    }
    return false;
  }
  return true;
}

double LayerScore::precision() const { return Ratio(run_correct_cells, run_occupied_cells); }
double LayerScore::recall() const { return Ratio(truth_found_cells, truth_occupied_cells); }

LayerScore ScoreLayer(const GridLayer& run, const Pose2& world_T_map, const GridLayer& truth,
                      const LayerScoreOptions& options) {
  std::string error;
  CHECK(options.IsValid(&error)) << "invalid LayerScoreOptions: " << error;
  CHECK_EQ(run.cells.size(), static_cast<size_t>(run.geometry.num_cells()));
  CHECK_EQ(truth.cells.size(), static_cast<size_t>(truth.geometry.num_cells()));
  LayerScore score;
  CountMatches(run, world_T_map, truth, options.tolerance_cells, /*inside_matches=*/true,
               &score.run_occupied_cells, &score.run_correct_cells);
  CountMatches(truth, world_T_map.inverse(), run, options.tolerance_cells, /*inside_matches=*/false,
               &score.truth_occupied_cells, &score.truth_found_cells);
  return score;
}

Status UnionOfLayers(const std::vector<GridLayer>& layers, const std::vector<std::string>& names,
                     GridLayer* union_layer) {
  CHECK(union_layer != nullptr);
  CHECK_EQ(layers.size(), names.size()) << "one name per layer";
  if (layers.empty()) return Status::Error("no layer to unite");
  const GridGeometry& g = layers[0].geometry;
  GridLayer result = GridLayer::Filled(g, CellState::kFree);
  for (size_t i = 0; i < layers.size(); ++i) {
    const GridGeometry& other = layers[i].geometry;
    const double r = g.resolution_meters();
    if (other.width() != g.width() || other.height() != g.height() ||
        std::abs(other.resolution_meters() - r) > 1e-9 * r ||
        (other.origin() - g.origin()).norm() > 1e-6 * r) {
      return Status::Error("layers '" + names[0] + "' and '" + names[i] +
                           "' are not on the same grid (size, resolution or origin differ)");
    }
    for (size_t c = 0; c < result.cells.size(); ++c) {
      if (layers[i].cells[c] == CellState::kOccupied) {
        result.cells[c] = CellState::kOccupied;
      } else if (layers[i].cells[c] == CellState::kUnknown && result.cells[c] == CellState::kFree) {
        result.cells[c] = CellState::kUnknown;
      }
    }
  }
  *union_layer = std::move(result);
  return Status::Ok();
}

int CountCellsOnFloorObstacles(const GridLayer& run, const Pose2& world_T_map, const GridLayer& floor_obstacles,
                               const GridLayer& structure, const LayerScoreOptions& options) {
  std::string error;
  CHECK(options.IsValid(&error)) << "invalid LayerScoreOptions: " << error;
  CHECK(floor_obstacles.geometry.width() == structure.geometry.width() &&
        floor_obstacles.geometry.height() == structure.geometry.height())
      << "the true layers are on one grid";
  const int k = options.tolerance_cells;
  int on = 0;
  ForEachOccupied(run, world_T_map, floor_obstacles, [&](const CellIndex& c) {
    if (NearOccupied(floor_obstacles, c, k, /*inside_matches=*/false) &&
        !NearOccupied(structure, c, k, /*inside_matches=*/true)) {
      ++on;
    }
  });
  return on;
}

namespace {

// The union of `stems` read from `dir` (an error names a missing or malformed file).
Status ReadUnion(const std::string& dir, const std::vector<std::string>& stems, GridLayer* layer) {
  std::vector<GridLayer> layers(stems.size());
  for (size_t i = 0; i < stems.size(); ++i) {
    HETSLAM_RETURN_IF_ERROR(ReadMapPgmYaml((std::filesystem::path(dir) / (stems[i] + ".yaml")).string(), &layers[i]));
  }
  return UnionOfLayers(layers, stems, layer);
}

}  // namespace

Status ScoreRunLayers(const std::string& run_dir, const std::string& truth_dir,
                      const Pose2& world_T_map, const LayerScoreOptions& options,
                      RunLayersReport* report, const std::string& seen_dir) {
  CHECK(report != nullptr);
  namespace fs = std::filesystem;
  std::string error;
  if (!options.IsValid(&error)) return Status::Error(error);
  RunLayersReport result;
  result.run_dir = run_dir;
  result.truth_dir = truth_dir;
  result.world_T_map = world_T_map;
  result.options = options;
  result.seen_dir = seen_dir;
  std::string looked_for;
  GridLayer map_run, map_truth;  // map.pgm and walls ∪ furniture, kept for the floor-obstacle count
  for (const RunLayerSpec& spec : StandardRunLayers()) {
    RunLayerResult layer;
    layer.spec = spec;
    const fs::path base = fs::path(run_dir) / spec.run_stem;
    layer.run_path = base.string() + ".yaml";
    const std::string pgm_path = base.string() + ".pgm";
    looked_for += (looked_for.empty() ? "" : ", ") + spec.run_stem + ".pgm";
    layer.present = fs::exists(layer.run_path) || fs::exists(pgm_path);
    if (layer.present) {
      GridLayer run;
      HETSLAM_RETURN_IF_ERROR(ReadMapPgmYaml(layer.run_path, &run));
      GridLayer truth;
      HETSLAM_RETURN_IF_ERROR(ReadUnion(truth_dir, spec.truth_stems, &truth));
      layer.score = ScoreLayer(run, world_T_map, truth, options);
      if (!seen_dir.empty()) {
        GridLayer seen;
        HETSLAM_RETURN_IF_ERROR(ReadUnion(seen_dir, spec.truth_stems, &seen));
        layer.seen = ScoreLayer(run, world_T_map, seen, options);
      }
      if (result.layers.empty()) {  // map.pgm, the first of StandardRunLayers()
        map_run = std::move(run);
        map_truth = std::move(truth);
      }
    }
    result.layers.push_back(std::move(layer));
  }
  // The localisation map against the true floor obstacles (when both are there).
  const RunLayerResult& map = result.layers.front();
  const fs::path obstacles_yaml = fs::path(truth_dir) / (std::string(kFloorObstaclesLayer) + ".yaml");
  if (map.present && fs::exists(obstacles_yaml)) {
    GridLayer obstacles;
    HETSLAM_RETURN_IF_ERROR(ReadUnion(truth_dir, {kFloorObstaclesLayer}, &obstacles));
    GridLayer all;  // (only to check that the true layers lie on one grid)
    HETSLAM_RETURN_IF_ERROR(UnionOfLayers({obstacles, map_truth}, {kFloorObstaclesLayer, "walls + furniture"}, &all));
    result.map_on_floor_obstacles = CountCellsOnFloorObstacles(map_run, world_T_map, obstacles, map_truth, options);
  }
  if (std::none_of(result.layers.begin(), result.layers.end(),
                   [](const RunLayerResult& l) { return l.present; })) {
    return Status::Error("'" + run_dir + "' holds none of the run layers (" + looked_for + ")");
  }
  *report = std::move(result);
  return Status::Ok();
}

std::string FormatRunLayersTable(const RunLayersReport& report) {
  std::ostringstream out;
  char line[256];
  const bool seen = !report.seen_dir.empty();
  std::snprintf(line, sizeof(line), "%-20s %-36s %9s %9s %21s %21s%s\n", "layer", "truth",
                "precision", "recall", "run correct/occupied", "truth found/occupied",
                seen ? "  seen recall    seen found/occupied" : "");
  out << line;
  for (const RunLayerResult& layer : report.layers) {
    const std::string name = layer.spec.run_stem + ".pgm";
    const std::string truth = JoinTruth(layer.spec, " + ");
    if (!layer.present) {
      std::snprintf(line, sizeof(line), "%-20s %-36s %9s\n", name.c_str(), truth.c_str(),
                    "absent");
    } else {
      const LayerScore& s = layer.score;
      const std::string run_counts =
          std::to_string(s.run_correct_cells) + "/" + std::to_string(s.run_occupied_cells);
      const std::string truth_counts =
          std::to_string(s.truth_found_cells) + "/" + std::to_string(s.truth_occupied_cells);
      std::string seen_columns;
      if (seen) {
        const std::string seen_counts =
            std::to_string(layer.seen.truth_found_cells) + "/" + std::to_string(layer.seen.truth_occupied_cells);
        char columns[64];
        std::snprintf(columns, sizeof(columns), "  %11s %22s", FormatNumber("%.4f", layer.seen.recall()).c_str(),
                      seen_counts.c_str());
        seen_columns = columns;
      }
      std::snprintf(line, sizeof(line), "%-20s %-36s %9s %9s %21s %21s%s\n", name.c_str(),
                    truth.c_str(), FormatNumber("%.4f", s.precision()).c_str(),
                    FormatNumber("%.4f", s.recall()).c_str(), run_counts.c_str(),
                    truth_counts.c_str(), seen_columns.c_str());
    }
    out << line;
  }
  if (report.map_on_floor_obstacles >= 0) {
    out << "map.pgm on true floor obstacles: " << report.map_on_floor_obstacles << " of "
        << report.layers.front().score.run_occupied_cells
        << " occupied cells (within the tolerance of a floor obstacle, not of walls or furniture; the "
           "localisation map should hold none)\n";
  }
  return out.str();
}

Status WriteRunLayersCsv(const RunLayersReport& report, const std::string& path) {
  std::ostringstream csv;
  csv << "layer,truth,status,precision,recall,run_occupied,run_correct,truth_occupied,"
         "truth_found,tolerance_cells,seen_recall,seen_occupied,seen_found\n";
  for (const RunLayerResult& layer : report.layers) {
    csv << layer.spec.run_stem << "," << JoinTruth(layer.spec, "+") << ",";
    if (!layer.present) {
      csv << "absent,,,,,,," << report.options.tolerance_cells << ",,,\n";
      continue;
    }
    const LayerScore& s = layer.score;
    csv << "scored," << FormatNumber("%.6f", s.precision()) << ","
        << FormatNumber("%.6f", s.recall()) << "," << s.run_occupied_cells << ","
        << s.run_correct_cells << "," << s.truth_occupied_cells << "," << s.truth_found_cells
        << "," << report.options.tolerance_cells << ",";
    if (report.seen_dir.empty()) {
      csv << ",,\n";
    } else {
      csv << FormatNumber("%.6f", layer.seen.recall()) << "," << layer.seen.truth_occupied_cells << ","
          << layer.seen.truth_found_cells << "\n";
    }
  }
  if (report.map_on_floor_obstacles >= 0) {
    csv << "map_on_floor_obstacles," << kFloorObstaclesLayer << ",counted,,,"
        << report.layers.front().score.run_occupied_cells << "," << report.map_on_floor_obstacles << ",,,"
        << report.options.tolerance_cells << ",,,\n";
  }
  const std::string text = csv.str();
  return WriteFileBytes(path, text.data(), text.size());
}

}  // namespace hetslam
