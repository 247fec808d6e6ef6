#include "datasets/sim/tag_camera.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <sstream>

#include "glog/logging.h"
#include "opencv2/imgproc.hpp"

#include "apriltag/apriltag.h"
#include "apriltag/tag36h11.h"
#include "datasets/sim/sim_random.h"

namespace hetslam {
namespace sim {

// The apriltag family and the 0/255 bitmap (white border included) of every code, made once.
struct TagCamera::Family {
  int total_width = 0;      // cells across the drawn pattern (10 for tag36h11)
  int width_at_border = 0;  // cells across the black square (8), whose edge is the tag size
  std::vector<std::vector<uint8_t>> bitmaps;  // [id][row * total_width + col], row 0 on top
};

namespace {

// Points closer to the camera plane than this are clipped away (metres): a tag crossing the
// camera plane is drawn as far as it lies in front.
constexpr double kNearPlaneMeters = 1e-3;

struct Vec2 {
  double x, y;
};

// A small convex polygon in pixel coordinates (a projected cell clipped to the near plane has
// at most 5 vertices; each of the 4 pixel-edge clips adds at most one).
struct Polygon {
  std::array<Vec2, 12> v;
  int n = 0;
};

// Sutherland-Hodgman: the part of `in` where a*x + b*y <= c.
Polygon ClipHalfPlane(const Polygon& in, double a, double b, double c) {
  Polygon out;
  for (int i = 0; i < in.n; ++i) {
    const Vec2& p = in.v[i];
    const Vec2& q = in.v[(i + 1) % in.n];
    const double dp = a * p.x + b * p.y - c;
    const double dq = a * q.x + b * q.y - c;
    if (dp <= 0.0) out.v[out.n++] = p;
    if ((dp < 0.0 && dq > 0.0) || (dp > 0.0 && dq < 0.0)) {
      const double s = dp / (dp - dq);
      out.v[out.n++] = {p.x + s * (q.x - p.x), p.y + s * (q.y - p.y)};
    }
  }
  return out;
}

double PolygonArea(const Polygon& polygon) {
  double twice = 0.0;
  for (int i = 0; i < polygon.n; ++i) {
    const Vec2& p = polygon.v[i];
    const Vec2& q = polygon.v[(i + 1) % polygon.n];
    twice += p.x * q.y - q.x * p.y;
  }
  return 0.5 * std::abs(twice);
}

// Area of the convex `polygon` inside the unit pixel square centred on (j, i).
double AreaInPixel(const Polygon& polygon, int j, int i) {
  Polygon local = polygon;
  for (int m = 0; m < local.n; ++m) local.v[m] = {local.v[m].x - j, local.v[m].y - i};
  local = ClipHalfPlane(local, 1.0, 0.0, 0.5);
  if (local.n >= 3) local = ClipHalfPlane(local, -1.0, 0.0, 0.5);
  if (local.n >= 3) local = ClipHalfPlane(local, 0.0, 1.0, 0.5);
  if (local.n >= 3) local = ClipHalfPlane(local, 0.0, -1.0, 0.5);
  return local.n >= 3 ? PolygonArea(local) : 0.0;
}

// The part of the 3D quad (camera frame) in front of the near plane, projected to pixels.
Polygon ProjectClipped(const std::array<Eigen::Vector3d, 4>& quad, const CameraIntrinsics& k) {
  Polygon pixels;
  auto add = [&](const Eigen::Vector3d& p) {
    const Eigen::Vector2d uv = k.Project(p);
    pixels.v[pixels.n++] = {uv.x(), uv.y()};
  };
  for (size_t i = 0; i < quad.size(); ++i) {
    const Eigen::Vector3d& p = quad[i];
    const Eigen::Vector3d& q = quad[(i + 1) % quad.size()];
    const double dp = p.z() - kNearPlaneMeters;
    const double dq = q.z() - kNearPlaneMeters;
    if (dp >= 0.0) add(p);
    if ((dp < 0.0 && dq > 0.0) || (dp > 0.0 && dq < 0.0)) add(p + (dp / (dp - dq)) * (q - p));
  }
  return pixels;
}

}  // namespace

bool TagCameraOptions::IsValid(std::string* error) const {
  std::ostringstream why;
  const CameraIntrinsics& k = intrinsics;
  auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  if (!positive(k.fx) || !positive(k.fy)) {
    why << "focal lengths must be positive, got fx " << k.fx << ", fy " << k.fy;
  } else if (!std::isfinite(k.cx) || !std::isfinite(k.cy)) {
    why << "principal point must be finite, got " << k.cx << ", " << k.cy;
  } else if (k.width < 1 || k.height < 1 || k.width > 16384 || k.height > 16384) {
    why << "image size must be in [1, 16384] pixels, got " << k.width << " x " << k.height;
  } else if (!(background_gray >= 0.0 && background_gray <= 255.0)) {
    why << "background gray must be in [0, 255], got " << background_gray;
  } else if (!(blur_sigma_pixels >= 0.0 && blur_sigma_pixels <= 50.0)) {
    why << "blur sigma must be in [0, 50] pixels, got " << blur_sigma_pixels;
  } else if (!(noise_std_gray >= 0.0 && noise_std_gray <= 255.0)) {
    why << "noise std must be in [0, 255] gray levels, got " << noise_std_gray;
  }
  if (why.str().empty()) return true;
  if (error != nullptr) *error = why.str();
  return false;
}

TagCamera::TagCamera(const TagCameraOptions& options) : options_(options) {
  std::string why;
  CHECK(options_.IsValid(&why)) << "invalid TagCameraOptions: " << why;
  apriltag_family_t* family = tag36h11_create();
  CHECK(family != nullptr) << "tag36h11_create failed";
  family_ = new Family;
  family_->total_width = family->total_width;
  family_->width_at_border = family->width_at_border;
  family_->bitmaps.resize(family->ncodes);
  for (uint32_t id = 0; id < family->ncodes; ++id) {
    image_u8_t* image = apriltag_to_image(family, static_cast<int>(id));
    CHECK(image != nullptr && image->width == family->total_width &&
          image->height == family->total_width)
        << "apriltag_to_image(" << id << ") did not give a " << family->total_width
        << " x " << family->total_width << " image";
    std::vector<uint8_t>& bitmap = family_->bitmaps[id];
    bitmap.resize(image->width * image->height);
    for (int row = 0; row < image->height; ++row) {
      for (int col = 0; col < image->width; ++col) {
        bitmap[row * image->width + col] = image->buf[row * image->stride + col];
      }
    }
    // image_u8_destroy is not exported by the Debian libapriltag; it frees exactly these two
    // blocks (image_u8_create_stride callocs the buffer and the struct).
    std::free(image->buf);
    std::free(image);
  }
  tag36h11_destroy(family);
  // The noise table: fixed, so that images depend only on the caller's generator.
  std::mt19937_64 table_rng(0x7a6ca3e7aULL);
  noise_table_.resize(1 << 16);
  for (float& sample : noise_table_) sample = static_cast<float>(StandardGaussian(&table_rng));
}

TagCamera::~TagCamera() { delete family_; }

bool TagCamera::IsInView(const SimulatedTag& tag, const Eigen::Isometry3d& world_T_camera) const {
  const Eigen::Isometry3d camera_T_tag = world_T_camera.inverse() * tag.world_T_tag;
  const Eigen::Vector3d p = camera_T_tag.translation();
  if (!(p.z() > kNearPlaneMeters)) return false;
  const CameraIntrinsics& k = options_.intrinsics;
  const Eigen::Vector2d uv = k.Project(p);
  const double u = uv.x(), v = uv.y();
  // Pixel centres at integer coordinates: the image covers [-0.5, width - 0.5).
  if (!(u >= -0.5 && u < k.width - 0.5 && v >= -0.5 && v < k.height - 0.5)) return false;
  // Line of sight from the tag to the camera against the tag's z axis.
  const Eigen::Vector3d to_camera = -p.normalized();
  const Eigen::Vector3d tag_z = camera_T_tag.linear().col(2);
  return tag_z.dot(to_camera) > std::cos(75.0 * M_PI / 180.0);
}

cv::Mat TagCamera::Render(const std::vector<SimulatedTag>& visible_tags,
                          const Eigen::Isometry3d& world_T_camera, std::mt19937_64* rng) const {
  CHECK(rng != nullptr) << "TagCamera::Render: rng is null";
  const CameraIntrinsics& k = options_.intrinsics;
  const int num_codes = static_cast<int>(family_->bitmaps.size());
  for (const SimulatedTag& tag : visible_tags) {
    CHECK(tag.id >= 0 && tag.id < num_codes)
        << "tag id " << tag.id << " is not a tag36h11 id (0.." << num_codes - 1 << ")";
    CHECK(std::isfinite(tag.size_meters) && tag.size_meters > 0.0)
        << "tag " << tag.id << " has size " << tag.size_meters;
  }
  cv::Mat image(k.height, k.width, CV_64F, cv::Scalar(options_.background_gray));

  // Far tags first, so that a nearer tag covers a farther one where they overlap.
  const Eigen::Isometry3d camera_T_world = world_T_camera.inverse();
  std::vector<std::pair<double, size_t>> order;
  for (size_t i = 0; i < visible_tags.size(); ++i) {
    const double depth = (camera_T_world * visible_tags[i].world_T_tag).translation().z();
    order.push_back({-depth, i});
  }
  std::stable_sort(order.begin(), order.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });

  const int cells = family_->total_width;
  // Per-tag coverage (pixel area covered by the pattern) and covered intensity (area * gray).
  cv::Mat coverage(k.height, k.width, CV_64F);
  cv::Mat covered(k.height, k.width, CV_64F);
  for (const auto& [unused, index] : order) {
    const SimulatedTag& tag = visible_tags[index];
    const Eigen::Isometry3d camera_T_tag = camera_T_world * tag.world_T_tag;
    // Only the front of a tag carries the pattern: the camera must be on its +z side.
    const Eigen::Vector3d tag_z = camera_T_tag.linear().col(2);
    if (!(tag_z.dot(-camera_T_tag.translation()) > 0.0)) continue;
    coverage.setTo(0.0);
    covered.setTo(0.0);
    const std::vector<uint8_t>& bitmap = family_->bitmaps[tag.id];
    // The drawn pattern (white border included) is size * total / at_border wide; cell (row,
    // col) spans x in [-w/2 + col * c, ...], y downwards from +w/2 (row 0 on top, y up).
    const double cell = tag.size_meters / family_->width_at_border;
    const double half = 0.5 * cell * cells;
    int x_min = k.width, x_max = -1, y_min = k.height, y_max = -1;
    for (int row = 0; row < cells; ++row) {
      for (int col = 0; col < cells; ++col) {
        const double x0 = -half + col * cell, x1 = x0 + cell;
        const double y0 = half - row * cell, y1 = y0 - cell;
        const std::array<Eigen::Vector3d, 4> corners = {
            camera_T_tag * Eigen::Vector3d(x0, y0, 0.0),
            camera_T_tag * Eigen::Vector3d(x1, y0, 0.0),
            camera_T_tag * Eigen::Vector3d(x1, y1, 0.0),
            camera_T_tag * Eigen::Vector3d(x0, y1, 0.0)};
        const Polygon polygon = ProjectClipped(corners, k);
        if (polygon.n < 3) continue;
        double u_lo = polygon.v[0].x, u_hi = u_lo, v_lo = polygon.v[0].y, v_hi = v_lo;
        for (int m = 1; m < polygon.n; ++m) {
          u_lo = std::min(u_lo, polygon.v[m].x);
          u_hi = std::max(u_hi, polygon.v[m].x);
          v_lo = std::min(v_lo, polygon.v[m].y);
          v_hi = std::max(v_hi, polygon.v[m].y);
        }
        // Pixel (i, j) covers [j - 0.5, j + 0.5] x [i - 0.5, i + 0.5]. Clamp in double first:
        // a vertex just in front of the near plane can project very far out.
        auto first = [](double lo, int size) {
          return static_cast<int>(std::clamp(std::floor(lo + 0.5), 0.0, size - 1.0));
        };
        const int j0 = first(u_lo, k.width), j1 = first(u_hi, k.width);
        const int i0 = first(v_lo, k.height), i1 = first(v_hi, k.height);
        if (u_hi < -0.5 || u_lo > k.width - 0.5 || v_hi < -0.5 || v_lo > k.height - 0.5) {
          continue;
        }
        x_min = std::min(x_min, j0);
        x_max = std::max(x_max, j1);
        y_min = std::min(y_min, i0);
        y_max = std::max(y_max, i1);
        const double gray = bitmap[row * cells + col];
        for (int i = i0; i <= i1; ++i) {
          for (int j = j0; j <= j1; ++j) {
            const double area = AreaInPixel(polygon, j, i);
            if (area <= 0.0) continue;
            coverage.at<double>(i, j) += area;
            covered.at<double>(i, j) += area * gray;
          }
        }
      }
    }
    // Composite over what is drawn already (cells of one tag never overlap: coverage <= 1).
    for (int i = y_min; i <= y_max; ++i) {
      for (int j = x_min; j <= x_max; ++j) {
        const double a = std::min(1.0, coverage.at<double>(i, j));
        double& out = image.at<double>(i, j);
        out = out * (1.0 - a) + covered.at<double>(i, j);
      }
    }
  }

  if (options_.blur_sigma_pixels > 0.0) {
    cv::GaussianBlur(image, image, cv::Size(0, 0), options_.blur_sigma_pixels,
                     options_.blur_sigma_pixels, cv::BORDER_REPLICATE);
  }
  cv::Mat gray(k.height, k.width, CV_8UC1);
  const bool noisy = options_.noise_std_gray > 0.0;
  uint64_t bits = 0;
  int bits_left = 0;  // 16-bit table indices left in `bits`
  for (int i = 0; i < k.height; ++i) {
    for (int j = 0; j < k.width; ++j) {
      double value = image.at<double>(i, j);
      // Row-major order, one draw per four pixels: the image depends on the generator only.
      if (noisy) {
        if (bits_left == 0) {
          bits = (*rng)();
          bits_left = 4;
        }
        value += options_.noise_std_gray * noise_table_[bits & 0xffff];
        bits >>= 16;
        --bits_left;
      }
      gray.at<uint8_t>(i, j) = static_cast<uint8_t>(std::lround(std::clamp(value, 0.0, 255.0)));
    }
  }
  return gray;
}

}  // namespace sim
}  // namespace hetslam
