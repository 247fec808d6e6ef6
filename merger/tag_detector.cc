#include "merger/tag_detector.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <sstream>

#include "Eigen/Eigenvalues"
#include "Eigen/QR"
#include "glog/logging.h"

#include "apriltag/apriltag.h"
#include "apriltag/apriltag_pose.h"
#include "apriltag/tag36h11.h"

namespace hetslam {
namespace {

// apriltag reports corner coordinates with pixel centres at +0.5 (pixel i covers [i, i + 1]);
// ours are at integers. Measured in tag_detector_test (CornersMatchTheProjection).
constexpr double kApriltagPixelOffset = 0.5;

// matd_destroy is not exported by the Debian libapriltag; a matd_t is one calloc'ed block.
void FreeMatrix(matd_t* m) { std::free(m); }

// Bilinear interpolation of an 8-bit image at (x, y), pixel centres at integers; false when
// the 2 x 2 neighbourhood is not inside the image.
bool Bilinear(const cv::Mat& image, double x, double y, double* value) {
  const double fx = std::floor(x), fy = std::floor(y);
  const int x0 = static_cast<int>(fx), y0 = static_cast<int>(fy);
  if (x0 < 0 || y0 < 0 || x0 + 1 >= image.cols || y0 + 1 >= image.rows) return false;
  const double ax = x - fx, ay = y - fy;
  const uint8_t* r0 = image.ptr<uint8_t>(y0);
  const uint8_t* r1 = image.ptr<uint8_t>(y0 + 1);
  *value = (1 - ay) * ((1 - ax) * r0[x0] + ax * r0[x0 + 1]) +
           ay * ((1 - ax) * r1[x0] + ax * r1[x0 + 1]);
  return true;
}

// A line through `point` along unit `direction`.
struct Line2 {
  Eigen::Vector2d point;
  Eigen::Vector2d direction;
};

// Sub-pixel edges of the black square (see the header): for each side, profiles across the
// edge over its middle 60%, each giving the edge position by the area of its black-to-white
// transition, e = E - (integral of (I - black) / (white - black) over [-E, E]): exact for a step
// edge under any symmetric blur and pixel box filter, so no bias from the sampling phase.
// A least-squares line through those edge points per side; corners where the lines meet.
// Returns false (corners untouched) when the tag is too small or the contrast too low.
bool RefineCorners(const cv::Mat& image, std::array<Eigen::Vector2d, 4>* corners) {
  const std::array<Eigen::Vector2d, 4>& q = *corners;
  const Eigen::Vector2d middle = 0.25 * (q[0] + q[1] + q[2] + q[3]);
  std::array<Line2, 4> lines;
  for (int side = 0; side < 4; ++side) {
    const Eigen::Vector2d a = q[side], b = q[(side + 1) % 4];
    const double length = (b - a).norm();
    // The black border is one of the 8 cells across the square: keep the profile inside it
    // and inside the white border beyond the edge, with room for the blur.
    const double extent = std::min(2.5, 0.4 * length / 8.0);
    if (extent < 1.0) return false;
    const Eigen::Vector2d along = (b - a) / length;
    Eigen::Vector2d normal(-along.y(), along.x());
    if (normal.dot(a - middle) < 0.0) normal = -normal;  // outwards: black to white
    constexpr double kStep = 0.1;
    const int steps = static_cast<int>(std::ceil(2.0 * extent / kStep));
    const double h = 2.0 * extent / steps;
    std::vector<Eigen::Vector2d> bases;
    std::vector<double> integrals;
    double black_sum = 0.0, white_sum = 0.0;
    for (double t = 0.2 * length; t <= 0.8 * length; t += 1.0) {
      const Eigen::Vector2d base = a + t * along;
      double integral = 0.0, first = 0.0, last = 0.0;
      bool inside = true;
      for (int k = 0; k <= steps && inside; ++k) {
        const Eigen::Vector2d p = base + (-extent + k * h) * normal;
        double v = 0.0;
        inside = Bilinear(image, p.x(), p.y(), &v);
        integral += (k == 0 || k == steps ? 0.5 : 1.0) * h * v;
        if (k == 0) first = v;
        if (k == steps) last = v;
      }
      if (!inside) continue;
      bases.push_back(base);
      integrals.push_back(integral);
      black_sum += first;
      white_sum += last;
    }
    if (bases.size() < 5) return false;
    const double black = black_sum / bases.size(), white = white_sum / bases.size();
    if (!(white - black > 20.0)) return false;
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    std::vector<Eigen::Vector2d> points;
    for (size_t j = 0; j < bases.size(); ++j) {
      const double white_length = (integrals[j] - 2.0 * extent * black) / (white - black);
      points.push_back(bases[j] + (extent - white_length) * normal);
      mean += points.back() / static_cast<double>(bases.size());
    }
    Eigen::Matrix2d scatter = Eigen::Matrix2d::Zero();
    for (const Eigen::Vector2d& p : points) scatter += (p - mean) * (p - mean).transpose();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eigen(scatter);
    lines[side] = {mean, eigen.eigenvectors().col(1)};
  }
  std::array<Eigen::Vector2d, 4> refined;
  for (int c = 0; c < 4; ++c) {
    // Corner c starts side c and ends side c - 1.
    const Line2& l1 = lines[(c + 3) % 4];
    const Line2& l2 = lines[c];
    Eigen::Matrix2d m;
    m << l1.direction, -l2.direction;
    if (std::abs(m.determinant()) < 1e-6) return false;
    const Eigen::Vector2d s = m.colPivHouseholderQr().solve(l2.point - l1.point);
    refined[c] = l1.point + s.x() * l1.direction;
    // A refinement that moves a corner far from the detector's is not trusted.
    if (!((refined[c] - q[c]).norm() < 1.5)) return false;
  }
  *corners = refined;
  return true;
}

// det->H: the homography taking apriltag's ideal corners (-1, 1), (1, 1), (1, -1), (-1, -1)
// to det->p[0..3] (h33 = 1; the 8 x 8 linear system of the four correspondences).
void SetHomographyFromCorners(apriltag_detection_t* det) {
  const double ideal[4][2] = {{-1, 1}, {1, 1}, {1, -1}, {-1, -1}};
  Eigen::Matrix<double, 8, 8> a;
  Eigen::Matrix<double, 8, 1> b;
  for (int c = 0; c < 4; ++c) {
    const double x = ideal[c][0], y = ideal[c][1];
    const double u = det->p[c][0], v = det->p[c][1];
    a.row(2 * c) << x, y, 1, 0, 0, 0, -u * x, -u * y;
    a.row(2 * c + 1) << 0, 0, 0, x, y, 1, -v * x, -v * y;
    b(2 * c) = u;
    b(2 * c + 1) = v;
  }
  const Eigen::Matrix<double, 8, 1> h = a.colPivHouseholderQr().solve(b);
  CHECK(det->H != nullptr && det->H->nrows == 3 && det->H->ncols == 3) << "detection without H";
  for (int k = 0; k < 8; ++k) MATD_EL(det->H, k / 3, k % 3) = h(k);
  MATD_EL(det->H, 2, 2) = 1.0;
}

}  // namespace

bool TagDetectorOptions::IsValid(std::string* error) const {
  std::ostringstream why;
  if (!(std::isfinite(decimate) && decimate >= 1.0 && decimate <= 16.0)) {
    why << "decimate must be in [1, 16], got " << decimate;
  } else if (!(std::isfinite(sigma_pixels) && sigma_pixels >= 0.0 && sigma_pixels <= 20.0)) {
    why << "sigma must be in [0, 20] pixels, got " << sigma_pixels;
  } else if (max_hamming < 0 || max_hamming > 2) {
    why << "max_hamming must be 0, 1 or 2, got " << max_hamming;
  }
  if (why.str().empty()) return true;
  if (error != nullptr) *error = why.str();
  return false;
}

struct TagDetector::Impl {
  apriltag_family_t* family = nullptr;
  apriltag_detector_t* detector = nullptr;
};

TagDetector::TagDetector(const TagDetectorOptions& options) : options_(options) {
  std::string why;
  CHECK(options_.IsValid(&why)) << "invalid TagDetectorOptions: " << why;
  impl_ = new Impl;
  impl_->family = tag36h11_create();
  impl_->detector = apriltag_detector_create();
  CHECK(impl_->family != nullptr && impl_->detector != nullptr) << "apriltag allocation failed";
  apriltag_detector_add_family_bits(impl_->detector, impl_->family, options_.max_hamming);
  impl_->detector->quad_decimate = static_cast<float>(options_.decimate);
  impl_->detector->quad_sigma = static_cast<float>(options_.sigma_pixels);
  impl_->detector->refine_edges = options_.refine_edges ? 1 : 0;
  // One thread: the library's work split would otherwise depend on scheduling.
  impl_->detector->nthreads = 1;
  impl_->detector->debug = 0;
}

TagDetector::~TagDetector() {
  apriltag_detector_destroy(impl_->detector);
  tag36h11_destroy(impl_->family);
  delete impl_;
}

Status TagDetector::Detect(const cv::Mat& gray8, const CameraIntrinsics& intrinsics,
                           double tag_size_meters, std::vector<TagDetection>* detections) {
  CHECK(detections != nullptr) << "TagDetector::Detect: detections is null";
  detections->clear();
  if (gray8.empty()) return Status::Error("tag detection: the image is empty");
  if (gray8.type() != CV_8UC1) {
    return Status::Error("tag detection: the image must be 8-bit single-channel (CV_8UC1), "
                         "got OpenCV type " + std::to_string(gray8.type()));
  }
  if ((intrinsics.width > 0 && intrinsics.width != gray8.cols) ||
      (intrinsics.height > 0 && intrinsics.height != gray8.rows)) {
    return Status::Error("tag detection: the image is " + std::to_string(gray8.cols) + " x " +
                         std::to_string(gray8.rows) + " but the intrinsics are for " +
                         std::to_string(intrinsics.width) + " x " +
                         std::to_string(intrinsics.height));
  }
  if (!(std::isfinite(intrinsics.fx) && intrinsics.fx > 0.0 && std::isfinite(intrinsics.fy) &&
        intrinsics.fy > 0.0 && std::isfinite(intrinsics.cx) && std::isfinite(intrinsics.cy))) {
    return Status::Error("tag detection: intrinsics need positive focal lengths and a finite "
                         "principal point");
  }
  if (!(std::isfinite(tag_size_meters) && tag_size_meters > 0.0)) {
    return Status::Error("tag detection: tag size must be positive, got " +
                         std::to_string(tag_size_meters));
  }

  // The detector reads the pixels through its own image struct; it never writes them.
  const cv::Mat continuous = gray8.isContinuous() ? gray8 : gray8.clone();
  image_u8_t image = {continuous.cols, continuous.rows, static_cast<int32_t>(continuous.step[0]),
                      const_cast<uint8_t*>(continuous.ptr<uint8_t>(0))};
  zarray_t* found = apriltag_detector_detect(impl_->detector, &image);
  CHECK(found != nullptr) << "apriltag_detector_detect failed";

  // apriltag frame (x right, y down, z into the tag) to ours (y up, z out of the tag).
  Eigen::Isometry3d apriltag_T_tag = Eigen::Isometry3d::Identity();
  apriltag_T_tag.linear() = Eigen::Vector3d(1.0, -1.0, -1.0).asDiagonal();

  for (int k = 0; k < zarray_size(found); ++k) {
    apriltag_detection_t* det = nullptr;
    zarray_get(found, k, &det);
    if (det->hamming > options_.max_hamming) continue;
    TagDetection out;
    out.id = det->id;
    out.hamming = det->hamming;
    out.decision_margin = det->decision_margin;
    // apriltag's p[0..3] are its tag-frame corners (-s/2, s/2), (s/2, s/2), (s/2, -s/2),
    // (-s/2, -s/2) with y down: ours (-,-), (+,-), (+,+), (-,+) with y up.
    for (int c = 0; c < 4; ++c) {
      out.corners_pixels[c] = Eigen::Vector2d(det->p[c][0] - kApriltagPixelOffset,
                                              det->p[c][1] - kApriltagPixelOffset);
    }
    out.center_pixels =
        Eigen::Vector2d(det->c[0] - kApriltagPixelOffset, det->c[1] - kApriltagPixelOffset);
    if (options_.refine_corners_subpixel &&
        RefineCorners(continuous, &out.corners_pixels)) {
      out.corners_refined = true;
      // The projected tag centre is where the diagonals of the projected square meet.
      const Eigen::Vector2d* p = out.corners_pixels.data();
      Eigen::Matrix2d m;
      m << p[2] - p[0], p[1] - p[3];
      const Eigen::Vector2d s = m.colPivHouseholderQr().solve(p[1] - p[0]);
      out.center_pixels = p[0] + s.x() * (p[2] - p[0]);
      // The pose solver reads the corners from the detection (orthogonal iteration) and its
      // homography (the starting pose): both must describe the refined corners.
      for (int c = 0; c < 4; ++c) {
        det->p[c][0] = p[c].x() + kApriltagPixelOffset;
        det->p[c][1] = p[c].y() + kApriltagPixelOffset;
      }
      SetHomographyFromCorners(det);
    }

    // The pose solver works in apriltag's pixel convention: shift the principal point along.
    apriltag_detection_info_t info;
    info.det = det;
    info.tagsize = tag_size_meters;
    info.fx = intrinsics.fx;
    info.fy = intrinsics.fy;
    info.cx = intrinsics.cx + kApriltagPixelOffset;
    info.cy = intrinsics.cy + kApriltagPixelOffset;
    apriltag_pose_t pose = {nullptr, nullptr};
    out.pose_error = estimate_tag_pose(&info, &pose);
    CHECK(pose.R != nullptr && pose.t != nullptr) << "estimate_tag_pose gave no pose";
    Eigen::Isometry3d camera_T_apriltag = Eigen::Isometry3d::Identity();
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) camera_T_apriltag.linear()(r, c) = MATD_EL(pose.R, r, c);
      camera_T_apriltag.translation()(r) = MATD_EL(pose.t, r, 0);
    }
    FreeMatrix(pose.R);
    FreeMatrix(pose.t);
    out.camera_T_tag = camera_T_apriltag * apriltag_T_tag;
    detections->push_back(out);
  }
  apriltag_detections_destroy(found);

  std::sort(detections->begin(), detections->end(),
            [](const TagDetection& a, const TagDetection& b) {
              if (a.id != b.id) return a.id < b.id;
              if (a.center_pixels.x() != b.center_pixels.x()) {
                return a.center_pixels.x() < b.center_pixels.x();
              }
              return a.center_pixels.y() < b.center_pixels.y();
            });
  return Status::Ok();
}

}  // namespace hetslam
