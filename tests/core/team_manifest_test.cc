#include "core/team_manifest.h"

#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/core/robot_log_test_util.h"

namespace hetslam {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;

TEST(TeamManifestTest, WriteThenRead) {
  TeamManifest original;
  original.robots.push_back({"ugv1", "wheeled", "ugv1", 0});
  original.robots.push_back({"uav1", "uav", "robots/uav1", 0});
  original.robots.push_back({"nao", "humanoid", "nao", 0});
  TagTruth tag;
  tag.id = 17;
  tag.family = "tag36h11";
  tag.size_meters = 0.16;
  tag.world_T_tag = MakePose(3.0, -1.25, 1.1, M_PI / 2, 0.0, M_PI);
  original.tags.push_back(tag);
  tag.id = 0;
  tag.world_T_tag = MakePose(0.1, 0.2, 0.3, 0.4, 0.5, 0.6);
  original.tags.push_back(tag);
  const std::string path = TempPath("team.txt");
  const Status write = WriteTeamManifest(path, original, {"three robots"});
  ASSERT_TRUE(write.ok()) << write.message();
  TeamManifest manifest;
  const Status read = ReadTeamManifest(path, &manifest);
  ASSERT_TRUE(read.ok()) << read.message();
  EXPECT_EQ(path, manifest.path);
  ASSERT_EQ(3u, manifest.robots.size());
  for (size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(original.robots[i].name, manifest.robots[i].name);
    EXPECT_EQ(original.robots[i].kind, manifest.robots[i].kind);
    EXPECT_EQ(original.robots[i].directory, manifest.robots[i].directory);
  }
  EXPECT_EQ(3, manifest.robots[0].line_number);
  ASSERT_EQ(2u, manifest.tags.size());
  for (size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(original.tags[i].id, manifest.tags[i].id);
    EXPECT_EQ("tag36h11", manifest.tags[i].family);
    EXPECT_EQ(0.16, manifest.tags[i].size_meters);
    ExpectSamePose(original.tags[i].world_T_tag, manifest.tags[i].world_T_tag);
  }
  EXPECT_EQ(manifest.directory + "/robots/uav1/log.txt",
            manifest.RobotLogPath(manifest.robots[1]));
  const std::string again = TempPath("team_again.txt");
  ASSERT_TRUE(WriteTeamManifest(again, original, {"three robots"}).ok());
  EXPECT_EQ(ReadText(path), ReadText(again));
}

TEST(TeamManifestTest, ErrorsNameFileAndLine) {
  const std::string head = "HSTEAM 1\n# robots\nrobot a wheeled a\n";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"robot a uav b\n", ":4: robot name 'a' is already used on line 3"},
      {"robot b tank b\n", ":4: robot b has unknown kind 'tank' (wheeled, uav or humanoid)"},
      {"robot b uav\n", ":4: robot needs 3 fields (name kind directory), found 2"},
      {"tag 1 tag36h11 0 0 0 0 0 0 0\n", ":4: tag size ('0') is not a positive number"},
      {"tag 1 tag36h11 -0.1 0 0 0 0 0 0\n", ":4: tag size ('-0.1') is not a positive number"},
      {"tag 1 tag36h11 nan 0 0 0 0 0 0\n", ":4: tag size ('nan') is not a positive number"},
      {"tag -1 tag36h11 0.1 0 0 0 0 0 0\n", ":4: tag id ('-1') is not a non-negative integer"},
      {"tag 1 tag36h11 0.1 0 0 0 0 0\n", ":4: tag needs 9 fields"},
      {"tag 1 tag36h11 0.1 0 0 0 0 x 0\n", ":4: tag pitch ('x') is not a finite number"},
      {"tag 1 tag36h11 0.1 0 0 0 0 0 0\ntag 1 tag36h11 0.2 1 0 0 0 0 0\n",
       ":5: tag tag36h11 1 is already placed on line 4"},
      {"camera 1\n", ":4: unknown message 'camera' (robot or tag)"},
      {"HSTEAM 1\n", ":4: HSTEAM header repeated"},
      // Issue #16: a robot directory must stay inside the dataset.
      {"robot x uav ../../../../etc\n", ":4: robot x directory '../../../../etc' leaves the dataset"},
      {"robot x uav /etc\n", ":4: robot x directory '/etc' leaves the dataset"},
      {"robot x uav a/../../b\n", ":4: robot x directory 'a/../../b' leaves the dataset"},
  };
  for (size_t c = 0; c < cases.size(); ++c) {
    const std::string path =
        WriteText("team_bad_" + std::to_string(c) + ".txt", head + cases[c].first);
    TeamManifest manifest;
    const Status status = ReadTeamManifest(path, &manifest);
    ASSERT_FALSE(status.ok()) << cases[c].first;
    EXPECT_THAT(status.message(), StartsWith(path + cases[c].second));
  }
  for (const std::string& text : {std::string(""), std::string("robot a wheeled a\n"),
                                  std::string("HSLOG 1\n"), std::string("HSTEAM 3\n")}) {
    const std::string path = WriteText("team_header.txt", text);
    TeamManifest manifest;
    const Status status = ReadTeamManifest(path, &manifest);
    ASSERT_FALSE(status.ok()) << text;
    EXPECT_THAT(status.message(), StartsWith(path + ":1: ")) << text;
    EXPECT_THAT(status.message(), HasSubstr("HSTEAM")) << text;
  }
}

TEST(TeamManifestTest, WriterRejectsInvalidManifests) {
  const std::string path = TempPath("team_rejected.txt");
  TeamManifest duplicate;
  duplicate.robots.push_back({"a", "uav", "a", 0});
  duplicate.robots.push_back({"a", "uav", "b", 0});
  EXPECT_THAT(WriteTeamManifest(path, duplicate, {}).message(), HasSubstr("used twice"));
  TeamManifest kind;
  kind.robots.push_back({"a", "boat", "a", 0});
  EXPECT_THAT(WriteTeamManifest(path, kind, {}).message(), HasSubstr("unknown kind 'boat'"));
  TeamManifest size;
  TagTruth tag;
  tag.family = "tag36h11";
  tag.size_meters = 0.0;
  size.tags.push_back(tag);
  EXPECT_THAT(WriteTeamManifest(path, size, {}).message(), HasSubstr("positive size"));
}

TEST(TeamManifestTest, RobotLogPathIsRelativeToTheManifest) {
  TeamManifest manifest;
  manifest.directory = "data/team";
  TeamRobot robot;
  robot.directory = "uav1";
  EXPECT_EQ("data/team/uav1/log.txt", manifest.RobotLogPath(robot));
}

}  // namespace
}  // namespace hetslam
