#include "core/laser_scan.h"

#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <string>
#include <unordered_map>
#include <unordered_set>

#include "core/euler.h"
#include "glog/logging.h"

namespace hetslam {

int LaserScan::NumValidBeams() const {
  int count = 0;
  for (double r : ranges_meters) count += IsValidRange(r) ? 1 : 0;
  return count;
}

Status CheckBeamAngles(int num_beams, double first_angle_radians, double increment_radians,
                       const char* first_name, const char* increment_name) {
  auto text = [](double v) {
    char buffer[64];
    std::snprintf(buffer, sizeof(buffer), "%.9g", v);
    return std::string(buffer);
  };
  if (!std::isfinite(first_angle_radians) || std::abs(first_angle_radians) > 2 * M_PI) {
    return Status::Error(std::string(first_name) + " " + text(first_angle_radians) +
                         " rad is not a finite angle in [-2 pi, 2 pi]");
  }
  if (!std::isfinite(increment_radians)) {
    return Status::Error(std::string(increment_name) + " " + text(increment_radians) + " rad is not finite");
  }
  if (num_beams >= 2 && increment_radians == 0.0) {
    return Status::Error(std::string(increment_name) + " is 0 with " + std::to_string(num_beams) +
                         " beams: every beam would point the same way");
  }
  if (num_beams >= 2 && std::abs(increment_radians) * (num_beams - 1) > 2 * M_PI + 1e-6) {
    return Status::Error(std::string(increment_name) + " " + text(increment_radians) + " rad with " +
                         std::to_string(num_beams) + " beams spans " +
                         text(std::abs(increment_radians) * (num_beams - 1)) + " rad, more than one turn");
  }
  return Status::Ok();
}

std::vector<double> EvenlySpacedAngles(int num_beams, double first_angle_radians,
                                       double increment_radians) {
  CHECK_GE(num_beams, 0) << "num_beams=" << num_beams;
  std::vector<double> angles(num_beams);
  for (int i = 0; i < num_beams; ++i) angles[i] = first_angle_radians + i * increment_radians;
  return angles;
}

std::vector<ProjectedPoint> ProjectScan(const LaserScan& scan, const BodyAttitude& attitude) {
  CHECK_EQ(scan.angles_radians.size(), scan.ranges_meters.size())
      << "scan at t=" << scan.stamp_seconds << " has mismatched angles and ranges";
  const Eigen::Matrix3d nav_R_robot =
      RotationFromRollPitchYaw(attitude.roll_radians, attitude.pitch_radians, 0.0);
  const Eigen::Isometry3d& robot_T_sensor = scan.robot_T_sensor;
  std::vector<ProjectedPoint> points;
  points.reserve(scan.ranges_meters.size());
  for (size_t i = 0; i < scan.ranges_meters.size(); ++i) {
    const double r = scan.ranges_meters[i];
    if (!scan.IsValidRange(r)) continue;
    const double a = scan.angles_radians[i];
    const Eigen::Vector3d e_sensor(r * std::cos(a), r * std::sin(a), 0.0);
    const Eigen::Vector3d p_nav = nav_R_robot * (robot_T_sensor * e_sensor) +
                                  Eigen::Vector3d(0.0, 0.0, attitude.base_height_meters);
    points.push_back({p_nav.head<2>().cast<float>(), static_cast<float>(p_nav.z()),
                      static_cast<int>(i)});
  }
  return points;
}

std::vector<Eigen::Vector2f> ScanPointsInRobotFrame(const LaserScan& scan) {
  std::vector<Eigen::Vector2f> points;
  for (const ProjectedPoint& p : ProjectScan(scan, BodyAttitude())) points.push_back(p.p_robot);
  return points;
}

std::vector<Eigen::Vector2f> VoxelFilter(const std::vector<Eigen::Vector2f>& points, float voxel_size_meters,
                                         VoxelPoint keep) {
  CHECK_GT(voxel_size_meters, 0.f) << "voxel_size_meters=" << voxel_size_meters;
  // A point's voxel key; false for a point that has none.
  const auto voxel_key = [voxel_size_meters](const Eigen::Vector2f& p, uint64_t* key) {
    // In float, as the voxels were always computed (a double division moves points that lie
    // on a voxel border to the next voxel, and changes which point a voxel keeps).
    const float fx = std::floor(p.x() / voxel_size_meters);
    const float fy = std::floor(p.y() / voxel_size_meters);
    // A non-finite point, or one whose voxel index does not fit an int64, is no usable point.
    if (!(std::abs(fx) < 9e18f && std::abs(fy) < 9e18f)) return false;
    const int64_t ix = static_cast<int64_t>(fx);
    const int64_t iy = static_cast<int64_t>(fy);
    *key = (static_cast<uint64_t>(ix) << 32) ^ (static_cast<uint64_t>(iy) & 0xffffffffu);
    return true;
  };
  std::vector<Eigen::Vector2f> kept;
  if (keep == VoxelPoint::kFirst) {
    std::unordered_set<uint64_t> seen;
    for (const Eigen::Vector2f& p : points) {
      uint64_t key;
      if (voxel_key(p, &key) && seen.insert(key).second) kept.push_back(p);
    }
    return kept;
  }
  if (keep == VoxelPoint::kFirstAndLast) {
    std::unordered_map<uint64_t, int> voxel_of_key;  // key -> voxel (order of its first point)
    std::vector<std::array<size_t, 2>> ends;         // each voxel's first and last point
    for (size_t i = 0; i < points.size(); ++i) {
      uint64_t key;
      if (!voxel_key(points[i], &key)) continue;
      const auto [it, inserted] = voxel_of_key.emplace(key, static_cast<int>(ends.size()));
      if (inserted) ends.push_back({i, i});
      ends[it->second][1] = i;
    }
    kept.reserve(2 * ends.size());
    for (const auto& [first, last] : ends) {
      kept.push_back(points[first]);
      if (last != first) kept.push_back(points[last]);
    }
    return kept;
  }
  // kMiddle: count each voxel's points, then take the middle of each on a second pass.
  std::unordered_map<uint64_t, int> voxel_of_key;  // key -> voxel (order of its first point)
  std::vector<int> voxel_of_point(points.size(), -1);
  std::vector<int> count;
  for (size_t i = 0; i < points.size(); ++i) {
    uint64_t key;
    if (!voxel_key(points[i], &key)) continue;
    const auto [it, inserted] = voxel_of_key.emplace(key, static_cast<int>(count.size()));
    if (inserted) count.push_back(0);
    voxel_of_point[i] = it->second;
    ++count[it->second];
  }
  kept.assign(count.size(), Eigen::Vector2f::Zero());
  std::vector<int> seen(count.size(), 0);
  for (size_t i = 0; i < points.size(); ++i) {
    const int v = voxel_of_point[i];
    if (v < 0) continue;
    const int index = seen[v]++;
    const int n = count[v];
    if (n % 2 == 1) {
      if (index == n / 2) kept[v] = points[i];
    } else if (index == n / 2 - 1 || index == n / 2) {
      kept[v] += 0.5f * points[i];
    }
  }
  return kept;
}

}  // namespace hetslam
