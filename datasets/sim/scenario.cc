#include "datasets/sim/scenario.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <utility>

#include "core/euler.h"
#include "core/robot_log_text.h"
#include "datasets/sim/sim_text.h"
#include "glog/logging.h"

namespace hetslam {
namespace sim {
namespace {

constexpr double kDegToRad = M_PI / 180.0;
// Every number of a scenario is within +-kMaxMagnitude (positions in metres, angles in degrees,
// rates, counts): beyond it a world is not a building and sizes lose their precision.
constexpr double kMaxMagnitude = 1e6;
// Sizes (box and obstacle sides, shelf depths) are at least this: smaller shapes round to
// degenerate walls and prisms far from the origin.
constexpr double kMinSizeMeters = 1e-3;
// A simulation runs at most a day of simulated time.
constexpr double kMaxDurationSeconds = 86400.0;

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
    if (std::abs(value) > kMaxMagnitude) {
      return context.Error("'" + tokens[0] + "' field " + std::to_string(i) + " '" + token +
                           "' is beyond +-1e6 (every number of a scenario is)");
    }
    values->push_back(value);
  }
  return Status::Ok();
}

bool IsInteger(double value) { return std::floor(value) == value; }

Eigen::Isometry3d PoseFromXyzRpy(const Eigen::Vector3d& xyz, double roll, double pitch,
                                 double yaw) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = RotationFromRollPitchYaw(roll, pitch, yaw);
  pose.translation() = xyz;
  return pose;
}

}  // namespace

Eigen::Isometry3d TagSpec::WorldTTag() const {
  const double c = std::cos(normal_yaw_radians), s = std::sin(normal_yaw_radians);
  Eigen::Isometry3d world_T_tag = Eigen::Isometry3d::Identity();
  world_T_tag.linear().col(0) = Eigen::Vector3d(-s, c, 0.0);  // right, seen facing the tag
  world_T_tag.linear().col(1) = Eigen::Vector3d(0.0, 0.0, 1.0);  // up
  world_T_tag.linear().col(2) = Eigen::Vector3d(c, s, 0.0);   // out of the wall
  world_T_tag.translation() = center;
  return world_T_tag;
}

// ---- Scenario -------------------------------------------------------------------------------

// Scenario::IsValid's bound of num_beams x rate x duration summed over the lasers (about 5 GB
// of log text).
constexpr double kMaxSimulatedBeams = 1e9;
// Scenario::IsValid's bound of the world's extent (the world image, truth grids and ray casts
// are sized by it).
constexpr double kMaxWorldSpanMeters = 1000.0;

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
  if (!IsTeam()) {
    const bool options_valid =
        laser.IsValid(&why) && robot.IsValid(&why) && odometry.IsValid(&why);
    if (!options_valid) {
      // `why` names the first invalid option.
    } else if (waypoints.empty()) {
      why = "scenario has no 'waypoint' lines (at least one is needed)";
    }
  } else {
    for (size_t i = 0; i < robots.size() && why.empty(); ++i) {
      if (!robots[i].IsValid(&why)) break;
      for (size_t j = 0; j < i; ++j) {
        if (robots[j].name == robots[i].name) why = "robot name '" + robots[i].name + "' used twice";
      }
    }
    for (size_t i = 0; i < tags.size() && why.empty(); ++i) {
      if (tags[i].id < 0 || tags[i].id > 586) {
        why = "tag id " + std::to_string(tags[i].id) + " is not a tag36h11 id (0 .. 586)";
      }
      for (size_t j = 0; j < i; ++j) {
        if (tags[j].id == tags[i].id) why = "tag id " + std::to_string(tags[i].id) + " used twice";
      }
    }
  }
  if (!why.empty()) {
    // Reported below.
  } else if (world.empty()) {
    why = "scenario has no walls ('wall' or 'box' lines)";
  } else if (!(world.Bounds().sizes().maxCoeff() <= kMaxWorldSpanMeters)) {
    std::ostringstream text;
    text << "the world spans " << world.Bounds().sizes().x() << " x " << world.Bounds().sizes().y()
         << " m, more than " << kMaxWorldSpanMeters << " m a side (a building, not a country)";
    why = text.str();
  } else if (!(duration_limit_seconds > 0.0 && duration_limit_seconds <= 86400.0)) {
    why = "duration limit must be in (0, 86400] s";
  } else {
    // Work and output size: the beams simulated over the duration limit (each a ray cast and
    // a number in the log).
    double beams = 0.0;
    if (!IsTeam()) beams = laser.num_beams * laser.rate_hz * duration_limit_seconds;
    for (const RobotSpec& spec : robots) beams += spec.laser.num_beams * spec.laser.rate_hz * duration_limit_seconds;
    if (beams > kMaxSimulatedBeams) {
      std::ostringstream text;
      text << "the lasers would cast " << beams << " beams over duration_limit_s " << duration_limit_seconds
           << ", more than " << kMaxSimulatedBeams << ": lower the beam counts, the laser rates or duration_limit_s";
      why = text.str();
    }
  }
  if (why.empty()) return true;
  if (error != nullptr) *error = why;
  return false;
}

namespace {

constexpr char kTopLevelKeywords[] =
    "wall, box, wall_height, ceiling, table, shelf, obstacle, random_obstacles, tag, "
    "robot_begin, waypoint, start, laser, robot, odometry or duration_limit_s";
constexpr char kRobotKeywords[] =
    "start, altitude, waypoint, stand, command, speed, laser, laser_mount, head_joint_height, "
    "head_level, head_hold, head_move, head_sweep, marg, camera, camera_mount, odometry, "
    "altimeter or robot_end";

// One pass over the scenario text. Statements outside robot blocks fill the world and the
// single-robot settings; inside a block they fill that robot's spec.
class ScenarioParser {
 public:
  ScenarioParser(const std::string& source_name, Scenario* scenario)
      : source_(source_name), scenario_(scenario) {}

  Status Parse(const std::string& text) {
    std::istringstream stream(text);
    std::string line;
    int line_number = 0;
    while (std::getline(stream, line)) {
      ++line_number;
      const std::vector<std::string> tokens = Tokenize(line);
      if (tokens.empty()) continue;
      const LineContext context{source_, line_number};
      HETSLAM_RETURN_IF_ERROR(robot_ == nullptr ? TopLevel(tokens, context)
                                                : RobotStatement(tokens, context));
    }
    if (robot_ != nullptr) {
      return Status::Error(source_ + ":" + std::to_string(robot_->source_line) + ": robot block '" +
                           robot_->name + "' is not closed (robot_end missing)");
    }
    if (scenario_->IsTeam() && !single_robot_lines_.empty()) {
      const auto& first = single_robot_lines_.front();
      return Status::Error(source_ + ":" + std::to_string(first.second) + ": '" + first.first +
                           "' outside a robot block: in a scenario with robot blocks every "
                           "robot statement goes inside its robot_begin .. robot_end block");
    }
    // Heights: walls reach the ceiling unless wall_height says otherwise.
    const double wall_height =
        wall_height_ > 0.0 ? wall_height_ : (std::isfinite(ceiling_) ? ceiling_ : 2.6);
    scenario_->world.SetHeights(wall_height, ceiling_);
    // Tags sit on something: a surface within 2 cm behind the tag's centre.
    for (const TagSpec& tag : scenario_->tags) {
      const Eigen::Vector3d normal = tag.WorldTTag().linear().col(2);
      const RayHit hit = scenario_->world.CastRay3D(tag.center + 0.02 * normal, -normal, 0.04);
      if (!hit.hit) {
        return Status::Error(source_ + ":" + std::to_string(tag.source_line) + ": tag " +
                             std::to_string(tag.id) +
                             " is not on a wall (nothing within 2 cm behind its centre; its "
                             "yaw is the direction it faces)");
      }
      if (tag.center.z() - 0.5 * tag.size_meters * 1.25 < 0.0 ||
          tag.center.z() + 0.5 * tag.size_meters * 1.25 > wall_height) {
        return Status::Error(source_ + ":" + std::to_string(tag.source_line) + ": tag " +
                             std::to_string(tag.id) + " does not fit between floor and wall top");
      }
    }
    std::string why;
    if (!scenario_->IsValid(&why)) return Status::Error(source_ + ": " + why);
    return Status::Ok();
  }

 private:
  // Records the first line of a singleton statement; an error when seen before.
  Status Once(std::map<std::string, int>* seen, const std::string& keyword,
              const LineContext& context) {
    const auto it = seen->find(keyword);
    if (it != seen->end()) {
      return context.Error("'" + keyword + "' given twice (first on line " +
                           std::to_string(it->second) + ")");
    }
    (*seen)[keyword] = context.line_number;
    return Status::Ok();
  }

  Status ParseLaser(const std::vector<std::string>& tokens, const LineContext& context,
                    LaserOptions* laser) {
    std::vector<double> v;
    HETSLAM_RETURN_IF_ERROR(ParseNumbers(
        tokens, 6, 6, "laser fov_deg num_beams max_range_m noise_std_m dropout_prob rate_hz",
        context, &v));
    if (!IsInteger(v[1]) || std::abs(v[1]) > 1e9) {
      return context.Error("laser num_beams must be an integer, got " + tokens[2]);
    }
    laser->field_of_view_radians = v[0] * kDegToRad;
    laser->num_beams = static_cast<int>(v[1]);
    laser->max_range_meters = v[2];
    laser->range_noise_std_meters = v[3];
    laser->dropout_probability = v[4];
    laser->rate_hz = v[5];
    std::string why;
    if (!laser->IsValid(&why)) return context.Error(why);
    return Status::Ok();
  }

  Status ParseOdometry(const std::vector<std::string>& tokens, const LineContext& context,
                       OdometryOptions* odometry) {
    std::vector<double> v;
    HETSLAM_RETURN_IF_ERROR(ParseNumbers(tokens, 4, 4,
                                         "odometry rate_hz trans_noise_m_per_sqrt_m "
                                         "rot_noise_deg_per_sqrt_m rot_noise_deg_per_sqrt_deg",
                                         context, &v));
    odometry->rate_hz = v[0];
    odometry->trans_noise_meters_per_sqrt_meter = v[1];
    odometry->rot_noise_radians_per_sqrt_meter = v[2] * kDegToRad;
    // deg/sqrt(deg) -> rad/sqrt(rad): sigma_rad = k_deg * sqrt(dtheta_deg) * d2r
    //                                           = k_deg * sqrt(d2r) * sqrt(dtheta_rad).
    odometry->rot_noise_radians_per_sqrt_radian = v[3] >= 0.0 ? v[3] * std::sqrt(kDegToRad) : v[3];
    std::string why;
    if (!odometry->IsValid(&why)) return context.Error(why);
    return Status::Ok();
  }

  Status ParseSpeed(const std::vector<std::string>& tokens, const std::string& usage,
                    const LineContext& context, RobotOptions* motion) {
    std::vector<double> v;
    HETSLAM_RETURN_IF_ERROR(ParseNumbers(tokens, 2, 2, usage, context, &v));
    motion->max_speed_mps = v[0];
    motion->max_turn_rate_radps = v[1] * kDegToRad;
    std::string why;
    if (!motion->IsValid(&why)) return context.Error(why);
    return Status::Ok();
  }

  // A box-like statement "KEY cx cy w h height [yaw_deg]".
  Status ParseBoxPrism(const std::vector<std::string>& tokens, const std::string& usage,
                       const LineContext& context, std::vector<double>* v) {
    HETSLAM_RETURN_IF_ERROR(ParseNumbers(tokens, 5, 6, usage, context, v));
    if (!((*v)[2] >= kMinSizeMeters && (*v)[3] >= kMinSizeMeters && (*v)[4] >= kMinSizeMeters)) {
      return context.Error("'" + tokens[0] + "' width, depth and height must be positive, at least 1 mm");
    }
    if ((*v)[4] > 100.0) return context.Error("'" + tokens[0] + "' height must be <= 100 m");
    if (v->size() == 5) v->push_back(0.0);
    return Status::Ok();
  }

  Status TopLevel(const std::vector<std::string>& tokens, const LineContext& context) {
    const std::string& keyword = tokens[0];
    std::vector<double> v;
    World& world = scenario_->world;
    if (keyword == "wall") {
      HETSLAM_RETURN_IF_ERROR(ParseNumbers(tokens, 4, 4, "wall x1 y1 x2 y2", context, &v));
      const Eigen::Vector2d a(v[0], v[1]), b(v[2], v[3]);
      if ((b - a).norm() < 1e-6) return context.Error("wall has zero length");
      world.AddWall(a, b, context.line_number);
    } else if (keyword == "box") {
      HETSLAM_RETURN_IF_ERROR(ParseNumbers(tokens, 4, 5, "box cx cy w h [yaw_deg]", context, &v));
      if (!(v[2] >= kMinSizeMeters && v[3] >= kMinSizeMeters)) {
        return context.Error("box width and height must be positive, at least 1 mm");
      }
      const double yaw = v.size() == 5 ? v[4] * kDegToRad : 0.0;
      world.AddBox(Eigen::Vector2d(v[0], v[1]), Eigen::Vector2d(v[2], v[3]), yaw,
                   context.line_number);
    } else if (keyword == "wall_height") {
      HETSLAM_RETURN_IF_ERROR(Once(&seen_, keyword, context));
      HETSLAM_RETURN_IF_ERROR(ParseNumbers(tokens, 1, 1, "wall_height meters", context, &v));
      if (!(v[0] > 0.0 && v[0] <= 100.0)) {
        return context.Error("wall_height must be in (0, 100] m");
      }
      wall_height_ = v[0];
    } else if (keyword == "ceiling") {
      HETSLAM_RETURN_IF_ERROR(Once(&seen_, keyword, context));
      if (tokens.size() == 2 && tokens[1] == "none") {
        ceiling_ = std::numeric_limits<double>::infinity();
        return Status::Ok();
      }
      HETSLAM_RETURN_IF_ERROR(
          ParseNumbers(tokens, 1, 1, "ceiling meters | ceiling none", context, &v));
      if (!(v[0] > 0.0 && v[0] <= 100.0)) return context.Error("ceiling must be in (0, 100] m");
      ceiling_ = v[0];
    } else if (keyword == "table") {
      HETSLAM_RETURN_IF_ERROR(
          ParseBoxPrism(tokens, "table cx cy w h height [yaw_deg]", context, &v));
      const TableShape shape;
      const double leg_span = 2.0 * (shape.leg_inset_meters + shape.leg_width_meters);
      if (!(v[2] > leg_span && v[3] > leg_span)) {
        return context.Error("table sides must be larger than " + Fixed(leg_span, 2) +
                             " m (room for the legs)");
      }
      if (!(v[4] > shape.top_thickness_meters)) {
        return context.Error("table height must be larger than its top's thickness " +
                             Fixed(shape.top_thickness_meters, 2) + " m");
      }
      world.AddTable(Eigen::Vector2d(v[0], v[1]), Eigen::Vector2d(v[2], v[3]), v[5] * kDegToRad,
                     v[4], context.line_number, shape);
    } else if (keyword == "obstacle") {
      HETSLAM_RETURN_IF_ERROR(
          ParseBoxPrism(tokens, "obstacle cx cy w h height [yaw_deg]", context, &v));
      world.AddBoxPrism(Eigen::Vector2d(v[0], v[1]), Eigen::Vector2d(v[2], v[3]),
                        v[5] * kDegToRad, 0.0, v[4], Surface::kObstacle, context.line_number);
    } else if (keyword == "shelf") {
      const std::string usage =
          "shelf x1 y1 x2 y2 lower_depth lower_height upper_depth height";
      HETSLAM_RETURN_IF_ERROR(ParseNumbers(tokens, 8, 8, usage, context, &v));
      if ((Eigen::Vector2d(v[2], v[3]) - Eigen::Vector2d(v[0], v[1])).norm() < kMinSizeMeters) {
        return context.Error("shelf back has zero length (under 1 mm)");
      }
      if (!(v[4] >= kMinSizeMeters && v[5] > 0.0 && v[6] >= kMinSizeMeters && v[7] > v[5] && v[7] <= 100.0)) {
        return context.Error("shelf depths and heights must be positive, height > lower_height");
      }
      world.AddShelf(Eigen::Vector2d(v[0], v[1]), Eigen::Vector2d(v[2], v[3]), v[4], v[5], v[6],
                     v[7], context.line_number);
    } else if (keyword == "random_obstacles") {
      HETSLAM_RETURN_IF_ERROR(
          ParseNumbers(tokens, 6, 6, "random_obstacles n x0 y0 x1 y1 max_height", context, &v));
      if (!IsInteger(v[0]) || v[0] < 1 || v[0] > 1000) {
        return context.Error("random_obstacles count must be an integer in [1, 1000], got " +
                             tokens[1]);
      }
      if (!(v[1] < v[3] && v[2] < v[4])) {
        return context.Error("random_obstacles region needs x0 < x1 and y0 < y1");
      }
      if (!(v[5] >= 0.05 && v[5] <= 2.0)) {
        return context.Error("random_obstacles max_height must be in [0.05, 2] m");
      }
      RandomObstacleSpec spec;
      spec.count = static_cast<int>(v[0]);
      spec.region = Eigen::AlignedBox2d(Eigen::Vector2d(v[1], v[2]), Eigen::Vector2d(v[3], v[4]));
      spec.max_height_meters = v[5];
      spec.source_line = context.line_number;
      scenario_->random_obstacles.push_back(spec);
    } else if (keyword == "tag") {
      HETSLAM_RETURN_IF_ERROR(ParseNumbers(tokens, 6, 6, "tag id size x y z yaw_deg", context, &v));
      if (!IsInteger(v[0]) || v[0] < 0 || v[0] > 586) {
        return context.Error("tag id must be a tag36h11 id (an integer in [0, 586]), got " +
                             tokens[1]);
      }
      if (!(v[1] > 0.0 && v[1] <= 2.0)) return context.Error("tag size must be in (0, 2] m");
      TagSpec tag;
      tag.id = static_cast<int>(v[0]);
      tag.size_meters = v[1];
      tag.center = Eigen::Vector3d(v[2], v[3], v[4]);
      tag.normal_yaw_radians = v[5] * kDegToRad;
      tag.source_line = context.line_number;
      for (const TagSpec& other : scenario_->tags) {
        if (other.id == tag.id) {
          return context.Error("tag id " + tokens[1] + " used twice (first on line " +
                               std::to_string(other.source_line) + ")");
        }
      }
      scenario_->tags.push_back(tag);
    } else if (keyword == "robot_begin") {
      if (tokens.size() != 3) {
        return context.Error("'robot_begin' takes a name and a kind (robot_begin NAME "
                             "wheeled|uav|humanoid), got " + std::to_string(tokens.size() - 1) +
                             " fields");
      }
      RobotKind kind;
      if (tokens[2] == "wheeled") {
        kind = RobotKind::kWheeled;
      } else if (tokens[2] == "uav") {
        kind = RobotKind::kUav;
      } else if (tokens[2] == "humanoid") {
        kind = RobotKind::kHumanoid;
      } else {
        return context.Error("unknown robot kind '" + tokens[2] +
                             "' (expected wheeled, uav or humanoid)");
      }
      const std::string& name = tokens[1];
      for (char c : name) {
        if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-')) {
          return context.Error("robot name '" + name +
                               "' may only hold letters, digits, '_' and '-' (it names a folder)");
        }
      }
      for (const RobotSpec& other : scenario_->robots) {
        if (other.name == name) {
          return context.Error("robot name '" + name + "' used twice (first on line " +
                               std::to_string(other.source_line) + ")");
        }
      }
      scenario_->robots.push_back(DefaultRobotSpec(name, kind));
      robot_ = &scenario_->robots.back();
      robot_->source_line = context.line_number;
      robot_seen_.clear();
    } else if (keyword == "robot_end") {
      return context.Error("'robot_end' without robot_begin");
    } else if (keyword == "waypoint") {
      single_robot_lines_.emplace_back(keyword, context.line_number);
      HETSLAM_RETURN_IF_ERROR(ParseNumbers(tokens, 2, 2, "waypoint x y", context, &v));
      scenario_->waypoints.emplace_back(v[0], v[1]);
    } else if (keyword == "start") {
      single_robot_lines_.emplace_back(keyword, context.line_number);
      HETSLAM_RETURN_IF_ERROR(Once(&seen_, keyword, context));
      HETSLAM_RETURN_IF_ERROR(ParseNumbers(tokens, 3, 3, "start x y yaw_deg", context, &v));
      scenario_->has_start_pose = true;
      scenario_->start_pose = Pose2(v[0], v[1], v[2] * kDegToRad);
    } else if (keyword == "laser") {
      single_robot_lines_.emplace_back(keyword, context.line_number);
      HETSLAM_RETURN_IF_ERROR(Once(&seen_, keyword, context));
      return ParseLaser(tokens, context, &scenario_->laser);
    } else if (keyword == "robot") {
      single_robot_lines_.emplace_back(keyword, context.line_number);
      HETSLAM_RETURN_IF_ERROR(Once(&seen_, keyword, context));
      return ParseSpeed(tokens, "robot speed_mps turn_rate_dps", context, &scenario_->robot);
    } else if (keyword == "odometry") {
      single_robot_lines_.emplace_back(keyword, context.line_number);
      HETSLAM_RETURN_IF_ERROR(Once(&seen_, keyword, context));
      return ParseOdometry(tokens, context, &scenario_->odometry);
    } else if (keyword == "duration_limit_s") {
      HETSLAM_RETURN_IF_ERROR(Once(&seen_, keyword, context));
      HETSLAM_RETURN_IF_ERROR(ParseNumbers(tokens, 1, 1, "duration_limit_s seconds", context, &v));
      if (!(v[0] > 0.0 && v[0] <= kMaxDurationSeconds)) {
        return context.Error("duration_limit_s must be positive and at most 86400 s");
      }
      scenario_->duration_limit_seconds = v[0];
    } else {
      return context.Error("unknown keyword '" + keyword + "' (expected " + kTopLevelKeywords +
                           ")");
    }
    return Status::Ok();
  }

  Status RobotStatement(const std::vector<std::string>& tokens, const LineContext& context) {
    const std::string& keyword = tokens[0];
    RobotSpec& robot = *robot_;
    const std::string kind_name = RobotKindName(robot.kind);
    auto only_for = [&](RobotKind kind) -> Status {
      if (robot.kind == kind) return Status::Ok();
      return context.Error("'" + keyword + "' is for " + RobotKindName(kind) + " robots, and '" +
                           robot.name + "' is " + kind_name);
    };
    std::vector<double> v;
    static const char* const kSingletons[] = {
        "start", "altitude", "speed", "laser", "laser_mount", "head_joint_height", "marg",
        "camera", "camera_mount", "odometry", "altimeter"};
    for (const char* singleton : kSingletons) {
      if (keyword == singleton) HETSLAM_RETURN_IF_ERROR(Once(&robot_seen_, keyword, context));
    }
    if (keyword == "robot_end") {
      if (tokens.size() != 1) return context.Error("'robot_end' takes no fields");
      std::string why;
      if (!robot.IsValid(&why)) {
        return Status::Error(source_ + ":" + std::to_string(robot.source_line) + ": " + why);
      }
      robot_ = nullptr;
    } else if (keyword == "start") {
      HETSLAM_RETURN_IF_ERROR(ParseNumbers(tokens, 3, 3, "start x y yaw_deg", context, &v));
      robot.has_start_pose = true;
      robot.start_pose = Pose2(v[0], v[1], v[2] * kDegToRad);
    } else if (keyword == "altitude") {
      HETSLAM_RETURN_IF_ERROR(only_for(RobotKind::kUav));
      HETSLAM_RETURN_IF_ERROR(ParseNumbers(tokens, 1, 1, "altitude meters", context, &v));
      if (!(v[0] >= 0.2 && v[0] <= 10.0)) return context.Error("altitude must be in [0.2, 10] m");
      robot.altitude_meters = v[0];
    } else if (keyword == "waypoint") {
      const bool uav = robot.kind == RobotKind::kUav;
      HETSLAM_RETURN_IF_ERROR(ParseNumbers(
          tokens, 2, uav ? 3 : 2, uav ? "waypoint x y [altitude]" : "waypoint x y", context, &v));
      RouteStep step;
      step.type = RouteStep::Type::kWaypoint;
      step.target = Eigen::Vector2d(v[0], v[1]);
      if (v.size() == 3) {
        if (!(v[2] >= 0.2 && v[2] <= 10.0)) {
          return context.Error("waypoint altitude must be in [0.2, 10] m");
        }
        step.altitude_meters = v[2];
      }
      step.source_line = context.line_number;
      robot.route.push_back(step);
    } else if (keyword == "stand") {
      HETSLAM_RETURN_IF_ERROR(ParseNumbers(tokens, 1, 1, "stand seconds", context, &v));
      if (!(v[0] > 0.0)) return context.Error("stand duration must be positive");
      RouteStep step;
      step.type = RouteStep::Type::kStand;
      step.duration_seconds = v[0];
      step.source_line = context.line_number;
      robot.route.push_back(step);
    } else if (keyword == "command") {
      HETSLAM_RETURN_IF_ERROR(
          ParseNumbers(tokens, 4, 4, "command seconds vx_mps vy_mps yaw_rate_dps", context, &v));
      if (!(v[0] > 0.0)) return context.Error("command duration must be positive");
      if (robot.kind == RobotKind::kWheeled && v[2] != 0.0) {
        return context.Error("a wheeled robot cannot move sideways (vy must be 0)");
      }
      if (std::hypot(v[1], v[2]) > robot.motion.max_speed_mps + 1e-12 ||
          std::abs(v[3] * kDegToRad) > robot.motion.max_turn_rate_radps + 1e-12) {
        return context.Error("command exceeds the robot's speed or yaw rate limit (" +
                             Fixed(robot.motion.max_speed_mps, 3) + " m/s, " +
                             Fixed(robot.motion.max_turn_rate_radps / kDegToRad, 1) +
                             " deg/s; set 'speed' first)");
      }
      RouteStep step;
      step.type = RouteStep::Type::kCommand;
      step.duration_seconds = v[0];
      step.vx_mps = v[1];
      step.vy_mps = v[2];
      step.yaw_rate_radps = v[3] * kDegToRad;
      step.source_line = context.line_number;
      robot.route.push_back(step);
    } else if (keyword == "speed") {
      HETSLAM_RETURN_IF_ERROR(
          ParseSpeed(tokens, "speed max_speed_mps turn_rate_dps", context, &robot.motion));
      if (robot.kind == RobotKind::kHumanoid && robot.motion.max_speed_mps > 0.15) {
        return context.Error("a humanoid walks at most 0.15 m/s");
      }
    } else if (keyword == "laser") {
      return ParseLaser(tokens, context, &robot.laser);
    } else if (keyword == "laser_mount" || keyword == "camera_mount") {
      HETSLAM_RETURN_IF_ERROR(
          ParseNumbers(tokens, 6, 6, keyword + " x y z roll_deg pitch_deg yaw_deg", context, &v));
      if (keyword == "laser_mount") {
        robot.body_T_laser = PoseFromXyzRpy(Eigen::Vector3d(v[0], v[1], v[2]), v[3] * kDegToRad,
                                            v[4] * kDegToRad, v[5] * kDegToRad);
      } else {
        robot.camera.laser_T_camera = CameraOptions::DefaultLaserTCamera(
            Eigen::Vector3d(v[0], v[1], v[2]), v[3] * kDegToRad, v[4] * kDegToRad,
            v[5] * kDegToRad);
      }
    } else if (keyword == "head_joint_height") {
      HETSLAM_RETURN_IF_ERROR(only_for(RobotKind::kHumanoid));
      HETSLAM_RETURN_IF_ERROR(ParseNumbers(tokens, 1, 1, "head_joint_height meters", context, &v));
      if (!(v[0] > 0.0 && v[0] < 5.0)) return context.Error("head_joint_height must be in (0, 5) m");
      robot.head_joint_height_meters = v[0];
    } else if (keyword == "head_level" || keyword == "head_hold" || keyword == "head_move" ||
               keyword == "head_sweep") {
      HETSLAM_RETURN_IF_ERROR(only_for(RobotKind::kHumanoid));
      HeadPhase phase;
      if (keyword == "head_level") {
        HETSLAM_RETURN_IF_ERROR(ParseNumbers(tokens, 1, 1, "head_level seconds", context, &v));
        phase.type = HeadPhase::Type::kLevel;
      } else if (keyword == "head_hold") {
        HETSLAM_RETURN_IF_ERROR(
            ParseNumbers(tokens, 2, 2, "head_hold seconds pitch_deg", context, &v));
        phase.type = HeadPhase::Type::kHold;
      } else if (keyword == "head_move") {
        HETSLAM_RETURN_IF_ERROR(
            ParseNumbers(tokens, 2, 2, "head_move seconds pitch_deg", context, &v));
        phase.type = HeadPhase::Type::kMove;
      } else {
        HETSLAM_RETURN_IF_ERROR(ParseNumbers(
            tokens, 4, 4, "head_sweep seconds min_deg max_deg period_s", context, &v));
        phase.type = HeadPhase::Type::kSweep;
      }
      if (!(v[0] > 0.0)) return context.Error("'" + keyword + "' duration must be positive");
      for (size_t i = 1; i < v.size() && (phase.type != HeadPhase::Type::kSweep || i < 3); ++i) {
        if (!(v[i] >= -30.0 && v[i] <= 60.0)) {
          return context.Error("head pitch must be in [-30, 60] degrees, got " + tokens[i + 1]);
        }
      }
      phase.duration_seconds = v[0];
      if (phase.type == HeadPhase::Type::kHold || phase.type == HeadPhase::Type::kMove) {
        phase.pitch_radians = v[1] * kDegToRad;
      }
      if (phase.type == HeadPhase::Type::kSweep) {
        if (!(v[1] < v[2])) return context.Error("head_sweep needs min_deg < max_deg");
        if (!(v[3] > 0.0)) return context.Error("head_sweep period must be positive");
        phase.min_pitch_radians = v[1] * kDegToRad;
        phase.max_pitch_radians = v[2] * kDegToRad;
        phase.period_seconds = v[3];
      }
      robot.head_profile.push_back(phase);
    } else if (keyword == "marg") {
      HETSLAM_RETURN_IF_ERROR(ParseNumbers(tokens, 9, 9,
                                           "marg rate_hz gyro_noise_dps gyro_bias_dps "
                                           "gyro_bias_walk_dps_per_sqrt_s accel_noise_mps2 "
                                           "accel_bias_mps2 mag_noise_ut attitude_noise_deg "
                                           "attitude_offset_deg",
                                           context, &v));
      MargOptions& marg = robot.marg;
      marg.rate_hz = v[0];
      marg.gyro_noise_radps = v[1] * kDegToRad;
      marg.gyro_bias_radps = v[2] * kDegToRad;
      marg.gyro_bias_walk_radps_per_sqrt_s = v[3] * kDegToRad;
      marg.accel_noise_mps2 = v[4];
      marg.accel_bias_mps2 = v[5];
      marg.mag_noise_microtesla = v[6];
      marg.attitude_noise_radians = v[7] * kDegToRad;
      marg.attitude_offset_radians = v[8] * kDegToRad;
      std::string why;
      if (!marg.IsValid(&why)) return context.Error(why);
    } else if (keyword == "camera") {
      CameraOptions& camera = robot.camera;
      if (tokens.size() == 2 && tokens[1] == "none") {
        camera.enabled = false;
        return Status::Ok();
      }
      HETSLAM_RETURN_IF_ERROR(ParseNumbers(
          tokens, 7, 7, "camera rate_hz width height fx fy cx cy | camera none", context, &v));
      if (!IsInteger(v[1]) || !IsInteger(v[2]) || std::abs(v[1]) > 1e6 || std::abs(v[2]) > 1e6) {
        return context.Error("camera width and height must be integers");
      }
      camera.enabled = true;
      camera.rate_hz = v[0];
      camera.width = static_cast<int>(v[1]);
      camera.height = static_cast<int>(v[2]);
      camera.fx = v[3];
      camera.fy = v[4];
      camera.cx = v[5];
      camera.cy = v[6];
      std::string why;
      if (!camera.IsValid(&why)) return context.Error(why);
    } else if (keyword == "odometry") {
      HETSLAM_RETURN_IF_ERROR(only_for(RobotKind::kWheeled));
      return ParseOdometry(tokens, context, &robot.odometry);
    } else if (keyword == "altimeter") {
      HETSLAM_RETURN_IF_ERROR(only_for(RobotKind::kUav));
      HETSLAM_RETURN_IF_ERROR(
          ParseNumbers(tokens, 2, 2, "altimeter rate_hz noise_std_m", context, &v));
      robot.altimeter.rate_hz = v[0];
      robot.altimeter.noise_std_meters = v[1];
      std::string why;
      if (!robot.altimeter.IsValid(&why)) return context.Error(why);
    } else {
      return context.Error("unknown keyword '" + keyword + "' inside robot block '" + robot.name +
                           "' (opened on line " + std::to_string(robot.source_line) +
                           "; expected " + kRobotKeywords + ")");
    }
    return Status::Ok();
  }

  const std::string& source_;
  Scenario* scenario_;
  RobotSpec* robot_ = nullptr;  // the open robot block, if any
  std::map<std::string, int> seen_;        // top-level singletons: first line
  std::map<std::string, int> robot_seen_;  // singletons of the open robot block
  std::vector<std::pair<std::string, int>> single_robot_lines_;  // top-level robot statements
  double wall_height_ = 0.0;  // 0: not given
  double ceiling_ = 2.6;
};

}  // namespace

Status ParseScenario(const std::string& text, const std::string& source_name,
                     Scenario* scenario) {
  CHECK(scenario != nullptr);
  *scenario = Scenario();
  scenario->source_name = source_name;
  return ScenarioParser(source_name, scenario).Parse(text);
}

Scenario MirroredScenario(const Scenario& scenario) {
  const Eigen::AlignedBox2d bounds = scenario.world.Bounds();
  const double axis = bounds.isEmpty() ? 0.0 : 0.5 * (bounds.min().x() + bounds.max().x());
  const auto point = [axis](const Eigen::Vector2d& p) { return Eigen::Vector2d(2.0 * axis - p.x(), p.y()); };
  const auto pose = [&point](const Pose2& p) { return Pose2(point(p.translation()), M_PI - p.theta()); };
  Scenario mirrored = scenario;
  mirrored.source_name = scenario.source_name + " (mirrored)";
  World& world = mirrored.world;
  world = World();
  world.SetHeights(scenario.world.wall_height_meters(), scenario.world.ceiling_height_meters());
  for (const WallSegment& wall : scenario.world.walls()) world.AddWall(point(wall.a), point(wall.b), wall.source_line);
  for (const Prism& prism : scenario.world.prisms()) {
    std::vector<Eigen::Vector2d> footprint;
    for (const Eigen::Vector2d& p : prism.footprint) footprint.push_back(point(p));
    world.AddPrism(std::move(footprint), prism.z_min_meters, prism.z_max_meters, prism.surface, prism.source_line);
  }
  for (Eigen::Vector2d& w : mirrored.waypoints) w = point(w);
  mirrored.start_pose = pose(scenario.start_pose);
  for (TagSpec& tag : mirrored.tags) {
    tag.center.x() = 2.0 * axis - tag.center.x();
    tag.normal_yaw_radians = WrapAngle(M_PI - tag.normal_yaw_radians);
  }
  for (RandomObstacleSpec& spec : mirrored.random_obstacles) {
    const Eigen::Vector2d a = point(spec.region.min()), b = point(spec.region.max());
    spec.region = Eigen::AlignedBox2d(a.cwiseMin(b), a.cwiseMax(b));
  }
  for (RobotSpec& robot : mirrored.robots) {
    robot.start_pose = pose(robot.start_pose);
    for (RouteStep& step : robot.route) {
      step.target = point(step.target);
      step.vy_mps = -step.vy_mps;
      step.yaw_rate_radps = -step.yaw_rate_radps;
    }
  }
  return mirrored;
}

Status ReadScenarioFile(const std::string& path, Scenario* scenario) {
  std::ifstream file;
  // Refuses a directory by name (an ifstream opens one and reads nothing from it).
  const Status opened = robot_log_text::OpenForReading(path, &file);
  if (!opened.ok()) return Status::Error(opened.message() + " (the scenario file)");
  std::ostringstream contents;
  contents << file.rdbuf();
  if (file.bad()) return Status::Error(path + ": error while reading scenario file");
  return ParseScenario(contents.str(), path, scenario);
}

}  // namespace sim
}  // namespace hetslam
