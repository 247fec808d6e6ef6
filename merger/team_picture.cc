#include "merger/team_picture.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "core/map_io.h"
#include "opencv2/core.hpp"
#include "opencv2/imgproc.hpp"

namespace hetslam {
namespace {

constexpr double kMaxPicturePixels = 1e8;

cv::Scalar Color(int robot) {
  uint8_t rgb[3];
  TrajectoryColor(robot, rgb);
  return cv::Scalar(rgb[0], rgb[1], rgb[2]);  // the picture is RGB
}

}  // namespace

bool TeamPictureOptions::IsValid(std::string* error) const {
  const bool ok = pixels_per_cell >= 1 && pixels_per_cell <= 16;
  if (error != nullptr) *error = ok ? "" : "pixels_per_cell must be in [1, 16]; ";
  return ok;
}

Status WriteTeamPicturePng(const OccupancyGrid& grid, const TeamPicture& picture, const TeamPictureOptions& options,
                           const std::string& path) {
  std::string error;
  if (!options.IsValid(&error)) return Status::Error("cannot write '" + path + "': " + error);
  const CellIndex lo = grid.observed_min(), hi = grid.observed_max();
  if (hi.x < lo.x || hi.y < lo.y) return Status::Error("cannot write '" + path + "': the map has no observed cell");
  const GridGeometry& g = grid.geometry();
  // The picture: the observed box and every drawn point, plus a border, in cells.
  Eigen::Vector2d min = g.CellMinCorner(lo), max = g.CellMinCorner({hi.x + 1, hi.y + 1});
  auto include = [&](const Eigen::Vector2d& p) {
    if (!p.allFinite()) return false;
    min = min.cwiseMin(p);
    max = max.cwiseMax(p);
    return true;
  };
  for (const TeamPicture::Robot& robot : picture.robots) {
    for (const Pose2& pose : robot.trajectory) {
      if (!include(pose.translation())) return Status::Error("cannot write '" + path + "': a non-finite pose");
    }
  }
  for (const TeamPicture::Tag& tag : picture.tags) {
    if (!include(tag.position)) return Status::Error("cannot write '" + path + "': a non-finite tag position");
  }
  const double r = g.resolution_meters();
  const Eigen::Vector2d border = Eigen::Vector2d::Constant(kMapBorderCells * r);
  min -= border;
  max += border;
  const int scale = options.pixels_per_cell;
  const double cols = std::ceil((max.x() - min.x()) / r) * scale, rows = std::ceil((max.y() - min.y()) / r) * scale;
  if (cols * rows > kMaxPicturePixels) return Status::Error("cannot write '" + path + "': the picture would be too large");
  cv::Mat image(static_cast<int>(rows), static_cast<int>(cols), CV_8UC3);
  // Row 0 on top (largest y), as every map picture of hetslam.
  auto to_pixel = [&](const Eigen::Vector2d& p) {
    return cv::Point(static_cast<int>(std::floor((p.x() - min.x()) / r * scale)),
                     static_cast<int>(std::floor((max.y() - p.y()) / r * scale)));
  };
  for (int row = 0; row < image.rows; ++row) {
    for (int col = 0; col < image.cols; ++col) {
      const Eigen::Vector2d p(min.x() + (col + 0.5) / scale * r, max.y() - (row + 0.5) / scale * r);
      const CellIndex c = g.WorldToCell(p);
      uint8_t v = kPgmUnknown;
      if (g.Contains(c)) {
        const CellState state = grid.State(c);
        v = state == CellState::kOccupied ? kPgmOccupied : state == CellState::kFree ? kPgmFree : kPgmUnknown;
      }
      image.at<cv::Vec3b>(row, col) = cv::Vec3b(v, v, v);
    }
  }
  for (const TeamPicture::Link& link : picture.links) {
    cv::line(image, to_pixel(link.from), to_pixel(link.to), Color(link.robot), link.first_link ? 3 : 1, cv::LINE_AA);
    cv::circle(image, to_pixel(link.from), link.first_link ? 4 : 2, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  }
  for (size_t i = 0; i < picture.robots.size(); ++i) {
    const std::vector<Pose2>& poses = picture.robots[i].trajectory;
    if (poses.empty()) continue;
    std::vector<cv::Point> line;
    for (const Pose2& pose : poses) line.push_back(to_pixel(pose.translation()));
    cv::polylines(image, line, false, Color(static_cast<int>(i)), 1, cv::LINE_AA);
    cv::circle(image, line.front(), 5, Color(static_cast<int>(i)), cv::FILLED, cv::LINE_AA);
    cv::circle(image, line.front(), 6, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  }
  for (const TeamPicture::Tag& tag : picture.tags) {
    const cv::Point p = to_pixel(tag.position);
    cv::rectangle(image, p - cv::Point(4, 4), p + cv::Point(4, 4), Color(tag.robot), cv::FILLED);
    cv::rectangle(image, p - cv::Point(5, 5), p + cv::Point(5, 5), cv::Scalar(0, 0, 0), 1);
    cv::putText(image, std::to_string(tag.id), p + cv::Point(7, -6), cv::FONT_HERSHEY_SIMPLEX, 0.45,
                cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  }
  // Legend, top left, on white.
  std::vector<std::pair<std::string, int>> lines;  // text, robot colour (-1: none)
  for (size_t i = 0; i < picture.robots.size(); ++i) {
    lines.emplace_back(picture.robots[i].name + picture.robots[i].note, static_cast<int>(i));
  }
  lines.emplace_back("square + id: a tag a robot placed", -1);
  lines.emplace_back("thick line: first link, thin: later constraints", -1);
  const int line_height = 16;
  int width = 0;
  for (const auto& [text, robot] : lines) {
    int baseline = 0;
    width = std::max(width, cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, 0.42, 1, &baseline).width);
  }
  const cv::Rect box(2, 2, std::min(image.cols - 4, width + 30), std::min(image.rows - 4, line_height * static_cast<int>(lines.size()) + 6));
  if (box.width > 0 && box.height > 0) {
    image(box).setTo(cv::Scalar(255, 255, 255));
    cv::rectangle(image, box, cv::Scalar(0, 0, 0), 1);
    for (size_t k = 0; k < lines.size(); ++k) {
      const int y = 4 + line_height * static_cast<int>(k) + line_height - 4;
      if (lines[k].second >= 0) cv::line(image, {6, y - 4}, {20, y - 4}, Color(lines[k].second), 3);
      cv::putText(image, lines[k].first, {24, y}, cv::FONT_HERSHEY_SIMPLEX, 0.42, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
    }
  }
  std::vector<uint8_t> pixels(image.data, image.data + image.total() * 3);
  return WritePng(path, image.cols, image.rows, 3, pixels);
}

}  // namespace hetslam
