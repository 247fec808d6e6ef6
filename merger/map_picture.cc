#include "merger/map_picture.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <sstream>

#include "core/file_io.h"
#include "core/laser_scan.h"
#include "core/map_io.h"
#include "core/plugin_loader.h"
#include "glog/logging.h"
#include "merger/map_picture_plugin.h"

namespace hetslam {
namespace {

// Sub-pixel precision of the anti-aliased drawing calls (coordinates are scaled by 2^bits).
constexpr double kShiftScale = 1 << map_picture_plugin::kSubpixelBits;
constexpr Rgb kBlack = {0, 0, 0};
constexpr Rgb kWhite = {255, 255, 255};
constexpr Rgb kConstraintLineRgb = {70, 70, 70};
constexpr Rgb kPanelLineRgb = {160, 160, 160};
constexpr Rgb kNoteTextRgb = {90, 90, 90};

// The process's drawing plugin (merger/map_picture_plugin.h), loaded with the first picture
// (thread-safe: a function-local static); null, with why in `tried`, when none loads.
const LoadedPluginTable& DrawingPlugin() {
  static const LoadedPluginTable plugin = LoadPluginTable(
      PluginCandidatePaths(map_picture_plugin::kPathVariable,
                           {HETSLAM_PICTURE_PLUGIN_BUILD_PATH, HETSLAM_PICTURE_PLUGIN_INSTALL_PATH}),
      map_picture_plugin::kEntryPointName, &CallPluginEntryPoint<MapPicturePluginApi>, "hetslam map picture plugin",
      [](const void* table) {
        const auto& api = *static_cast<const MapPicturePluginApi*>(table);
        return PluginBuildMismatch(api.abi_version, map_picture_plugin::kAbiVersion, api.layout_fingerprint,
                                   map_picture_plugin::LayoutFingerprint(), api.compiler);
      },
      // As when OpenCV was linked: OpenCV's symbols bound as they are called (binding all of
      // them at once made Intel's run, whose peak is its picture, 0.4 MiB heavier).
      PluginBinding::kLazy);
  return plugin;
}

// A point in picture pixels: whole, or in 1/2^kSubpixelBits pixels for anti-aliased strokes.
struct Point {
  int x = 0;
  int y = 0;
  bool operator!=(const Point& other) const { return x != other.x || y != other.y; }
};

// OpenCV's drawing calls (through the plugin) on an RGB picture or a rectangle of one. The
// picture is held in RGB order, as the PNG stores it (the drawing calls do not care what the
// channels mean): no conversion before writing. A canvas may hold a band of the picture's rows,
// from `first_row` on (the picture is drawn and written a band at a time: issue #15, Intel's
// peak RSS was its picture): every call takes picture coordinates, and drawing clips to the band.
class Canvas {
 public:
  Canvas(const MapPicturePluginApi* api, const PictureView& view, int first_row = 0)
      : api_(api), view_(view), first_row_(first_row) {}

  // The picture's top-left `width` x `height` pixels (of those this band holds), to which drawing
  // then clips.
  Canvas TopLeft(int width, int height) const {
    PictureView view = view_;
    view.width = std::min(width, view_.width);
    view.height = std::clamp(height - first_row_, 0, view_.height);
    return Canvas(api_, view, first_row_);
  }
  // Whether picture row `row` is in this band.
  bool HasRow(int row) const { return row >= first_row_ && row < first_row_ + view_.height; }
  void FillRow(int row, int begin, int end, const Rgb& color) {
    if (!HasRow(row)) return;
    uint8_t* pixel = view_.data + (row - first_row_) * view_.step + 3 * static_cast<size_t>(begin);
    for (int x = begin; x < end; ++x, pixel += 3) std::memcpy(pixel, color.data(), 3);
  }
  // Row `to` as row `from` over the first `width` pixels (both in this band).
  void CopyRow(int from, int to, int width) {
    std::memcpy(view_.data + (to - first_row_) * view_.step, view_.data + (from - first_row_) * view_.step,
                static_cast<size_t>(width) * 3);
  }

  // Anti-aliased, sub-pixel points; a negative thickness fills.
  void Circle(Point centre, int radius, const Rgb& color, int thickness) {
    if (empty()) return;
    api_->circle(&view_, centre.x, centre.y - SubpixelRows(), radius, color.data(), thickness,
                 PictureStroke::kAntiAliasedSubpixel);
  }
  void FillConvexPolygon(const std::vector<Point>& corners, const Rgb& color) {
    if (corners.empty() || empty()) return;
    const std::vector<int32_t> xy = Flat(corners, SubpixelRows());
    api_->fill_convex_polygon(&view_, xy.data(), static_cast<int>(corners.size()), color.data(),
                              PictureStroke::kAntiAliasedSubpixel);
  }
  void Polyline(const std::vector<Point>& points, bool closed, const Rgb& color, int thickness) {
    if (points.empty() || empty()) return;
    const std::vector<int32_t> xy = Flat(points, SubpixelRows());
    api_->polyline(&view_, xy.data(), static_cast<int>(points.size()), closed, color.data(), thickness,
                   PictureStroke::kAntiAliasedSubpixel);
  }
  void Rectangle(Point corner, Point opposite, const Rgb& color, int thickness) {
    if (empty()) return;
    api_->rectangle(&view_, corner.x, corner.y - SubpixelRows(), opposite.x, opposite.y - SubpixelRows(), color.data(),
                    thickness, PictureStroke::kAntiAliasedSubpixel);
  }
  void Line(Point from, Point to, const Rgb& color, int thickness) {
    if (empty()) return;
    api_->line(&view_, from.x, from.y - SubpixelRows(), to.x, to.y - SubpixelRows(), color.data(), thickness,
               PictureStroke::kAntiAliasedSubpixel);
  }
  // Whole pixels, aliased: the `width` x `height` box from (x, y) (nothing when empty), a line.
  void PixelBox(int x, int y, int width, int height, const Rgb& color, int thickness) {
    if (width <= 0 || height <= 0 || empty()) return;
    api_->rectangle(&view_, x, y - first_row_, x + width - 1, y - first_row_ + height - 1, color.data(), thickness,
                    PictureStroke::kWholePixels);
  }
  void PixelLine(Point from, Point to, const Rgb& color, int thickness) {
    if (empty()) return;
    api_->line(&view_, from.x, from.y - first_row_, to.x, to.y - first_row_, color.data(), thickness,
               PictureStroke::kWholePixels);
  }
  // Anti-aliased text in the Hershey simplex font; `origin` (whole pixels) is the left end of
  // the baseline.
  void Text(const std::string& text, Point origin, double font_scale, const Rgb& color, int thickness) {
    if (empty()) return;
    api_->put_text(&view_, text.c_str(), origin.x, origin.y - first_row_, font_scale, color.data(), thickness);
  }

 private:
  bool empty() const { return view_.width <= 0 || view_.height <= 0; }
  int SubpixelRows() const { return first_row_ * (1 << map_picture_plugin::kSubpixelBits); }
  // (x, y) pairs, as the plugin takes them, `dy` taken from every y.
  static std::vector<int32_t> Flat(const std::vector<Point>& points, int dy) {
    std::vector<int32_t> xy;
    xy.reserve(2 * points.size());
    for (const Point& p : points) xy.insert(xy.end(), {p.x, p.y - dy});
    return xy;
  }

  const MapPicturePluginApi* api_;
  PictureView view_;
  int first_row_ = 0;
};

constexpr int kFilled = -1;
// The picture is drawn and written in bands of about this many bytes (PngRowWriter).
constexpr size_t kBandBytes = size_t{512} << 10;
constexpr int kBandMarginRows = 16;

// Our pixel centres (MapPictureLayout) are at +0.5, the drawing calls' at integer coordinates.
Point Fixed(const Eigen::Vector2d& pixel) {
  return {static_cast<int>(std::lround((pixel.x() - 0.5) * kShiftScale)),
          static_cast<int>(std::lround((pixel.y() - 0.5) * kShiftScale))};
}
int FixedLength(double pixels) { return static_cast<int>(std::lround(pixels * kShiftScale)); }

std::string Error(const std::string& path, const std::string& why) {
  return "cannot write map picture '" + path + "': " + why;
}

// Which cell classes the map part shows (for the legend).
struct Shown {
  bool wall = false, structure = false, obstacle = false, free = false, unknown = false;
};

// Text measures at the picture's decoration scale.
struct TextStyle {
  const MapPicturePluginApi* api = nullptr;
  double font_scale = 0.5;
  int thickness = 1;
  int height = 14;  // pixels

  int Width(const std::string& text) const { return api->text_width(text.c_str(), font_scale, thickness); }
  // `origin` is the left end of the baseline.
  void Draw(Canvas& canvas, const std::string& text, Point origin, const Rgb& color) const {
    canvas.Text(text, origin, font_scale, color, thickness);
  }
  // Text with a white halo: readable over any map colour.
  void DrawHaloed(Canvas& canvas, const std::string& text, Point origin) const {
    canvas.Text(text, origin, font_scale, kWhite, thickness + 3);
    Draw(canvas, text, origin, kBlack);
  }
};

// A length as short text: "5 cm" below a metre, else "2 m".
std::string LengthText(double meters) {
  char buffer[32];
  if (meters < 1.0) {
    std::snprintf(buffer, sizeof(buffer), "%g cm", std::round(meters * 1000.0) / 10.0);
  } else {
    std::snprintf(buffer, sizeof(buffer), "%g m", meters);
  }
  return buffer;
}

// The value of the 1-2-5 series (..., 0.5, 1, 2, 5, 10, ...) closest in ratio to `target`.
double NiceLength(double target) {
  const double decade = std::pow(10.0, std::floor(std::log10(target)));
  double best = decade;
  for (const double step : {1.0, 2.0, 5.0, 10.0}) {
    const double value = step * decade;
    if (std::abs(std::log(value / target)) < std::abs(std::log(best / target))) best = value;
  }
  return best;
}

// ---- Glyphs, drawn around a point in picture pixels (our convention). ----

void DrawStartDisc(Canvas& canvas, const Eigen::Vector2d& at, const Rgb& color, int ui) {
  canvas.Circle(Fixed(at), FixedLength(5.0 * ui), color, kFilled);
  canvas.Circle(Fixed(at), FixedLength(5.0 * ui), kBlack, ui);
}

// An arrow head centred on `at`, pointing along `direction` (unit, picture pixels).
void DrawArrowHead(Canvas& canvas, const Eigen::Vector2d& at, const Eigen::Vector2d& direction,
                   const Rgb& color, int ui) {
  const double length = 18.0 * ui;
  const Eigen::Vector2d normal(-direction.y(), direction.x());
  const Eigen::Vector2d base = at - 0.35 * length * direction;
  const std::vector<Point> corners = {Fixed(at + 0.65 * length * direction), Fixed(base + 0.4 * length * normal),
                                     Fixed(base - 0.4 * length * normal)};
  canvas.FillConvexPolygon(corners, color);
  canvas.Polyline(corners, true, kBlack, ui);
}

void DrawMarkerGlyph(Canvas& canvas, const Eigen::Vector2d& at, MapPictureMarker::Kind kind,
                     int ui) {
  switch (kind) {
    case MapPictureMarker::Kind::kTag: {
      const double half = 6.0 * ui, inner = 2.5 * ui;
      canvas.Rectangle(Fixed(at - Eigen::Vector2d(half, half)), Fixed(at + Eigen::Vector2d(half, half)), kBlack,
                       kFilled);
      canvas.Rectangle(Fixed(at - Eigen::Vector2d(inner, inner)), Fixed(at + Eigen::Vector2d(inner, inner)), kWhite,
                       kFilled);
      break;
    }
    case MapPictureMarker::Kind::kConstraint: {
      const double r = 7.0 * ui;
      const std::vector<Point> corners = {Fixed(at + Eigen::Vector2d(0, -r)), Fixed(at + Eigen::Vector2d(r, 0)),
                                         Fixed(at + Eigen::Vector2d(0, r)), Fixed(at + Eigen::Vector2d(-r, 0))};
      canvas.FillConvexPolygon(corners, kWhite);
      canvas.Polyline(corners, true, kBlack, 2 * ui);
      break;
    }
    case MapPictureMarker::Kind::kPoint: {
      const double r = 6.0 * ui;
      canvas.Line(Fixed(at + Eigen::Vector2d(-r, -r)), Fixed(at + Eigen::Vector2d(r, r)), kBlack, 2 * ui);
      canvas.Line(Fixed(at + Eigen::Vector2d(-r, r)), Fixed(at + Eigen::Vector2d(r, -r)), kBlack, 2 * ui);
      break;
    }
  }
}

void DrawDashedLine(Canvas& canvas, const Eigen::Vector2d& from, const Eigen::Vector2d& to,
                    int ui) {
  const double length = (to - from).norm();
  const double dash = 9.0 * ui, gap = 6.0 * ui;
  if (length == 0.0) return;
  const Eigen::Vector2d along = (to - from) / length;
  for (double s = 0.0; s < length; s += dash + gap) {
    canvas.Line(Fixed(from + s * along), Fixed(from + std::min(length, s + dash) * along), kConstraintLineRgb, 2 * ui);
  }
}

const char* MarkerKindName(MapPictureMarker::Kind kind) {
  switch (kind) {
    case MapPictureMarker::Kind::kTag:
      return "tag";
    case MapPictureMarker::Kind::kConstraint:
      return "inter-robot constraint";
    case MapPictureMarker::Kind::kPoint:
      return "marker";
  }
  return "marker";
}

// One legend row: a cell swatch, a trajectory sample or a marker glyph, and its text.
struct LegendEntry {
  enum class Icon { kSwatch, kTrajectory, kMarker };
  Icon icon = Icon::kSwatch;
  Rgb color = kBlack;
  MapPictureMarker::Kind marker = MapPictureMarker::Kind::kPoint;
  std::string text;
};

}  // namespace

bool MapPictureOptions::IsValid(std::string* error) const {
  std::ostringstream why;
  if (min_short_side_pixels < 1 || min_short_side_pixels > 100'000) {
    why << "min_short_side_pixels must be in [1, 100000], got " << min_short_side_pixels;
  } else if (max_pixels < 1) {
    why << "max_pixels must be positive, got " << max_pixels;
  } else if (border_cells < 0 || border_cells > 1000) {
    why << "border_cells must be in [0, 1000], got " << border_cells;
  } else if (trajectory_width_pixels < 1 || trajectory_width_pixels > 50) {
    why << "trajectory_width_pixels must be in [1, 50], got " << trajectory_width_pixels;
  } else if (text_height_pixels < 6 || text_height_pixels > 200) {
    why << "text_height_pixels must be in [6, 200], got " << text_height_pixels;
  }
  if (why.str().empty()) return true;
  if (error != nullptr) *error = why.str();
  return false;
}

Status WriteMapPicture(const std::string& path, const OccupancyGrid& structure,
                       const OccupancyGrid* floor_obstacles,
                       const std::vector<MapPictureTrajectory>& trajectories,
                       const std::vector<MapPictureMarker>& markers,
                       const MapPictureOptions& options, MapPictureLayout* layout) {
  std::string why;
  if (!options.IsValid(&why)) return Status::Error(Error(path, "invalid options: " + why));
  const LoadedPluginTable& plugin = DrawingPlugin();
  if (plugin.table == nullptr) {
    const char* variable = std::getenv(map_picture_plugin::kPathVariable);
    return Status::Error(Error(path, "its drawing plugin could not be loaded: tried " + plugin.tried + "; " +
                                         (variable != nullptr && variable[0] != '\0'
                                              ? std::string("HETSLAM_PICTURE_PLUGIN must name the plugin's full path "
                                                            "(unset, the built and the installed plugin are tried)")
                                              : std::string("set HETSLAM_PICTURE_PLUGIN to the full path of "
                                                            "libhetslam_picture_plugin.so"))));
  }
  const MapPicturePluginApi* api = static_cast<const MapPicturePluginApi*>(plugin.table);
  const GridGeometry& g = structure.geometry();
  const double resolution = g.resolution_meters();
  if (floor_obstacles != nullptr &&
      floor_obstacles->geometry().resolution_meters() != resolution) {
    std::ostringstream s;
    s << "the floor obstacle grid's resolution (" << floor_obstacles->geometry().resolution_meters()
      << " m) differs from the structure grid's (" << resolution << " m)";
    return Status::Error(Error(path, s.str()));
  }

  // ---- Extent, in (unbounded) cells of the structure grid's lattice; double first so that a
  // far away pose cannot overflow an int. ----
  double lo_x = std::numeric_limits<double>::infinity(), lo_y = lo_x, hi_x = -lo_x, hi_y = -lo_x;
  auto include_cell = [&](double x, double y) {
    lo_x = std::min(lo_x, x);
    lo_y = std::min(lo_y, y);
    hi_x = std::max(hi_x, x);
    hi_y = std::max(hi_y, y);
  };
  auto include_world = [&](const Eigen::Vector2d& p) {
    const Eigen::Vector2d c = g.WorldToContinuousCell(p);
    include_cell(std::floor(c.x()), std::floor(c.y()));
  };
  if (structure.observed_max().x >= structure.observed_min().x) {
    include_cell(structure.observed_min().x, structure.observed_min().y);
    include_cell(structure.observed_max().x, structure.observed_max().y);
  }
  if (floor_obstacles != nullptr &&
      floor_obstacles->observed_max().x >= floor_obstacles->observed_min().x) {
    const GridGeometry& o = floor_obstacles->geometry();
    include_world(o.CellCenter(floor_obstacles->observed_min()));
    include_world(o.CellCenter(floor_obstacles->observed_max()));
  }
  for (size_t t = 0; t < trajectories.size(); ++t) {
    for (size_t k = 0; k < trajectories[t].poses.size(); ++k) {
      const Pose2& pose = trajectories[t].poses[k];
      if (!pose.ToVector().allFinite()) {
        return Status::Error(Error(path, "trajectory " + std::to_string(t) + " ('" +
                                             trajectories[t].name + "') pose " +
                                             std::to_string(k) + " is not finite"));
      }
      include_world(pose.translation());
    }
  }
  for (size_t m = 0; m < markers.size(); ++m) {
    const MapPictureMarker& marker = markers[m];
    if (!marker.world.allFinite() ||
        (marker.line_to_world.has_value() && !marker.line_to_world->allFinite())) {
      return Status::Error(Error(path, "marker " + std::to_string(m) + " ('" + marker.label +
                                           "') has a non-finite position"));
    }
    include_world(marker.world);
    if (marker.line_to_world.has_value()) include_world(*marker.line_to_world);
  }
  if (!(lo_x <= hi_x && lo_y <= hi_y)) {
    return Status::Error(Error(path, "nothing to draw (no observed cell, no pose, no marker)"));
  }
  // Beyond this many cells from the grid's origin (5e7 km at 5 cm) cell indices would not fit
  // the 64-bit arithmetic below.
  constexpr double kMaxCellCoordinate = 1e12;
  if (std::max({-lo_x, -lo_y, hi_x, hi_y}) > kMaxCellCoordinate) {
    return Status::Error(Error(path, "a pose or marker lies over 1e12 cells from the map"));
  }
  const double cells_x = hi_x - lo_x + 1.0 + 2.0 * options.border_cells;
  const double cells_y = hi_y - lo_y + 1.0 + 2.0 * options.border_cells;
  if (cells_x * cells_y > options.max_pixels) {
    std::ostringstream s;
    s << "the map part would have " << cells_x << " x " << cells_y
      << " cells, over max_pixels = " << options.max_pixels
      << " even at one pixel per cell; is a pose or marker far away from the map?";
    return Status::Error(Error(path, s.str()));
  }
  const int width_cells = static_cast<int>(cells_x);
  const int height_cells = static_cast<int>(cells_y);
  // Cell coordinates may exceed int far from the grid's origin: keep them in 64 bits.
  const int64_t min_x = static_cast<int64_t>(lo_x) - options.border_cells;
  const int64_t min_y = static_cast<int64_t>(lo_y) - options.border_cells;

  // ---- Scale: the smallest integer making the shorter side long enough, within max_pixels. ----
  const int short_cells = std::min(width_cells, height_cells);
  int scale = std::max(1, (options.min_short_side_pixels + short_cells - 1) / short_cells);
  const double cells = cells_x * cells_y;
  if (cells * scale * scale > options.max_pixels) {
    scale = std::max(1, static_cast<int>(std::floor(std::sqrt(options.max_pixels / cells))));
    while (scale > 1 && cells * scale * scale > options.max_pixels) --scale;
  }
  const int map_width = width_cells * scale;
  const int map_height = height_cells * scale;
  const int ui = std::max(1, std::min(map_width, map_height) / 1000);

  MapPictureLayout geometry;
  geometry.map_width_pixels = map_width;
  geometry.map_height_pixels = map_height;
  geometry.pixels_per_cell = scale;
  geometry.min_cell = {static_cast<int>(std::clamp<int64_t>(min_x, INT32_MIN, INT32_MAX)),
                       static_cast<int>(std::clamp<int64_t>(min_y, INT32_MIN, INT32_MAX))};
  geometry.max_cell = {
      static_cast<int>(std::clamp<int64_t>(min_x + width_cells - 1, INT32_MIN, INT32_MAX)),
      static_cast<int>(std::clamp<int64_t>(min_y + height_cells - 1, INT32_MIN, INT32_MAX))};
  geometry.map_min_corner_world =
      g.origin() + Eigen::Vector2d(static_cast<double>(min_x), static_cast<double>(min_y)) *
                       resolution;
  geometry.meters_per_pixel = resolution / scale;
  geometry.scale_bar_meters = NiceLength(0.15 * width_cells * resolution);

  // ---- Cells: one picture row per cell row, copied `scale` times. ----
  const uint8_t wall_bit = 1u << static_cast<int>(PointLabel::kWall);
  const uint8_t structure_bit = 1u << static_cast<int>(PointLabel::kStructure);
  const uint8_t obstacle_bit = 1u << static_cast<int>(PointLabel::kFloorObstacle);
  Shown shown;
  auto cell_color = [&](int64_t x, int64_t y) -> const Rgb& {
    if (x >= 0 && y >= 0 && x < g.width() && y < g.height()) {
      const int i = g.LinearIndex({static_cast<int>(x), static_cast<int>(y)});
      if (structure.State(i) == CellState::kOccupied) {
        const uint8_t mask = structure.LabelMask(i);
        if (mask & wall_bit) {
          shown.wall = true;
          return kMapPictureWallRgb;
        }
        if ((mask & obstacle_bit) && !(mask & structure_bit)) {
          shown.obstacle = true;
          return kMapPictureFloorObstacleRgb;
        }
        shown.structure = true;
        return kMapPictureStructureRgb;
      }
    }
    if (floor_obstacles != nullptr) {
      const GridGeometry& o = floor_obstacles->geometry();
      const Eigen::Vector2d centre =
          g.origin() + Eigen::Vector2d(x + 0.5, y + 0.5) * resolution;
      const Eigen::Vector2d c = o.WorldToContinuousCell(centre);
      const double ox = std::floor(c.x()), oy = std::floor(c.y());
      if (ox >= 0 && oy >= 0 && ox < o.width() && oy < o.height() &&
          floor_obstacles->State(o.LinearIndex({static_cast<int>(ox), static_cast<int>(oy)})) ==
              CellState::kOccupied) {
        shown.obstacle = true;
        return kMapPictureFloorObstacleRgb;
      }
    }
    if (x >= 0 && y >= 0 && x < g.width() && y < g.height() &&
        structure.State(g.LinearIndex({static_cast<int>(x), static_cast<int>(y)})) ==
            CellState::kFree) {
      shown.free = true;
      return kMapPictureFreeRgb;
    }
    shown.unknown = true;
    return kMapPictureUnknownRgb;
  };
  // The legend shows only what the map does: a pass over the cells first, so that the picture
  // is allocated once at its final size and the cells drawn straight into it (a separate map
  // image copied in would double the picture's memory: Intel's peak RSS).
  for (int row_cell = 0; row_cell < height_cells; ++row_cell) {
    for (int col_cell = 0; col_cell < width_cells; ++col_cell) cell_color(min_x + col_cell, min_y + row_cell);
  }

  // ---- Legend: only what the picture shows. ----
  TextStyle text;
  text.api = api;
  text.height = options.text_height_pixels * ui;
  text.thickness = ui;
  text.font_scale = api->font_scale_from_height(text.height, text.thickness);
  std::vector<LegendEntry> legend;
  auto add_swatch = [&](bool show, const Rgb& color, const std::string& name) {
    if (show) legend.push_back({LegendEntry::Icon::kSwatch, color, {}, name});
  };
  add_swatch(shown.wall, kMapPictureWallRgb, "walls");
  add_swatch(shown.structure, kMapPictureStructureRgb,
             shown.wall ? "other structure" : "structure");
  add_swatch(shown.obstacle, kMapPictureFloorObstacleRgb, "floor obstacles");
  add_swatch(shown.free, kMapPictureFreeRgb, "free");
  add_swatch(shown.unknown, kMapPictureUnknownRgb, "unknown");
  for (size_t t = 0; t < trajectories.size(); ++t) {
    if (trajectories[t].poses.empty()) continue;
    uint8_t rgb[3];
    TrajectoryColor(static_cast<int>(t), rgb);
    legend.push_back({LegendEntry::Icon::kTrajectory,
                      {rgb[0], rgb[1], rgb[2]},
                      {},
                      trajectories[t].name.empty() ? "trajectory " + std::to_string(t)
                                                   : trajectories[t].name});
  }
  for (const MapPictureMarker::Kind kind :
       {MapPictureMarker::Kind::kTag, MapPictureMarker::Kind::kConstraint,
        MapPictureMarker::Kind::kPoint}) {
    if (std::any_of(markers.begin(), markers.end(),
                    [kind](const MapPictureMarker& m) { return m.kind == kind; })) {
      legend.push_back({LegendEntry::Icon::kMarker, kBlack, kind, MarkerKindName(kind)});
    }
  }

  const int margin = 12 * ui;
  const int row_height = text.height * 2;
  const int swatch = text.height + 4 * ui;
  const int icon_width = 2 * swatch + 4 * ui;
  int text_width = 0;
  for (const LegendEntry& entry : legend) text_width = std::max(text_width, text.Width(entry.text));
  const int panel_width = margin + icon_width + margin + text_width + margin;
  const int legend_height = 2 * margin + static_cast<int>(legend.size()) * row_height;
  const int strip_height = 2 * margin + 2 * text.height;
  const int width = map_width + panel_width;
  const int height = std::max(map_height + strip_height, legend_height);

  // Drawn and written a band of rows at a time by core's dependency-free PNG encoder
  // (PngRowWriter; OpenCV's image codecs would load ~130 shared libraries and ~45 MiB into every
  // program that draws a map): the picture is never in memory whole (Intel's, 1708 x 1672 RGB,
  // 8.6 MB, was its run's peak RSS). Each band is drawn in full, every overlay clipped to it.
  geometry.width_pixels = width;
  geometry.height_pixels = height;
  PngRowWriter png;
  HETSLAM_RETURN_IF_ERROR(png.Open(path, width, height, 3));
  const size_t step = static_cast<size_t>(width) * 3;
  const int band_rows = std::clamp(static_cast<int>(kBandBytes / step), 1, height);
  auto to_pixel = [&](const Eigen::Vector2d& p_world) { return geometry.WorldToPixel(p_world); };
  // Each trajectory's polyline (its poses' pixels, repeats dropped), once for every band.
  std::vector<std::vector<Point>> trajectory_lines(trajectories.size());
  for (size_t t = 0; t < trajectories.size(); ++t) {
    const std::vector<Pose2>& poses = trajectories[t].poses;
    if (poses.size() < 2) continue;
    std::vector<Point>& line = trajectory_lines[t];
    line.reserve(poses.size());
    for (const Pose2& pose : poses) {
      const Point p = Fixed(to_pixel(pose.translation()));
      if (line.empty() || line.back() != p) line.push_back(p);
    }
  }
  std::vector<uint8_t> pixels(step * static_cast<size_t>(band_rows + 2 * kBandMarginRows));
  for (int first_row = 0; first_row < height; first_row += band_rows) {
    const int rows = std::min(band_rows, height - first_row);
    // Drawn with a margin of rows on either side, cut off when written: the anti-aliased
    // strokes a band's edge clips are a pixel off near it.
    const int drawn_first = std::max(0, first_row - kBandMarginRows);
    const int drawn_rows = std::min(height, first_row + rows + kBandMarginRows) - drawn_first;
    std::fill(pixels.begin(), pixels.begin() + static_cast<std::ptrdiff_t>(step * drawn_rows), uint8_t{255});
    PictureView view;
    view.data = pixels.data();
    view.width = width;
    view.height = drawn_rows;
    view.step = step;
    Canvas picture(api, view, drawn_first);
    // The map's cells: a pixel row as its cell row, or as the row above it in the band.
    for (int y = drawn_first; y < std::min(drawn_first + drawn_rows, map_height); ++y) {
      if (y > drawn_first && y % scale != 0) {
        picture.CopyRow(y - 1, y, map_width);
        continue;
      }
      const int row_cell = y / scale;
      const int64_t cell_y = min_y + height_cells - 1 - row_cell;  // row 0 shows the largest y
      for (int col_cell = 0; col_cell < width_cells; ++col_cell) {
        picture.FillRow(y, col_cell * scale, (col_cell + 1) * scale, cell_color(min_x + col_cell, cell_y));
      }
    }
    Canvas map = picture.TopLeft(map_width, map_height);  // drawing clips to the map

    // ---- Overlays, bottom to top: constraint lines, trajectories, their ends, markers, labels. ----
    for (const MapPictureMarker& marker : markers) {
      if (marker.line_to_world.has_value()) {
        DrawDashedLine(map, to_pixel(marker.world), to_pixel(*marker.line_to_world), ui);
      }
    }
    for (size_t t = 0; t < trajectories.size(); ++t) {
      if (trajectories[t].poses.size() < 2) continue;
      uint8_t rgb[3];
      TrajectoryColor(static_cast<int>(t), rgb);
      map.Polyline(trajectory_lines[t], false, {rgb[0], rgb[1], rgb[2]}, options.trajectory_width_pixels * ui);
    }
    for (size_t t = 0; t < trajectories.size(); ++t) {
      const std::vector<Pose2>& poses = trajectories[t].poses;
      if (poses.empty()) continue;
      uint8_t rgb[3];
      TrajectoryColor(static_cast<int>(t), rgb);
      const Rgb color = {rgb[0], rgb[1], rgb[2]};
      DrawStartDisc(map, to_pixel(poses.front().translation()), color, ui);
      const double theta = poses.back().theta();
      // Image rows grow downwards: world heading (cos, sin) is picture direction (cos, -sin).
      DrawArrowHead(map, to_pixel(poses.back().translation()),
                    Eigen::Vector2d(std::cos(theta), -std::sin(theta)), color, ui);
    }
    for (const MapPictureMarker& marker : markers) {
      DrawMarkerGlyph(map, to_pixel(marker.world), marker.kind, ui);
    }
    for (const MapPictureMarker& marker : markers) {
      if (marker.label.empty()) continue;
      const Eigen::Vector2d at = to_pixel(marker.world);
      // Above right of the marker, or on the far side of its line so the text does not sit on it.
      bool left = false, below = false;
      if (marker.line_to_world.has_value()) {
        const Eigen::Vector2d towards = to_pixel(*marker.line_to_world) - at;
        left = towards.x() > 0.0;
        below = towards.y() < 0.0;
      }
      const int x = static_cast<int>(std::lround(at.x())) +
                    (left ? -10 * ui - text.Width(marker.label) : 10 * ui);
      const int y = static_cast<int>(std::lround(at.y())) + (below ? 8 * ui + text.height : -8 * ui);
      text.DrawHaloed(map, marker.label, {x, y});
    }

    // ---- Legend panel, right of the map, over the whole height. ----
    picture.PixelLine({map_width, 0}, {map_width, height - 1}, kPanelLineRgb, 1);
    for (size_t k = 0; k < legend.size(); ++k) {
      const LegendEntry& entry = legend[k];
      const int x0 = map_width + margin;
      const int centre_y = margin + static_cast<int>(k) * row_height + row_height / 2;
      const Eigen::Vector2d icon_centre(x0 + icon_width / 2.0, centre_y + 0.5);
      switch (entry.icon) {
        case LegendEntry::Icon::kSwatch: {
          picture.PixelBox(x0, centre_y - swatch / 2, swatch, swatch, entry.color, kFilled);
          picture.PixelBox(x0, centre_y - swatch / 2, swatch, swatch, kPanelLineRgb, 1);
          break;
        }
        case LegendEntry::Icon::kTrajectory: {
          const Eigen::Vector2d from(x0 + 0.5, centre_y + 0.5);
          const Eigen::Vector2d to(x0 + icon_width - 11.0 * ui, centre_y + 0.5);
          picture.Line(Fixed(from), Fixed(to), entry.color, options.trajectory_width_pixels * ui);
          DrawArrowHead(picture, to, Eigen::Vector2d(1.0, 0.0), entry.color, ui);
          break;
        }
        case LegendEntry::Icon::kMarker:
          if (entry.marker == MapPictureMarker::Kind::kConstraint) {
            DrawDashedLine(picture, Eigen::Vector2d(x0 + 0.5, centre_y + 0.5),
                           Eigen::Vector2d(x0 + icon_width, centre_y + 0.5), ui);
          }
          DrawMarkerGlyph(picture, icon_centre, entry.marker, ui);
          break;
      }
      text.Draw(picture, entry.text, {x0 + icon_width + margin, centre_y + text.height / 2}, kBlack);
    }

    // ---- Scale bar strip, under the map. ----
    const int bar_length = static_cast<int>(std::lround(geometry.scale_bar_meters / resolution * scale));
    const int bar_y = map_height + margin + text.height;
    const int bar_thickness = 4 * ui;
    picture.PixelBox(margin, bar_y - bar_thickness / 2, bar_length, bar_thickness, kBlack, kFilled);
    for (const int x : {margin, margin + bar_length - ui}) {
      picture.PixelBox(x, bar_y - 3 * bar_thickness / 2, ui, 3 * bar_thickness, kBlack, kFilled);
    }
    const std::string bar_text = LengthText(geometry.scale_bar_meters);
    text.Draw(picture, bar_text, {margin + bar_length + margin, bar_y + text.height / 2}, kBlack);
    const std::string cell_text = "cells " + LengthText(resolution);
    text.Draw(picture, cell_text, {margin + bar_length + 3 * margin + text.Width(bar_text), bar_y + text.height / 2},
              kNoteTextRgb);
    HETSLAM_RETURN_IF_ERROR(png.AddRows(pixels.data() + step * static_cast<size_t>(first_row - drawn_first), rows));
  }
  HETSLAM_RETURN_IF_ERROR(png.Finish());
  if (layout != nullptr) *layout = geometry;
  return Status::Ok();
}

}  // namespace hetslam
