#include "core/g2o_io.h"

#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

#include "core/synthetic_pose_graph.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace hetslam {
namespace {

using ::testing::HasSubstr;

Status Parse(const std::string& text, PoseGraph2d* graph) {
  std::istringstream input(text);
  return ParseG2oPoseGraph2d(input, "test.g2o", graph);
}

TEST(G2oIoTest, ParsesVerticesEdgesFixAndUpperTriangularInformation) {
  const std::string text =
      "# a comment\n"
      "VERTEX_SE2 0 0 0 0\n"
      "\n"
      "VERTEX_SE2 1 1.5 -0.5 3.5\n"  // theta is wrapped to 3.5 - 2 pi
      "EDGE_SE2 0 1 1.5 -0.5 0.25 100 1 2 200 3 400\n"
      "FIX 0\n";
  PoseGraph2d graph;
  const Status status = Parse(text, &graph);
  ASSERT_TRUE(status.ok()) << status.message();
  ASSERT_EQ(2u, graph.vertices.size());
  EXPECT_EQ(1, graph.vertices[1].id);
  EXPECT_DOUBLE_EQ(1.5, graph.vertices[1].world_T_vertex.x());
  EXPECT_DOUBLE_EQ(-0.5, graph.vertices[1].world_T_vertex.y());
  EXPECT_NEAR(3.5 - 2.0 * M_PI, graph.vertices[1].world_T_vertex.theta(), 1e-12);
  ASSERT_EQ(1u, graph.edges.size());
  const PoseGraph2dEdge& edge = graph.edges[0];
  EXPECT_EQ(0, edge.id_from);
  EXPECT_EQ(1, edge.id_to);
  EXPECT_DOUBLE_EQ(0.25, edge.from_T_to_measured.theta());
  Eigen::Matrix3d expected;
  expected << 100, 1, 2, 1, 200, 3, 2, 3, 400;
  EXPECT_EQ(expected, edge.information);
  ASSERT_EQ(1u, graph.fixed_vertex_ids.size());
  EXPECT_EQ(0, graph.fixed_vertex_ids[0]);
}

TEST(G2oIoTest, WriteThenReadRoundTripsThroughAFile) {
  ManhattanGraphOptions options;
  options.num_poses = 200;
  SyntheticPoseGraph2d synthetic = GenerateManhattanPoseGraph2d(options, 17);
  PoseGraph2d& graph = synthetic.graph;
  graph.fixed_vertex_ids = {0, 5};
  // A full (non-diagonal) information on one edge, to check the upper triangle's order.
  graph.edges[3].information << 50, 1, -2, 1, 60, 3, -2, 3, 70;
  const std::string path = ::testing::TempDir() + "/g2o_io_round_trip.g2o";
  const Status written = WriteG2oPoseGraph2d(path, graph);
  ASSERT_TRUE(written.ok()) << written.message();
  PoseGraph2d read;
  const Status status = ReadG2oPoseGraph2d(path, &read);
  ASSERT_TRUE(status.ok()) << status.message();
  std::remove(path.c_str());
  ASSERT_EQ(graph.vertices.size(), read.vertices.size());
  for (size_t k = 0; k < graph.vertices.size(); ++k) {
    EXPECT_EQ(graph.vertices[k].id, read.vertices[k].id);
    const Pose2& a = graph.vertices[k].world_T_vertex;
    const Pose2& b = read.vertices[k].world_T_vertex;
    EXPECT_DOUBLE_EQ(a.x(), b.x());
    EXPECT_DOUBLE_EQ(a.y(), b.y());
    EXPECT_NEAR(a.theta(), b.theta(), 1e-15);
  }
  ASSERT_EQ(graph.edges.size(), read.edges.size());
  for (size_t k = 0; k < graph.edges.size(); ++k) {
    EXPECT_EQ(graph.edges[k].id_from, read.edges[k].id_from);
    EXPECT_EQ(graph.edges[k].id_to, read.edges[k].id_to);
    EXPECT_DOUBLE_EQ(graph.edges[k].from_T_to_measured.x(), read.edges[k].from_T_to_measured.x());
    EXPECT_DOUBLE_EQ(graph.edges[k].from_T_to_measured.y(), read.edges[k].from_T_to_measured.y());
    EXPECT_NEAR(graph.edges[k].from_T_to_measured.theta(),
                read.edges[k].from_T_to_measured.theta(), 1e-15);
    EXPECT_EQ(graph.edges[k].information, read.edges[k].information);
    // The generator labels edges as the reader's id convention does.
    EXPECT_EQ(graph.edges[k].kind, read.edges[k].kind) << "edge " << k;
  }
  EXPECT_EQ(graph.fixed_vertex_ids, read.fixed_vertex_ids);
}

TEST(G2oIoTest, EdgesBetweenConsecutiveIdsAreSequentialTheOthersLoopClosures) {
  const std::string text =
      "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nVERTEX_SE2 2 2 0 0\nVERTEX_SE2 7 0 1 0\n"
      "EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n"   // forward step
      "EDGE_SE2 2 1 -1 0 0 1 0 0 1 0 1\n"  // backward step: still consecutive
      "EDGE_SE2 0 2 2 0 0 1 0 0 1 0 1\n"
      "EDGE_SE2 7 0 0 -1 0 1 0 0 1 0 1\n";
  PoseGraph2d graph;
  const Status status = Parse(text, &graph);
  ASSERT_TRUE(status.ok()) << status.message();
  ASSERT_EQ(4u, graph.edges.size());
  EXPECT_EQ(EdgeKind::kSequential, graph.edges[0].kind);
  EXPECT_EQ(EdgeKind::kSequential, graph.edges[1].kind);
  EXPECT_EQ(EdgeKind::kLoopClosure, graph.edges[2].kind);
  EXPECT_EQ(EdgeKind::kLoopClosure, graph.edges[3].kind);
}

struct MalformedCase {
  std::string text;
  std::string expected_message;  // must appear in the error, including "test.g2o:<line>:"
};

TEST(G2oIoTest, MalformedLinesAreErrorsNamingFileAndLine) {
  const std::string v01 = "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\n";
  const std::vector<MalformedCase> cases = {
      {"VERTEX_SE2 0 0 0\n", "test.g2o:1: VERTEX_SE2 needs 4 fields"},
      {"VERTEX_SE2 0 0 0 0 7\n", "test.g2o:1: VERTEX_SE2 needs 4 fields"},
      {"VERTEX_SE2 x 0 0 0\n", "test.g2o:1: bad vertex id 'x'"},
      {"VERTEX_SE2 -1 0 0 0\n", "test.g2o:1: bad vertex id '-1'"},
      {"VERTEX_SE2 0 0 nan 0\n", "test.g2o:1: VERTEX_SE2 field 'nan' is not a finite number"},
      {"VERTEX_SE2 0 0 1.0abc 0\n", "'1.0abc' is not a finite number"},
      {v01 + "VERTEX_SE2 1 2 0 0\n", "test.g2o:3: vertex 1 already defined on line 2"},
      {v01 + "EDGE_SE2 0 1 1 0 0 1 0 0 1 0\n", "test.g2o:3: EDGE_SE2 needs 11 fields"},
      {v01 + "EDGE_SE2 0 1 1 0 inf 1 0 0 1 0 1\n", "test.g2o:3: EDGE_SE2 field 'inf'"},
      {v01 + "EDGE_SE2 0 1 1 0 0 1 0 0 -1 0 1\n",
       "test.g2o:3: EDGE_SE2 information matrix is not positive definite"},
      {v01 + "EDGE_SE2 1 1 1 0 0 1 0 0 1 0 1\n", "test.g2o:3: EDGE_SE2 connects vertex 1 to itself"},
      {"EDGE_SE2 0 7 1 0 0 1 0 0 1 0 1\n" + v01,
       "test.g2o:1: EDGE_SE2 refers to vertex 7, which has no VERTEX_SE2"},
      {v01 + "FIX\n", "test.g2o:3: FIX needs at least one vertex id"},
      {v01 + "FIX 0 9\n", "test.g2o:3: FIX refers to vertex 9"},
      {v01 + "VERTEX_SE3:QUAT 2 0 0 0 0 0 0 1\n", "test.g2o:3: unsupported g2o record"},
      // Issue #16: magnitudes the solve cannot take, and a factor that is not usable.
      {v01 + "EDGE_SE2 0 1 1 0 0 1e300 0 0 1e300 0 1e300\n", "test.g2o:3: EDGE_SE2 information entry '1e300'"},
      {v01 + "EDGE_SE2 0 1 1e10 0 0 1 0 0 1 0 1\n", "test.g2o:3: EDGE_SE2 translation is beyond +-1e9 m"},
      {"VERTEX_SE2 0 -2e9 0 0\n", "test.g2o:1: VERTEX_SE2 position is beyond +-1e9 m"},
      {v01 + "EDGE_SE2 0 1 1 0 0 1 1 0 1 0 1\n", "test.g2o:3: EDGE_SE2 information matrix is not positive definite"},
  };
  for (const MalformedCase& c : cases) {
    PoseGraph2d graph;
    const Status status = Parse(c.text, &graph);
    EXPECT_FALSE(status.ok()) << "accepted:\n" << c.text;
    EXPECT_THAT(status.message(), HasSubstr(c.expected_message)) << "input:\n" << c.text;
  }
}

TEST(G2oIoTest, MissingFileIsAnErrorNamingIt) {
  PoseGraph2d graph;
  const Status status = ReadG2oPoseGraph2d("/nonexistent/graph.g2o", &graph);
  EXPECT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("/nonexistent/graph.g2o"));
}

TEST(G2oIoTest, AcceptsCrlfAndTabs) {
  PoseGraph2d graph;
  const Status status = Parse("VERTEX_SE2\t0\t1 2 0.5\r\nVERTEX_SE2 1 0 0 0\r\n", &graph);
  ASSERT_TRUE(status.ok()) << status.message();
  ASSERT_EQ(2u, graph.vertices.size());
  EXPECT_DOUBLE_EQ(0.5, graph.vertices[0].world_T_vertex.theta());
}


TEST(G2oIoTest, ADirectoryIsAnErrorNamingIt) {
  PoseGraph2d graph;
  const Status status = ReadG2oPoseGraph2d(::testing::TempDir(), &graph);
  EXPECT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("Is a directory"));
}

}  // namespace
}  // namespace hetslam
