// SE(2) rigid transforms for planar poses.
//
// A Pose2 `a_T_b` maps points expressed in frame b into frame a:
//   p_a = a_T_b * p_b = R(theta) * p_b + t.
// Poses are (x, y, theta) in metres and radians, right-handed, theta wrapped to [-pi, pi).
// Composition: a_T_c = a_T_b * b_T_c. Relative pose of b seen from a: a.inverse() * b
// (see Between()).
#ifndef HETSLAM_CORE_SE2_H_
#define HETSLAM_CORE_SE2_H_

#include <cmath>
#include <ostream>

#include "Eigen/Core"

namespace hetslam {

// Wraps an angle to [-pi, pi). Plain double; the Jet-friendly version used inside Ceres
// cost functions lives in factors/angle.h.
inline double WrapAngle(double angle_radians) {
  constexpr double kTwoPi = 2.0 * M_PI;
  double wrapped = std::fmod(angle_radians + M_PI, kTwoPi);
  if (wrapped < 0.0) wrapped += kTwoPi;
  return wrapped - M_PI;
}

class Pose2 {
 public:
  Pose2() = default;
  Pose2(double x, double y, double theta) : translation_(x, y), theta_(WrapAngle(theta)) {}
  Pose2(const Eigen::Vector2d& translation, double theta)
      : translation_(translation), theta_(WrapAngle(theta)) {}

  static Pose2 Identity() { return Pose2(); }

  double x() const { return translation_.x(); }
  double y() const { return translation_.y(); }
  double theta() const { return theta_; }
  const Eigen::Vector2d& translation() const { return translation_; }
  Eigen::Matrix2d rotation() const {
    const double c = std::cos(theta_), s = std::sin(theta_);
    Eigen::Matrix2d r;
    r << c, -s, s, c;
    return r;
  }

  Pose2 inverse() const {
    const double c = std::cos(theta_), s = std::sin(theta_);
    // R^T * (-t)
    return Pose2(-c * x() - s * y(), s * x() - c * y(), -theta_);
  }

  Pose2 operator*(const Pose2& rhs) const {
    const double c = std::cos(theta_), s = std::sin(theta_);
    return Pose2(x() + c * rhs.x() - s * rhs.y(), y() + s * rhs.x() + c * rhs.y(),
                 theta_ + rhs.theta_);
  }

  Eigen::Vector2d operator*(const Eigen::Vector2d& p) const {
    const double c = std::cos(theta_), s = std::sin(theta_);
    return Eigen::Vector2d(x() + c * p.x() - s * p.y(), y() + s * p.x() + c * p.y());
  }

  // operator*(p) for many points: the cosine and sine taken once, the same doubles. (They are
  // libm calls that a loop does not hoist: one per point was 2–3% of a FR079 run.)
  class PointTransform {
   public:
    explicit PointTransform(const Pose2& pose)
        : x_(pose.x()), y_(pose.y()), c_(std::cos(pose.theta())), s_(std::sin(pose.theta())) {}
    Eigen::Vector2d operator()(const Eigen::Vector2d& p) const {
      return Eigen::Vector2d(x_ + c_ * p.x() - s_ * p.y(), y_ + s_ * p.x() + c_ * p.y());
    }

   private:
    double x_, y_, c_, s_;
  };

  Eigen::Vector3d ToVector() const { return Eigen::Vector3d(x(), y(), theta_); }
  static Pose2 FromVector(const Eigen::Vector3d& v) { return Pose2(v.x(), v.y(), v.z()); }

 private:
  Eigen::Vector2d translation_ = Eigen::Vector2d::Zero();
  double theta_ = 0.0;
};

// Pose of b expressed in frame a, given world_T_a and world_T_b: a_T_b = world_T_a^-1 * world_T_b.
inline Pose2 Between(const Pose2& world_T_a, const Pose2& world_T_b) {
  return world_T_a.inverse() * world_T_b;
}

// Pose interpolated between a (alpha = 0) and b (alpha = 1): translation linearly, rotation
// along the shorter arc.
inline Pose2 Interpolate(const Pose2& a, const Pose2& b, double alpha) {
  const double dtheta = WrapAngle(b.theta() - a.theta());
  return Pose2(a.translation() + alpha * (b.translation() - a.translation()),
               a.theta() + alpha * dtheta);
}

inline std::ostream& operator<<(std::ostream& os, const Pose2& pose) {
  return os << "(" << pose.x() << ", " << pose.y() << ", " << pose.theta() << ")";
}

}  // namespace hetslam

#endif  // HETSLAM_CORE_SE2_H_
