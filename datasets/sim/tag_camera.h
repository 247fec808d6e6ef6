// A simulated grey-scale camera that sees AprilTags (tag36h11) on a plain background.
//
// Each visible tag is drawn from the apriltag library's own family bitmap (tag36h11_create(),
// apriltag_to_image(): the 10 x 10 cell pattern including its white border) by exact area
// coverage: every cell is projected (a perspective quad, clipped to the part in front of the
// camera) and each pixel gets the area-weighted mean of the cells and background it overlaps,
// i.e. a perspective warp of the bitmap box-filtered over the pixel, with no sampling bias on
// edges (a point-sampled warp, even supersampled, shifts edges by up to half a sample, which
// tilts the pose of a frontal tag by degrees). Then the whole image gets Gaussian blur
// (cv::GaussianBlur, replicated border) and Gaussian pixel noise, and is rounded to 8 bits.
// The noise of each pixel is noise_std times an entry of a fixed table of 65536 standard
// normal samples (drawn once, from a constant seed), picked by 16 bits of the caller's
// generator: four pixels per draw, no transcendental per pixel (generating per-pixel Box-Muller
// samples took most of a dataset's generation time).
// Pixel centres are at integer coordinates (pixel (row i, column j) covers [j - 0.5, j + 0.5] x
// [i - 0.5, i + 0.5]), the convention of CameraIntrinsics (core/camera_model.h). Occlusion
// between tags and by walls is the caller's business (pass only the tags it can see); nearer
// tags are drawn over farther ones; tags behind the camera or partly outside the image are
// drawn clipped, as a real camera would see them; a tag seen from its back (camera on its -z
// side) is not drawn.
//
// Frames (see core/robot_log.h): world_T_camera is the OpenCV optical frame (z forward, x right,
// y down); world_T_tag has x right, y up as seen when facing the tag, z out of the tag. The tag
// size is the edge of the black square (apriltag's `tagsize` convention): the drawn pattern,
// white border included, is size * 10 / 8 wide for tag36h11.
#ifndef HETSLAM_DATASETS_SIM_TAG_CAMERA_H_
#define HETSLAM_DATASETS_SIM_TAG_CAMERA_H_

#include <random>
#include <string>
#include <vector>

#include "Eigen/Core"
#include "Eigen/Geometry"
#include "core/camera_model.h"
#include "core/status.h"
#include "opencv2/core.hpp"

namespace hetslam {
namespace sim {

struct SimulatedTag {
  int id = 0;                  // tag36h11 id, 0 .. 586
  double size_meters = 0.16;   // edge of the black square
  Eigen::Isometry3d world_T_tag = Eigen::Isometry3d::Identity();
};

struct TagCameraOptions {
  CameraIntrinsics intrinsics{525.0, 525.0, 319.5, 239.5, 640, 480};
  double background_gray = 150.0;     // 0..255
  double blur_sigma_pixels = 0.6;     // 0 disables the blur
  double noise_std_gray = 2.0;        // per pixel, 0 disables the noise

  bool IsValid(std::string* error) const;
};

class TagCamera {
 public:
  // CHECK-fails on invalid options.
  explicit TagCamera(const TagCameraOptions& options);
  ~TagCamera();
  TagCamera(const TagCamera&) = delete;
  TagCamera& operator=(const TagCamera&) = delete;

  // Renders the image (CV_8UC1, intrinsics width x height). Random pixel noise comes from
  // `rng` in a fixed order: the same inputs and generator state give the same image.
  // An unknown tag id is a CHECK failure (validate scenario input before).
  cv::Mat Render(const std::vector<SimulatedTag>& visible_tags,
                 const Eigen::Isometry3d& world_T_camera, std::mt19937_64* rng) const;

  // True when the tag's centre is in front of the camera, projects inside the image and the
  // tag faces the camera (angle between its z axis and the line of sight below 75°).
  bool IsInView(const SimulatedTag& tag, const Eigen::Isometry3d& world_T_camera) const;

  const TagCameraOptions& options() const { return options_; }

 private:
  TagCameraOptions options_;
  struct Family;
  Family* family_ = nullptr;  // owned: the apriltag family and its bitmaps
  std::vector<float> noise_table_;  // 65536 standard normal samples
};

}  // namespace sim
}  // namespace hetslam

#endif  // HETSLAM_DATASETS_SIM_TAG_CAMERA_H_
