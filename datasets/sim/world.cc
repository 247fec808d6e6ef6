#include "datasets/sim/world.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <sstream>

#include "glog/logging.h"

namespace hetslam {
namespace sim {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

double Cross(const Eigen::Vector2d& u, const Eigen::Vector2d& v) {
  return u.x() * v.y() - u.y() * v.x();
}

// Orientation of the triangle (p, q, r): +1 counter-clockwise, -1 clockwise, 0 collinear.
int Orientation(const Eigen::Vector2d& p, const Eigen::Vector2d& q, const Eigen::Vector2d& r) {
  const double c = Cross(q - p, r - p);
  const double scale = (q - p).norm() * (r - p).norm();
  if (std::abs(c) <= 1e-12 * scale) return 0;
  return c > 0.0 ? 1 : -1;
}

// For collinear p, q, r: is r within the bounding box of p..q?
bool OnSegment(const Eigen::Vector2d& p, const Eigen::Vector2d& q, const Eigen::Vector2d& r) {
  return r.x() <= std::max(p.x(), q.x()) && r.x() >= std::min(p.x(), q.x()) &&
         r.y() <= std::max(p.y(), q.y()) && r.y() >= std::min(p.y(), q.y());
}

bool SegmentsIntersect(const Eigen::Vector2d& p1, const Eigen::Vector2d& q1,
                       const Eigen::Vector2d& p2, const Eigen::Vector2d& q2) {
  const int o1 = Orientation(p1, q1, p2), o2 = Orientation(p1, q1, q2);
  const int o3 = Orientation(p2, q2, p1), o4 = Orientation(p2, q2, q1);
  if (o1 != o2 && o3 != o4) return true;
  if (o1 == 0 && OnSegment(p1, q1, p2)) return true;
  if (o2 == 0 && OnSegment(p1, q1, q2)) return true;
  if (o3 == 0 && OnSegment(p2, q2, p1)) return true;
  if (o4 == 0 && OnSegment(p2, q2, q1)) return true;
  return false;
}

// The distance t >= 0 along the ray origin + t * d (|d| = 1) to `wall`, or +infinity when the
// ray misses it or runs parallel to it. The one intersection formula of CastRay and CastRays.
double RayWallDistance(const Eigen::Vector2d& origin, const Eigen::Vector2d& d,
                       const WallSegment& wall) {
  // origin + t d = a + s e  =>  t = (w x e) / (d x e),  s = (w x d) / (d x e),  w = a - origin.
  const Eigen::Vector2d e = wall.b - wall.a;
  const double denom = Cross(d, e);
  if (std::abs(denom) <= 1e-12 * e.norm()) return std::numeric_limits<double>::infinity();
  const Eigen::Vector2d w = wall.a - origin;
  const double t = Cross(w, e) / denom;
  const double s = Cross(w, d) / denom;
  if (t < 0.0 || s < 0.0 || s > 1.0) return std::numeric_limits<double>::infinity();
  return t;
}

double PointSegmentDistance(const Eigen::Vector2d& p, const Eigen::Vector2d& a,
                            const Eigen::Vector2d& b) {
  const Eigen::Vector2d ab = b - a;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0.0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return (a + t * ab - p).norm();
}

// ---- Scenario parsing -----------------------------------------------------------------------

// Splits a line into white-space separated tokens, dropping a '#' comment.
std::vector<std::string> Tokenize(const std::string& line) {
  const std::string content = line.substr(0, line.find('#'));
  std::istringstream stream(content);
  std::vector<std::string> tokens;
  std::string token;
  while (stream >> token) tokens.push_back(token);
  return tokens;
}

// Context for error messages of one line.
struct LineContext {
  const std::string& source;
  int line_number;
  Status Error(const std::string& message) const {
    return Status::Error(source + ":" + std::to_string(line_number) + ": " + message);
  }
};

// Parses tokens[1..] as exactly `expected` finite numbers (or between `expected` and
// `expected_max` when the latter is larger).
Status ParseNumbers(const std::vector<std::string>& tokens, size_t expected, size_t expected_max,
                    const std::string& usage, const LineContext& context,
                    std::vector<double>* values) {
  const size_t given = tokens.size() - 1;
  if (given < expected || given > std::max(expected, expected_max)) {
    return context.Error("'" + tokens[0] + "' takes " +
                         (expected_max > expected ? std::to_string(expected) + " or " +
                                                        std::to_string(expected_max)
                                                  : std::to_string(expected)) +
                         " numbers (" + usage + "), got " + std::to_string(given));
  }
  values->clear();
  for (size_t i = 1; i < tokens.size(); ++i) {
    const std::string& token = tokens[i];
    char* end = nullptr;
    errno = 0;
    const double value = std::strtod(token.c_str(), &end);
    if (end == token.c_str() || *end != '\0') {
      return context.Error("'" + tokens[0] + "' field " + std::to_string(i) + " '" + token +
                           "' is not a number (" + usage + ")");
    }
    if (!std::isfinite(value) || errno == ERANGE) {
      return context.Error("'" + tokens[0] + "' field " + std::to_string(i) + " '" + token +
                           "' is not a finite number");
    }
    values->push_back(value);
  }
  return Status::Ok();
}

bool IsInteger(double value) { return std::floor(value) == value; }

}  // namespace

// ---- World ----------------------------------------------------------------------------------

void World::AddWall(const Eigen::Vector2d& a, const Eigen::Vector2d& b, int source_line) {
  CHECK(a.allFinite() && b.allFinite()) << "wall end points must be finite: (" << a.transpose()
                                        << ") (" << b.transpose() << ")";
  CHECK_GT((b - a).norm(), 0.0) << "zero-length wall at (" << a.transpose() << ")";
  walls_.push_back({a, b, source_line});
}

void World::AddBox(const Eigen::Vector2d& center, const Eigen::Vector2d& size_meters,
                   double yaw_radians, int source_line) {
  CHECK(size_meters.x() > 0.0 && size_meters.y() > 0.0)
      << "box size must be positive: " << size_meters.transpose();
  const Pose2 world_T_box(center, yaw_radians);
  const double hx = 0.5 * size_meters.x(), hy = 0.5 * size_meters.y();
  const Eigen::Vector2d corners[4] = {world_T_box * Eigen::Vector2d(-hx, -hy),
                                      world_T_box * Eigen::Vector2d(hx, -hy),
                                      world_T_box * Eigen::Vector2d(hx, hy),
                                      world_T_box * Eigen::Vector2d(-hx, hy)};
  for (int i = 0; i < 4; ++i) AddWall(corners[i], corners[(i + 1) % 4], source_line);
}

bool World::CastRay(const Eigen::Vector2d& origin, double angle_radians,
                    double max_range_meters, double* range_meters) const {
  CHECK(range_meters != nullptr);
  const Eigen::Vector2d d(std::cos(angle_radians), std::sin(angle_radians));
  double best = std::numeric_limits<double>::infinity();
  for (const WallSegment& wall : walls_) best = std::min(best, RayWallDistance(origin, d, wall));
  if (best > max_range_meters) return false;
  *range_meters = best;
  return true;
}

void World::CastRays(const Eigen::Vector2d& origin, const std::vector<double>& angles_radians,
                     double max_range_meters, std::vector<double>* ranges_meters) const {
  CHECK(ranges_meters != nullptr);
  constexpr double kInfinity = std::numeric_limits<double>::infinity();
  const size_t n = angles_radians.size();
  ranges_meters->assign(n, kInfinity);
  if (n == 0) return;
  // Rays sorted by wrapped angle in [-pi, pi); the directions use the caller's angles as given,
  // exactly as CastRay does, so both give the same numbers.
  std::vector<std::pair<double, int>> sorted(n);
  std::vector<Eigen::Vector2d> directions(n);
  for (size_t i = 0; i < n; ++i) {
    sorted[i] = {WrapAngle(angles_radians[i]), static_cast<int>(i)};
    directions[i] = Eigen::Vector2d(std::cos(angles_radians[i]), std::sin(angles_radians[i]));
  }
  std::sort(sorted.begin(), sorted.end());
  auto test_rays_in = [&](double lo, double hi, const WallSegment& wall) {
    auto it = std::lower_bound(sorted.begin(), sorted.end(), std::make_pair(lo, -1));
    for (; it != sorted.end() && it->first <= hi; ++it) {
      double& range = (*ranges_meters)[it->second];
      range = std::min(range, RayWallDistance(origin, directions[it->second], wall));
    }
  };
  // Widening of each wall's angular interval, so that rays through an end point are never
  // culled by rounding in atan2.
  constexpr double kSlackRadians = 1e-9;
  for (const WallSegment& wall : walls_) {
    const double distance = PointSegmentDistance(origin, wall.a, wall.b);
    if (distance > max_range_meters) continue;
    if (distance <= 1e-9) {
      // The origin is on (or within rounding of) the wall: rays leave it at t ~ 0 in almost
      // every direction. Test every ray, as CastRay does.
      test_rays_in(-M_PI - 1.0, M_PI + 1.0, wall);
      continue;
    }
    // The wall subtends the shorter arc (less than pi: the origin is off the segment) from
    // angle(pa) to angle(pb).
    const Eigen::Vector2d pa = wall.a - origin, pb = wall.b - origin;
    double start = WrapAngle(std::atan2(pa.y(), pa.x()));
    double width = WrapAngle(std::atan2(pb.y(), pb.x()) - start);
    if (width < 0.0) {
      start = WrapAngle(start + width);
      width = -width;
    }
    const double lo = start - kSlackRadians;
    const double hi = start + width + kSlackRadians;
    test_rays_in(lo, std::min(hi, M_PI), wall);
    if (lo < -M_PI) test_rays_in(lo + 2.0 * M_PI, M_PI, wall);
    if (hi >= M_PI) test_rays_in(-M_PI, hi - 2.0 * M_PI, wall);
  }
  for (double& range : *ranges_meters) {
    if (range > max_range_meters) range = kInfinity;
  }
}

bool World::SegmentHitsWall(const Eigen::Vector2d& p, const Eigen::Vector2d& q) const {
  for (const WallSegment& wall : walls_) {
    if (SegmentsIntersect(p, q, wall.a, wall.b)) return true;
  }
  return false;
}

double World::DistanceToNearestWall(const Eigen::Vector2d& p) const {
  double best = std::numeric_limits<double>::infinity();
  for (const WallSegment& wall : walls_) {
    best = std::min(best, PointSegmentDistance(p, wall.a, wall.b));
  }
  return best;
}

Eigen::AlignedBox2d World::Bounds() const {
  Eigen::AlignedBox2d box;  // empty
  for (const WallSegment& wall : walls_) {
    box.extend(wall.a);
    box.extend(wall.b);
  }
  return box;
}

// ---- Options --------------------------------------------------------------------------------

bool LaserOptions::IsValid(std::string* error) const {
  std::ostringstream why;
  if (!(field_of_view_radians > 0.0 && field_of_view_radians <= 2.0 * M_PI + 1e-12)) {
    why << "laser field of view must be in (0, 360] degrees, got "
        << field_of_view_radians / kDegToRad;
  } else if (num_beams < 2 || num_beams > 100000) {
    why << "laser num_beams must be in [2, 100000], got " << num_beams;
  } else if (!(max_range_meters > 0.0 && max_range_meters <= 1000.0)) {
    why << "laser max range must be in (0, 1000] m, got " << max_range_meters;
  } else if (!(range_noise_std_meters >= 0.0 && range_noise_std_meters < max_range_meters)) {
    why << "laser range noise std must be in [0, max range), got " << range_noise_std_meters;
  } else if (!(dropout_probability >= 0.0 && dropout_probability < 1.0)) {
    why << "laser dropout probability must be in [0, 1), got " << dropout_probability;
  } else if (!(rate_hz > 0.0 && rate_hz <= 1000.0)) {
    why << "laser rate must be in (0, 1000] Hz, got " << rate_hz;
  }
  if (why.str().empty()) return true;
  if (error != nullptr) *error = why.str();
  return false;
}

double LaserOptions::AngleIncrementRadians() const {
  CHECK_GE(num_beams, 2) << "num_beams=" << num_beams;
  return num_beams % 2 == 1 ? field_of_view_radians / (num_beams - 1)
                            : field_of_view_radians / num_beams;
}

std::vector<double> LaserOptions::BeamAnglesRadians() const {
  const double increment = AngleIncrementRadians();
  std::vector<double> angles(num_beams);
  for (int i = 0; i < num_beams; ++i) angles[i] = -0.5 * field_of_view_radians + i * increment;
  return angles;
}

bool RobotOptions::IsValid(std::string* error) const {
  std::ostringstream why;
  if (!(max_speed_mps > 0.0 && max_speed_mps <= 20.0)) {
    why << "robot speed must be in (0, 20] m/s, got " << max_speed_mps;
  } else if (!(max_turn_rate_radps > 0.0 && max_turn_rate_radps <= 4.0 * M_PI)) {
    why << "robot turn rate must be in (0, 720] deg/s, got " << max_turn_rate_radps / kDegToRad;
  }
  if (why.str().empty()) return true;
  if (error != nullptr) *error = why.str();
  return false;
}

bool OdometryOptions::IsValid(std::string* error) const {
  std::ostringstream why;
  if (!(rate_hz > 0.0 && rate_hz <= 1000.0)) {
    why << "odometry rate must be in (0, 1000] Hz, got " << rate_hz;
  } else if (!(trans_noise_meters_per_sqrt_meter >= 0.0 &&
               std::isfinite(trans_noise_meters_per_sqrt_meter))) {
    why << "odometry translation noise must be finite and >= 0, got "
        << trans_noise_meters_per_sqrt_meter;
  } else if (!(rot_noise_radians_per_sqrt_meter >= 0.0 &&
               std::isfinite(rot_noise_radians_per_sqrt_meter))) {
    why << "odometry rotation noise per sqrt(m) must be finite and >= 0, got "
        << rot_noise_radians_per_sqrt_meter;
  } else if (!(rot_noise_radians_per_sqrt_radian >= 0.0 &&
               std::isfinite(rot_noise_radians_per_sqrt_radian))) {
    why << "odometry rotation noise per sqrt(rad) must be finite and >= 0, got "
        << rot_noise_radians_per_sqrt_radian;
  }
  if (why.str().empty()) return true;
  if (error != nullptr) *error = why.str();
  return false;
}

// ---- Scenario -------------------------------------------------------------------------------

Pose2 Scenario::InitialPose() const {
  if (has_start_pose) return start_pose;
  CHECK(!waypoints.empty()) << "scenario '" << source_name << "' has no waypoints";
  if (waypoints.size() == 1) return Pose2(waypoints[0], 0.0);
  const Eigen::Vector2d heading = waypoints[1] - waypoints[0];
  return Pose2(waypoints[0], std::atan2(heading.y(), heading.x()));
}

int Scenario::FirstWaypointToReach() const { return has_start_pose ? 0 : 1; }

bool Scenario::IsValid(std::string* error) const {
  std::string why;
  const bool options_valid = laser.IsValid(&why) && robot.IsValid(&why) && odometry.IsValid(&why);
  if (!options_valid) {
    // `why` names the first invalid option.
  } else if (waypoints.empty()) {
    why = "scenario has no 'waypoint' lines (at least one is needed)";
  } else if (world.empty()) {
    why = "scenario has no walls ('wall' or 'box' lines)";
  } else if (!(duration_limit_seconds > 0.0)) {
    why = "duration limit must be positive";
  }
  if (why.empty()) return true;
  if (error != nullptr) *error = why;
  return false;
}

Status ParseScenario(const std::string& text, const std::string& source_name,
                     Scenario* scenario) {
  CHECK(scenario != nullptr);
  *scenario = Scenario();
  scenario->source_name = source_name;
  std::istringstream stream(text);
  std::string line;
  int line_number = 0;
  // Line of each singleton statement already seen (0 = not yet).
  int laser_line = 0, robot_line = 0, odometry_line = 0, duration_line = 0, start_line = 0;
  std::vector<double> v;
  while (std::getline(stream, line)) {
    ++line_number;
    const std::vector<std::string> tokens = Tokenize(line);
    if (tokens.empty()) continue;
    const LineContext context{source_name, line_number};
    const std::string& keyword = tokens[0];
    auto once = [&](int* seen_line) -> Status {
      if (*seen_line != 0) {
        return context.Error("'" + keyword + "' given twice (first on line " +
                             std::to_string(*seen_line) + ")");
      }
      *seen_line = line_number;
      return Status::Ok();
    };
    Status status;
    if (keyword == "wall") {
      if (!(status = ParseNumbers(tokens, 4, 4, "wall x1 y1 x2 y2", context, &v)).ok()) {
        return status;
      }
      const Eigen::Vector2d a(v[0], v[1]), b(v[2], v[3]);
      if ((b - a).norm() < 1e-6) return context.Error("wall has zero length");
      scenario->world.AddWall(a, b, line_number);
    } else if (keyword == "box") {
      if (!(status = ParseNumbers(tokens, 4, 5, "box cx cy w h [yaw_deg]", context, &v)).ok()) {
        return status;
      }
      if (!(v[2] > 0.0 && v[3] > 0.0)) {
        return context.Error("box width and height must be positive");
      }
      const double yaw = v.size() == 5 ? v[4] * kDegToRad : 0.0;
      scenario->world.AddBox(Eigen::Vector2d(v[0], v[1]), Eigen::Vector2d(v[2], v[3]), yaw,
                             line_number);
    } else if (keyword == "waypoint") {
      if (!(status = ParseNumbers(tokens, 2, 2, "waypoint x y", context, &v)).ok()) {
        return status;
      }
      scenario->waypoints.emplace_back(v[0], v[1]);
    } else if (keyword == "start") {
      if (!(status = once(&start_line)).ok()) return status;
      if (!(status = ParseNumbers(tokens, 3, 3, "start x y yaw_deg", context, &v)).ok()) {
        return status;
      }
      scenario->has_start_pose = true;
      scenario->start_pose = Pose2(v[0], v[1], v[2] * kDegToRad);
    } else if (keyword == "laser") {
      if (!(status = once(&laser_line)).ok()) return status;
      if (!(status = ParseNumbers(
                tokens, 6, 6,
                "laser fov_deg num_beams max_range_m noise_std_m dropout_prob rate_hz", context,
                &v))
               .ok()) {
        return status;
      }
      if (!IsInteger(v[1]) || std::abs(v[1]) > 1e9) {
        return context.Error("laser num_beams must be an integer, got " + tokens[2]);
      }
      LaserOptions& laser = scenario->laser;
      laser.field_of_view_radians = v[0] * kDegToRad;
      laser.num_beams = static_cast<int>(v[1]);
      laser.max_range_meters = v[2];
      laser.range_noise_std_meters = v[3];
      laser.dropout_probability = v[4];
      laser.rate_hz = v[5];
      std::string why;
      if (!laser.IsValid(&why)) return context.Error(why);
    } else if (keyword == "robot") {
      if (!(status = once(&robot_line)).ok()) return status;
      if (!(status = ParseNumbers(tokens, 2, 2, "robot speed_mps turn_rate_dps", context, &v))
               .ok()) {
        return status;
      }
      scenario->robot.max_speed_mps = v[0];
      scenario->robot.max_turn_rate_radps = v[1] * kDegToRad;
      std::string why;
      if (!scenario->robot.IsValid(&why)) return context.Error(why);
    } else if (keyword == "odometry") {
      if (!(status = once(&odometry_line)).ok()) return status;
      if (!(status = ParseNumbers(tokens, 4, 4,
                                  "odometry rate_hz trans_noise_m_per_sqrt_m "
                                  "rot_noise_deg_per_sqrt_m rot_noise_deg_per_sqrt_deg",
                                  context, &v))
               .ok()) {
        return status;
      }
      OdometryOptions& odometry = scenario->odometry;
      odometry.rate_hz = v[0];
      odometry.trans_noise_meters_per_sqrt_meter = v[1];
      odometry.rot_noise_radians_per_sqrt_meter = v[2] * kDegToRad;
      // deg/sqrt(deg) -> rad/sqrt(rad): sigma_rad = k_deg * sqrt(dtheta_deg) * d2r
      //                                           = k_deg * sqrt(d2r) * sqrt(dtheta_rad).
      odometry.rot_noise_radians_per_sqrt_radian =
          v[3] >= 0.0 ? v[3] * std::sqrt(kDegToRad) : v[3];
      std::string why;
      if (!odometry.IsValid(&why)) return context.Error(why);
    } else if (keyword == "duration_limit_s") {
      if (!(status = once(&duration_line)).ok()) return status;
      if (!(status = ParseNumbers(tokens, 1, 1, "duration_limit_s seconds", context, &v)).ok()) {
        return status;
      }
      if (!(v[0] > 0.0)) return context.Error("duration_limit_s must be positive");
      scenario->duration_limit_seconds = v[0];
    } else {
      return context.Error("unknown keyword '" + keyword +
                           "' (expected wall, box, waypoint, start, laser, robot, odometry or "
                           "duration_limit_s)");
    }
  }
  std::string why;
  if (!scenario->IsValid(&why)) return Status::Error(source_name + ": " + why);
  return Status::Ok();
}

Status ReadScenarioFile(const std::string& path, Scenario* scenario) {
  std::ifstream file(path);
  if (!file) return Status::Error(path + ": cannot open scenario file");
  std::ostringstream contents;
  contents << file.rdbuf();
  if (file.bad()) return Status::Error(path + ": error while reading scenario file");
  return ParseScenario(contents.str(), path, scenario);
}

}  // namespace sim
}  // namespace hetslam
