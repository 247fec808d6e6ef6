// The team simulator: several robots (wheeled, UAV, humanoid) in a 2.5D world, each with a 3D
// ray-cast 2D laser, a MARG unit, a camera that sees AprilTags and ground truth, written as an
// HSLOG/HSTEAM dataset (core/robot_log.h, core/team_manifest.h). The single-robot 2D path
// (simulator.h) is separate and unchanged.
//
// Time: every robot starts at t = 0. The controller runs and the 6D truth is integrated at the
// control rate (dt = 1 / control_rate_hz); sensors sample that truth at their own rates,
// t_j = j / rate, interpolating between control steps (linear in position, slerp in rotation)
// when their stamps fall between them. A robot's log ends when its plan is done and it stands
// still, or at the duration limit.
//
// Motion (the command is body-frame (vx, vy, yaw rate), logged as COMMAND at the control rate;
// its changes are limited to the kind's acceleration limits):
//  - wheeled: the unicycle waypoint controller of simulator.h (vy = 0), exact arcs, level body
//    on the floor.
//  - humanoid: the same controller at <= 0.15 m/s; vy allowed in scripted commands. While
//    walking, the body sways with the steps (1 Hz, roll +-2°, lateral +-1.5 cm, scaled by the
//    speed); the head pitch follows RobotSpec::head_profile and moves laser and camera.
//  - UAV: holonomic: the controller asks for a world velocity towards the waypoint (braking
//    into stop waypoints) and turns the nose towards it; the velocity follows the command with
//    a first-order lag (0.25 s), altitude is held by vz = clamp(1/s * error, +-0.4 m/s) with
//    the same lag. The accelerations tilt the airframe as a multirotor's must: target pitch =
//    atan(a_forward / g), target roll = -atan(a_left / g) (heading frame), followed with a
//    0.15 s first-order lag and clamped to +-15°.
// Rates for the MARG come from the integrated truth by finite differences at the control rate:
// a_world(k) = (p(k+1) - 2 p(k) + p(k-1)) / dt², omega_body(k) = (log(R(k-1)^T R(k)) +
// log(R(k)^T R(k+1))) / (2 dt), with p(-1) = p(0), R(-1) = R(0) (robots start at rest) and,
// after the last step, the last velocity and rate extrapolated (p(K+1) = 2 p(K) - p(K-1)).
//
// Sensors: laser (LASER; MOUNT at every scan for humanoids, once at t = 0 otherwise) with the
// noise and dropouts of SimulateScan, no return written as max range; MARG + ATTITUDE (model
// in MargOptions, robot_spec.h); camera (IMAGE + a PNG, tags visible when TagCamera::IsInView and
// a clear line of sight from the camera to the tag's centre and four corners); ODOM (wheeled,
// OdometryOptions noise, odometry frame = the robot's start pose); ALTITUDE (UAV,
// AltimeterOptions); TRUTH world_T_body at every LASER and IMAGE stamp.
//
// Randomness: random obstacles are placed first with the caller's generator; then two numbers
// per robot, in scenario order, seed that robot's sensor generator and its image-noise
// generator. Everything is therefore a function of the caller's seed: same seed, same bytes.
#ifndef HETSLAM_DATASETS_SIM_TEAM_SIMULATOR_H_
#define HETSLAM_DATASETS_SIM_TEAM_SIMULATOR_H_

#include <cstdint>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "Eigen/Core"
#include "Eigen/Geometry"
#include "core/laser_scan.h"
#include "core/robot_log.h"
#include "core/status.h"
#include "datasets/sim/scenario.h"
#include "datasets/sim/truth_layers.h"

namespace hetslam {
namespace sim {

struct TeamSimulatorOptions {
  double control_rate_hz = 100.0;    // controller, COMMAND lines and truth integration
  double max_duration_seconds = 0.0; // > 0: stop here if earlier than the scenario's limit
  bool render_images = true;         // false: IMAGE lines are logged, no PNG is written
  double world_image_pixels_per_meter = 40.0;
  TruthLayerOptions truth_layers;    // the true map layers written with the dataset

  // Control rate in (0, 1000] Hz, max duration finite and >= 0, pixels per metre in (0, 1000],
  // valid truth layer options.
  bool IsValid(std::string* error) const;
};

// One sample of a robot's integrated truth (at the control rate).
struct TruthSample {
  double stamp_seconds = 0.0;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // world_T_body translation
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();  // world_R_body
  Eigen::Vector3d acceleration_world = Eigen::Vector3d::Zero();  // finite differences
  Eigen::Vector3d rate_body = Eigen::Vector3d::Zero();           // finite differences
};

// A camera frame the writer renders: where the camera was and which tags it sees.
struct CameraFrame {
  double stamp_seconds = 0.0;
  Eigen::Isometry3d world_T_camera = Eigen::Isometry3d::Identity();  // optical frame
  std::vector<int> visible_tags;  // indices into Scenario::tags
  std::string relative_path;      // "images/NNNNNN.png", as in the IMAGE line
};

struct RobotSimulation {
  std::string name;
  RobotKind kind = RobotKind::kWheeled;
  RobotLog log;                     // every message (the images themselves are not in it)
  std::vector<CameraFrame> frames;  // one per IMAGE message
  std::vector<TruthSample> truth;   // at the control rate
  std::uint64_t image_noise_seed = 0;
  bool completed = false;           // the plan was finished before the duration limit
  double duration_seconds = 0.0;
  double path_length_meters = 0.0;  // horizontal distance travelled
  int num_no_return_beams = 0;
  std::map<Surface, int> beams_by_surface;  // what the returned beams hit (before noise)
  SeenCells seen;  // the true layers' cells its returned beams ended on (truth_layers.h)
};

struct TeamSimulationResult {
  World world;  // the scenario's world with the random obstacles placed
  std::vector<RobotSimulation> robots;  // scenario order
};

// Adds the scenario's random obstacles to `world` (a copy of scenario.world): boxes 0.15 to
// 0.4 m wide, heights in [0.05, max height], random yaw, uniformly in their region, at least
// 0.1 m from every wall and prism and 0.45 m from every robot's start and waypoint legs.
// An error naming the scenario line when they do not fit after many tries.
Status PlaceRandomObstacles(const Scenario& scenario, std::mt19937_64* rng, World* world);

// Whether every robot's planned route (start, then every waypoint, in straight legs) stays
// clear of `world`: the simulator moves robots through anything (it has no collisions), so a
// leg through a wall, a pillar or a shelf gives a log no robot could record. Blocked: a wall
// (any robot; a UAV above the walls' top passes), a prism reaching below 0.3 m for wheeled and
// humanoid robots (a table's legs and a floor obstacle block, its top does not), a prism
// reaching above the leg's altitude minus 0.2 m for a UAV. An error naming the waypoint's line
// and what is in the way.
Status CheckRoutesClear(const Scenario& scenario, const World& world);

// One 2D laser scan ray-cast in 3D from world_T_laser (beams in the laser's x-y plane, angles
// of LaserOptions::BeamAnglesRadians), with the noise and dropouts of SimulateScan: two draws
// per beam; no hit within range, a dropout or a noisy range outside (0, max) is written as the
// max range. `surfaces` (optional) receives what each beam hit before noise (kNone: nothing);
// `returned` (optional) each beam's hit before noise when the beam returned (one not written
// as the max range), else a RayHit with hit = false.
LaserScan SimulateScan3D(const World& world, const LaserOptions& laser,
                         const Eigen::Isometry3d& world_T_laser, double stamp_seconds,
                         std::mt19937_64* rng, std::vector<Surface>* surfaces = nullptr,
                         int* num_no_return = nullptr, std::vector<RayHit>* returned = nullptr);

// Runs a team scenario (Scenario::IsTeam()). Errors: an invalid scenario or options, a route
// through a wall or furniture (CheckRoutesClear), random obstacles that do not fit.
Status SimulateTeam(const Scenario& scenario, const TeamSimulatorOptions& options,
                    std::mt19937_64* rng, TeamSimulationResult* result);

struct TeamDatasetFiles {
  std::string manifest_path;                 // <dir>/team.txt
  std::vector<std::string> robot_log_paths;  // <dir>/<robot>/log.txt
  std::string world_image_path;              // <dir>/world.png
  std::string truth_layers_directory;        // <dir>/truth_layers
  std::vector<std::string> truth_layer_paths;  // its .pgm and .yaml files (WriteTruthLayers)
  int images_written = 0;
};

// Writes the dataset: <dir>/team.txt (robots and tag truth), <dir>/<robot>/log.txt,
// <dir>/<robot>/images/NNNNNN.png (rendered by TagCamera when options.render_images),
// <dir>/truth_layers/{walls,furniture,floor_obstacles}.{pgm,yaml} (the true map layers of
// result.world, truth_layers.h), <dir>/<robot>/seen_layers/ (the same three, restricted to
// what that robot's laser returned from: SeenTruthLayers) and <dir>/world.png. `directory` is created if missing.
// `comment_lines` go into the manifest and every log (e.g. scenario and seed).
Status WriteTeamDataset(const std::string& directory, const Scenario& scenario,
                        const TeamSimulationResult& result, const TeamSimulatorOptions& options,
                        const std::vector<std::string>& comment_lines, TeamDatasetFiles* files);

// The floor plan seen from above, north up: walls (black), furniture (tan; a table's top
// outline), floor obstacles (brown), tags (red marks with their id), a 1 m grid and each
// robot's true path in its own colour with its start (circle) and name.
Status WriteTeamWorldImage(const std::string& path, const Scenario& scenario,
                           const TeamSimulationResult& result, double pixels_per_meter);

}  // namespace sim
}  // namespace hetslam

#endif  // HETSLAM_DATASETS_SIM_TEAM_SIMULATOR_H_
