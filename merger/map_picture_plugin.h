// The boundary between the map picture (merger/map_picture.h) and its drawing plugin (internal;
// embedders use merger/map_picture.h). OpenCV's core library brings in libGL, X11 and TBB:
// with imgproc about 3.5 MiB resident in every process that links them, mapped from the start
// (measured on FR079: a hetslam_run that maps none of them peaks 3.2-4.6 MiB lower on all four
// real logs). So OpenCV's drawing calls live in a MODULE library, libhetslam_picture_plugin.so
// (merger/map_picture_plugin.cc), which merger/map_picture.cc loads with dlopen the first time a
// picture is drawn; layout, cell colours, legend and the PNG stay in hetslam_picture. A program
// draws its picture after its estimator is freed, so the libraries never add to the run's peak.
//
// The plugin exports one C symbol, hetslam_picture_plugin_api(), returning a table of drawing
// functions over plain data (a pixel buffer, integer coordinates, C strings): OpenCV's calls
// with the same arguments, so that a picture is the same bytes as when they were linked in. A
// plugin of another build is refused (core/plugin_loader.h) when its ABI version, the layout
// fingerprint of the types exchanged or its compiler differ.
//
// Where the plugin is looked for:
//   1. $HETSLAM_PICTURE_PLUGIN, the full path of the .so; when set, nothing else is tried;
//   2. the build tree's plugin (its path compiled in), so programs and tests run from the build;
//   3. <libdir>/hetslam/libhetslam_picture_plugin.so under the CMAKE_INSTALL_PREFIX configured.
#ifndef HETSLAM_MERGER_MAP_PICTURE_PLUGIN_H_
#define HETSLAM_MERGER_MAP_PICTURE_PLUGIN_H_

#include <cstddef>
#include <cstdint>
#include <initializer_list>

#include "core/plugin_loader.h"

namespace hetslam {

// An RGB picture (3 bytes a pixel, rows `step` bytes apart), or a rectangle of one: drawing
// clips to it.
struct PictureView {
  uint8_t* data = nullptr;  // pixel (0, 0)
  int width = 0;
  int height = 0;
  size_t step = 0;  // bytes from one row to the next
};

// The two ways a shape is drawn: anti-aliased with coordinates (and radii) in 1/2^kSubpixelBits
// pixels (OpenCV's LINE_AA with shift), or aliased on whole pixels (LINE_8, no shift).
enum class PictureStroke : int32_t { kAntiAliasedSubpixel = 0, kWholePixels = 1 };

namespace map_picture_plugin {

// Bumped whenever the table below changes or one of its functions changes meaning.
constexpr uint32_t kAbiVersion = 1;
// Fractional bits of kAntiAliasedSubpixel coordinates.
constexpr int kSubpixelBits = 4;

// The layout fingerprint (core/plugin_loader.h) of what the table exchanges.
constexpr uint64_t LayoutFingerprint() {
  return PluginLayoutFingerprint({sizeof(PictureView), alignof(PictureView), sizeof(PictureStroke), sizeof(size_t),
                                  static_cast<uint64_t>(kSubpixelBits)});
}

constexpr char kEntryPointName[] = "hetslam_picture_plugin_api";
constexpr char kPathVariable[] = "HETSLAM_PICTURE_PLUGIN";

}  // namespace map_picture_plugin

// The plugin's table: OpenCV's Hershey simplex font and drawing calls. `rgb` is three bytes;
// `points` holds `count` (x, y) pairs; a negative thickness fills. The first three fields keep
// their types and places in every version.
struct MapPicturePluginApi {
  uint32_t abi_version;         // map_picture_plugin::kAbiVersion of the plugin's build
  uint64_t layout_fingerprint;  // map_picture_plugin::LayoutFingerprint() of the plugin's build
  const char* compiler;         // the plugin's compiler (__VERSION__)
  // cv::getFontScaleFromHeight and the width of cv::getTextSize.
  double (*font_scale_from_height)(int height_pixels, int thickness);
  int (*text_width)(const char* text, double font_scale, int thickness);
  // cv::putText, anti-aliased; (x, y) is the left end of the baseline, whole pixels.
  void (*put_text)(const PictureView* view, const char* text, int x, int y, double font_scale, const uint8_t* rgb,
                   int thickness);
  void (*circle)(const PictureView* view, int x, int y, int radius, const uint8_t* rgb, int thickness,
                 PictureStroke stroke);
  void (*fill_convex_polygon)(const PictureView* view, const int32_t* points, int count, const uint8_t* rgb,
                              PictureStroke stroke);
  void (*polyline)(const PictureView* view, const int32_t* points, int count, bool closed, const uint8_t* rgb,
                   int thickness, PictureStroke stroke);
  // Corners (x0, y0) and (x1, y1), both inside the rectangle.
  void (*rectangle)(const PictureView* view, int x0, int y0, int x1, int y1, const uint8_t* rgb, int thickness,
                    PictureStroke stroke);
  void (*line)(const PictureView* view, int x0, int y0, int x1, int y1, const uint8_t* rgb, int thickness,
               PictureStroke stroke);
};

}  // namespace hetslam

// Defined by the plugin (merger/map_picture_plugin.cc), the one symbol it exports (the plugin is
// compiled with hidden visibility); its table lives as long as the plugin.
extern "C" __attribute__((visibility("default"))) const hetslam::MapPicturePluginApi* hetslam_picture_plugin_api(void);

#endif  // HETSLAM_MERGER_MAP_PICTURE_PLUGIN_H_
