// The pinhole camera model of hetslam (robot log PARAMs, the simulated tag camera, the tag
// detector).
//
// Camera frame: the OpenCV optical frame, x right, y down, z forward (along the optical axis).
// Pixels: (u, v) = (column, row), pixel centres at integer coordinates: pixel (row i, column j)
// covers [j - 0.5, j + 0.5] x [i - 0.5, i + 0.5], so the image covers
// [-0.5, width - 0.5) x [-0.5, height - 0.5) and a centred principal point is
// cx = (width - 1) / 2, cy = (height - 1) / 2. No lens distortion.
#ifndef HETSLAM_CORE_CAMERA_MODEL_H_
#define HETSLAM_CORE_CAMERA_MODEL_H_

#include "Eigen/Core"

namespace hetslam {

struct CameraIntrinsics {
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;  // pixels
  int width = 0, height = 0;

  // The pixel (u, v) = (fx x / z + cx, fy y / z + cy) of the camera-frame point p_camera.
  // Meaningful for z > 0 only (no check: a point on or behind the camera plane gives an
  // infinite or mirrored pixel); not clipped to the image.
  Eigen::Vector2d Project(const Eigen::Vector3d& p_camera) const {
    return Eigen::Vector2d(fx * p_camera.x() / p_camera.z() + cx,
                           fy * p_camera.y() / p_camera.z() + cy);
  }
};

}  // namespace hetslam

#endif  // HETSLAM_CORE_CAMERA_MODEL_H_
