#include "core/team_manifest.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <utility>

#include "core/file_io.h"
#include "core/robot_log_text.h"
#include "core/text_fields.h"
#include "glog/logging.h"

namespace hetslam {

namespace {

using text_fields::ParseFiniteDouble;
using text_fields::ParseInteger;

}  // namespace

std::string TeamManifest::RobotLogPath(const TeamRobot& robot) const {
  const std::string robot_directory = robot_log_text::JoinPath(directory, robot.directory);
  return robot_log_text::JoinPath(robot_directory, "log.txt");
}

Status ReadTeamManifest(const std::string& path, TeamManifest* manifest) {
  CHECK(manifest != nullptr) << "ReadTeamManifest: manifest is null";
  *manifest = TeamManifest();
  manifest->path = path;
  manifest->directory = robot_log_text::DirectoryOf(path);
  std::ifstream in;
  HETSLAM_RETURN_IF_ERROR(robot_log_text::OpenForReading(path, &in));
  auto where = [&](int line_number) { return path + ":" + std::to_string(line_number) + ": "; };

  bool have_header = false;
  std::map<std::string, int> robot_lines;                  // name -> line
  std::map<std::pair<std::string, int>, int> tag_lines;    // (family, id) -> line
  std::string line;
  std::vector<std::string> fields;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    text_fields::Split(line, &fields);
    if (fields.empty() || fields[0][0] == '#') continue;
    const std::string& type = fields[0];
    if (!have_header) {
      int version = 0;
      const Status status = robot_log_text::CheckHeader(fields, "HSTEAM", &version);
      if (!status.ok()) return Status::Error(where(line_number) + status.message());
      have_header = true;
      continue;
    }
    if (type == "robot") {
      if (fields.size() != 4) {
        return Status::Error(where(line_number) + "robot needs 3 fields (name kind directory), "
                             "found " + std::to_string(fields.size() - 1));
      }
      TeamRobot robot;
      robot.name = fields[1];
      robot.kind = fields[2];
      robot.directory = fields[3];
      robot.line_number = line_number;
      if (!robot_log_text::StaysInside(robot.directory)) {
        return Status::Error(where(line_number) + "robot " + robot.name + " directory '" + robot.directory +
                             "' leaves the dataset (an absolute path or a '..' component): it must be relative to "
                             "the manifest's folder and inside it");
      }
      if (robot.kind != "wheeled" && robot.kind != "uav" && robot.kind != "humanoid") {
        return Status::Error(where(line_number) + "robot " + robot.name + " has unknown kind '" +
                             robot.kind + "' (wheeled, uav or humanoid)");
      }
      const auto [it, inserted] = robot_lines.emplace(robot.name, line_number);
      if (!inserted) {
        return Status::Error(where(line_number) + "robot name '" + robot.name +
                             "' is already used on line " + std::to_string(it->second));
      }
      manifest->robots.push_back(robot);
    } else if (type == "tag") {
      if (fields.size() != 10) {
        return Status::Error(where(line_number) + "tag needs 9 fields (id family size x y z roll "
                             "pitch yaw), found " + std::to_string(fields.size() - 1));
      }
      TagTruth tag;
      tag.line_number = line_number;
      long long id = 0;
      if (!ParseInteger(fields[1], 0, std::numeric_limits<int>::max(), &id)) {
        return Status::Error(where(line_number) + "tag id ('" + fields[1] +
                             "') is not a non-negative integer");
      }
      tag.id = static_cast<int>(id);
      tag.family = fields[2];
      if (!ParseFiniteDouble(fields[3], &tag.size_meters) || !(tag.size_meters > 0.0)) {
        return Status::Error(where(line_number) + "tag size ('" + fields[3] +
                             "') is not a positive number of metres");
      }
      double v[6];
      for (int i = 0; i < 6; ++i) {
        if (!ParseFiniteDouble(fields[4 + i], &v[i])) {
          return Status::Error(where(line_number) + "tag " + robot_log_text::kPoseNames[i] +
                               " ('" + fields[4 + i] + "') is not a finite number");
        }
      }
      tag.world_T_tag = robot_log_text::PoseFromValues(v);
      const auto [it, inserted] =
          tag_lines.emplace(std::make_pair(tag.family, tag.id), line_number);
      if (!inserted) {
        return Status::Error(where(line_number) + "tag " + tag.family + " " + fields[1] +
                             " is already placed on line " + std::to_string(it->second));
      }
      manifest->tags.push_back(tag);
    } else if (type == "HSTEAM") {
      return Status::Error(where(line_number) + "HSTEAM header repeated");
    } else {
      return Status::Error(where(line_number) + "unknown message '" + type +
                           "' (robot or tag)");
    }
  }
  return robot_log_text::CheckEndOfFile(in, path, line_number, have_header, "HSTEAM");
}

Status WriteTeamManifest(const std::string& path, const TeamManifest& manifest,
                         const std::vector<std::string>& comment_lines) {
  std::set<std::string> names;
  for (const TeamRobot& robot : manifest.robots) {
    if (!robot_log_text::IsPlainWord(robot.name) ||
        !robot_log_text::IsPlainWord(robot.directory)) {
      return Status::Error("robot '" + robot.name + "' in '" + robot.directory +
                           "': name and directory must be one word not starting with '#'");
    }
    if (robot.kind != "wheeled" && robot.kind != "uav" && robot.kind != "humanoid") {
      return Status::Error("robot " + robot.name + " has unknown kind '" + robot.kind + "'");
    }
    if (!names.insert(robot.name).second) {
      return Status::Error("robot name '" + robot.name + "' is used twice");
    }
  }
  std::set<std::pair<std::string, int>> tags;
  for (const TagTruth& tag : manifest.tags) {
    const std::string which = "tag " + tag.family + " " + std::to_string(tag.id);
    if (tag.id < 0 || !robot_log_text::IsPlainWord(tag.family)) {
      return Status::Error(which + ": needs an id >= 0 and a one-word family");
    }
    if (!std::isfinite(tag.size_meters) || !(tag.size_meters > 0.0)) {
      return Status::Error(which + " has size " + robot_log_text::FormatDouble(tag.size_meters) +
                           "; needs a positive size");
    }
    if (!robot_log_text::IsWritablePose(tag.world_T_tag)) {
      return Status::Error(which + ": world_T_tag is not a finite rigid pose");
    }
    if (!tags.insert({tag.family, tag.id}).second) {
      return Status::Error(which + " is placed twice");
    }
  }
  FILE* file = nullptr;
  HETSLAM_RETURN_IF_ERROR(OpenForWriting(path, "w", &file));
  std::fprintf(file, "HSTEAM %d\n", robot_log_text::kVersion);
  WriteCommentLines(file, comment_lines);
  for (const TeamRobot& robot : manifest.robots) {
    std::fprintf(file, "robot %s %s %s\n", robot.name.c_str(), robot.kind.c_str(),
                 robot.directory.c_str());
  }
  for (const TagTruth& tag : manifest.tags) {
    std::fprintf(file, "tag %d %s %s %s\n", tag.id, tag.family.c_str(),
                 robot_log_text::FormatDouble(tag.size_meters).c_str(),
                 robot_log_text::FormatPose(tag.world_T_tag).c_str());
  }
  return CommitWrittenFile(file, path);
}

}  // namespace hetslam
