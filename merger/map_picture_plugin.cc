// The map picture's drawing plugin (merger/map_picture_plugin.h): OpenCV's font and drawing
// calls over a caller's pixel buffer. Built as the MODULE libhetslam_picture_plugin.so with
// hidden visibility: hetslam_picture_plugin_api() is its one exported symbol.
#include "merger/map_picture_plugin.h"

#include <vector>

#include "opencv2/core.hpp"
#include "opencv2/imgproc.hpp"

namespace hetslam {
namespace {

constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;

// The view as a Mat header over the caller's pixels (no copy).
cv::Mat Image(const PictureView* view) { return cv::Mat(view->height, view->width, CV_8UC3, view->data, view->step); }

cv::Scalar Color(const uint8_t* rgb) { return cv::Scalar(rgb[0], rgb[1], rgb[2]); }

int LineType(PictureStroke stroke) { return stroke == PictureStroke::kAntiAliasedSubpixel ? cv::LINE_AA : cv::LINE_8; }
int Shift(PictureStroke stroke) {
  return stroke == PictureStroke::kAntiAliasedSubpixel ? map_picture_plugin::kSubpixelBits : 0;
}

std::vector<cv::Point> Points(const int32_t* points, int count) {
  std::vector<cv::Point> out(static_cast<size_t>(count));
  for (int i = 0; i < count; ++i) out[i] = cv::Point(points[2 * i], points[2 * i + 1]);
  return out;
}

double FontScaleFromHeight(int height_pixels, int thickness) {
  return cv::getFontScaleFromHeight(kFont, height_pixels, thickness);
}

int TextWidth(const char* text, double font_scale, int thickness) {
  int baseline = 0;
  return cv::getTextSize(text, kFont, font_scale, thickness, &baseline).width;
}

void PutText(const PictureView* view, const char* text, int x, int y, double font_scale, const uint8_t* rgb,
             int thickness) {
  cv::Mat image = Image(view);
  cv::putText(image, text, cv::Point(x, y), kFont, font_scale, Color(rgb), thickness, cv::LINE_AA);
}

void Circle(const PictureView* view, int x, int y, int radius, const uint8_t* rgb, int thickness,
            PictureStroke stroke) {
  cv::Mat image = Image(view);
  cv::circle(image, cv::Point(x, y), radius, Color(rgb), thickness, LineType(stroke), Shift(stroke));
}

void FillConvexPolygon(const PictureView* view, const int32_t* points, int count, const uint8_t* rgb,
                       PictureStroke stroke) {
  cv::Mat image = Image(view);
  const std::vector<cv::Point> corners = Points(points, count);
  cv::fillConvexPoly(image, corners, Color(rgb), LineType(stroke), Shift(stroke));
}

void Polyline(const PictureView* view, const int32_t* points, int count, bool closed, const uint8_t* rgb,
              int thickness, PictureStroke stroke) {
  cv::Mat image = Image(view);
  const std::vector<cv::Point> line = Points(points, count);
  cv::polylines(image, line, closed, Color(rgb), thickness, LineType(stroke), Shift(stroke));
}

void Rectangle(const PictureView* view, int x0, int y0, int x1, int y1, const uint8_t* rgb, int thickness,
               PictureStroke stroke) {
  cv::Mat image = Image(view);
  cv::rectangle(image, cv::Point(x0, y0), cv::Point(x1, y1), Color(rgb), thickness, LineType(stroke), Shift(stroke));
}

void Line(const PictureView* view, int x0, int y0, int x1, int y1, const uint8_t* rgb, int thickness,
          PictureStroke stroke) {
  cv::Mat image = Image(view);
  cv::line(image, cv::Point(x0, y0), cv::Point(x1, y1), Color(rgb), thickness, LineType(stroke), Shift(stroke));
}

const MapPicturePluginApi kApi = {
    map_picture_plugin::kAbiVersion,
    map_picture_plugin::LayoutFingerprint(),
    __VERSION__,
    &FontScaleFromHeight,
    &TextWidth,
    &PutText,
    &Circle,
    &FillConvexPolygon,
    &Polyline,
    &Rectangle,
    &Line,
};

}  // namespace
}  // namespace hetslam

extern "C" const hetslam::MapPicturePluginApi* hetslam_picture_plugin_api(void) { return &hetslam::kApi; }
