#include "core/g2o_io.h"

#include <cerrno>
#include <climits>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <unordered_map>

#include "Eigen/Cholesky"
#include "core/file_io.h"
#include "core/robot_log_text.h"

namespace hetslam {
namespace {

std::vector<std::string> SplitFields(const std::string& line) {
  std::vector<std::string> fields;
  std::istringstream stream(line);
  std::string field;
  while (stream >> field) fields.push_back(field);
  return fields;
}

// The whole field must be a finite number.
bool ParseFinite(const std::string& field, double* value) {
  const char* begin = field.c_str();
  char* end = nullptr;
  const double v = std::strtod(begin, &end);
  if (end == begin || *end != '\0' || !std::isfinite(v)) return false;
  *value = v;
  return true;
}

// The whole field must be a decimal integer in [0, INT_MAX].
bool ParseId(const std::string& field, int* id) {
  const char* begin = field.c_str();
  char* end = nullptr;
  errno = 0;
  const long long v = std::strtoll(begin, &end, 10);
  if (end == begin || *end != '\0' || errno == ERANGE || v < 0 || v > INT_MAX) return false;
  *id = static_cast<int>(v);
  return true;
}

// Magnitude limits (header): beyond them a value is corrupt and the solve would overflow.
constexpr double kMaxCoordinate = 1e9;    // metres
constexpr double kMaxInformation = 1e18;  // information entries

std::string Where(const std::string& source_name, int line_number) {
  return source_name + ":" + std::to_string(line_number) + ": ";
}

}  // namespace

Status ParseG2oPoseGraph2d(std::istream& input, const std::string& source_name,
                           PoseGraph2d* graph) {
  *graph = PoseGraph2d();
  std::unordered_map<int, int> vertex_line;  // id -> line defining it
  std::vector<int> edge_lines;               // line of graph->edges[k]
  std::vector<int> fix_lines;                // line of graph->fixed_vertex_ids[k]
  std::string line;
  int line_number = 0;
  while (std::getline(input, line)) {
    ++line_number;
    const std::vector<std::string> fields = SplitFields(line);
    if (fields.empty() || fields[0][0] == '#') continue;
    const std::string& tag = fields[0];
    const std::string where = Where(source_name, line_number);
    if (tag == "VERTEX_SE2") {
      if (fields.size() != 5) {
        return Status::Error(where + "VERTEX_SE2 needs 4 fields (id x y theta), got " +
                             std::to_string(fields.size() - 1));
      }
      PoseGraph2dVertex vertex;
      if (!ParseId(fields[1], &vertex.id)) {
        return Status::Error(where + "bad vertex id '" + fields[1] + "'");
      }
      double v[3];
      for (int k = 0; k < 3; ++k) {
        if (!ParseFinite(fields[2 + k], &v[k])) {
          return Status::Error(where + "VERTEX_SE2 field '" + fields[2 + k] +
                               "' is not a finite number");
        }
      }
      const auto inserted = vertex_line.emplace(vertex.id, line_number);
      if (!inserted.second) {
        return Status::Error(where + "vertex " + fields[1] + " already defined on line " +
                             std::to_string(inserted.first->second));
      }
      if (std::abs(v[0]) > kMaxCoordinate || std::abs(v[1]) > kMaxCoordinate) {
        return Status::Error(where + "VERTEX_SE2 position is beyond +-1e9 m");
      }
      vertex.world_T_vertex = Pose2(v[0], v[1], v[2]);
      graph->vertices.push_back(vertex);
    } else if (tag == "EDGE_SE2") {
      if (fields.size() != 12) {
        return Status::Error(where +
                             "EDGE_SE2 needs 11 fields (i j dx dy dtheta I11 I12 I13 I22 I23 "
                             "I33), got " +
                             std::to_string(fields.size() - 1));
      }
      PoseGraph2dEdge edge;
      if (!ParseId(fields[1], &edge.id_from) || !ParseId(fields[2], &edge.id_to)) {
        return Status::Error(where + "bad vertex id in EDGE_SE2 '" + fields[1] + " " +
                             fields[2] + "'");
      }
      if (edge.id_from == edge.id_to) {
        return Status::Error(where + "EDGE_SE2 connects vertex " + fields[1] + " to itself");
      }
      double v[9];
      for (int k = 0; k < 9; ++k) {
        if (!ParseFinite(fields[3 + k], &v[k])) {
          return Status::Error(where + "EDGE_SE2 field '" + fields[3 + k] +
                               "' is not a finite number");
        }
      }
      if (std::abs(v[0]) > kMaxCoordinate || std::abs(v[1]) > kMaxCoordinate) {
        return Status::Error(where + "EDGE_SE2 translation is beyond +-1e9 m");
      }
      edge.from_T_to_measured = Pose2(v[0], v[1], v[2]);
      Eigen::Matrix3d& info = edge.information;
      info << v[3], v[4], v[5],  //
          v[4], v[6], v[7],      //
          v[5], v[7], v[8];
      for (int k = 3; k < 9; ++k) {
        if (std::abs(v[k]) > kMaxInformation) {
          return Status::Error(where + "EDGE_SE2 information entry '" + fields[3 + k] + "' is beyond +-1e18");
        }
      }
      // Eigen's LLT reports success on some matrices whose factor is not finite (products that
      // overflow): the factor itself is checked, as the factors' SqrtInformation CHECKs it.
      const Eigen::LLT<Eigen::Matrix3d> llt(info);
      const Eigen::Matrix3d factor = llt.matrixL();
      if (llt.info() != Eigen::Success || !factor.allFinite() || !(factor.diagonal().minCoeff() > 0.0) ||
          !(factor * factor.transpose()).isApprox(info, 1e-6)) {
        return Status::Error(where + "EDGE_SE2 information matrix is not positive definite");
      }
      // The file names no kind: consecutive ids are sequential (header).
      const long id_step = static_cast<long>(edge.id_to) - edge.id_from;
      edge.kind = id_step == 1 || id_step == -1 ? EdgeKind::kSequential : EdgeKind::kLoopClosure;
      graph->edges.push_back(edge);
      edge_lines.push_back(line_number);
    } else if (tag == "FIX") {
      if (fields.size() < 2) return Status::Error(where + "FIX needs at least one vertex id");
      for (size_t k = 1; k < fields.size(); ++k) {
        int id = 0;
        if (!ParseId(fields[k], &id)) {
          return Status::Error(where + "bad vertex id in FIX '" + fields[k] + "'");
        }
        graph->fixed_vertex_ids.push_back(id);
        fix_lines.push_back(line_number);
      }
    } else {
      return Status::Error(where + "unsupported g2o record '" + tag +
                           "' (2D pose graphs read VERTEX_SE2, EDGE_SE2 and FIX)");
    }
  }
  if (input.bad()) return Status::Error(source_name + ": read error");
  // Edges and FIX lines may precede the vertices they name; check references at the end.
  for (size_t k = 0; k < graph->edges.size(); ++k) {
    for (const int id : {graph->edges[k].id_from, graph->edges[k].id_to}) {
      if (vertex_line.count(id) == 0) {
        return Status::Error(Where(source_name, edge_lines[k]) + "EDGE_SE2 refers to vertex " +
                             std::to_string(id) + ", which has no VERTEX_SE2");
      }
    }
  }
  for (size_t k = 0; k < graph->fixed_vertex_ids.size(); ++k) {
    if (vertex_line.count(graph->fixed_vertex_ids[k]) == 0) {
      return Status::Error(Where(source_name, fix_lines[k]) + "FIX refers to vertex " +
                           std::to_string(graph->fixed_vertex_ids[k]) +
                           ", which has no VERTEX_SE2");
    }
  }
  return Status::Ok();
}

Status ReadG2oPoseGraph2d(const std::string& path, PoseGraph2d* graph) {
  std::ifstream input;
  HETSLAM_RETURN_IF_ERROR(robot_log_text::OpenForReading(path, &input));
  return ParseG2oPoseGraph2d(input, path, graph);
}

void WriteG2oPoseGraph2d(const PoseGraph2d& graph, std::ostream* output) {
  std::ostream& out = *output;
  out << std::setprecision(17);
  for (const PoseGraph2dVertex& v : graph.vertices) {
    out << "VERTEX_SE2 " << v.id << ' ' << v.world_T_vertex.x() << ' ' << v.world_T_vertex.y()
        << ' ' << v.world_T_vertex.theta() << '\n';
  }
  for (const PoseGraph2dEdge& e : graph.edges) {
    const Pose2& m = e.from_T_to_measured;
    const Eigen::Matrix3d& info = e.information;
    out << "EDGE_SE2 " << e.id_from << ' ' << e.id_to << ' ' << m.x() << ' ' << m.y() << ' '
        << m.theta() << ' ' << info(0, 0) << ' ' << info(0, 1) << ' ' << info(0, 2) << ' '
        << info(1, 1) << ' ' << info(1, 2) << ' ' << info(2, 2) << '\n';
  }
  if (!graph.fixed_vertex_ids.empty()) {
    out << "FIX";
    for (const int id : graph.fixed_vertex_ids) out << ' ' << id;
    out << '\n';
  }
}

Status WriteG2oPoseGraph2d(const std::string& path, const PoseGraph2d& graph) {
  std::ostringstream text;
  WriteG2oPoseGraph2d(graph, &text);
  const std::string bytes = text.str();
  return WriteFileBytes(path, bytes.data(), bytes.size());
}

}  // namespace hetslam
