#include "slamcore/graph_io.h"

#include <Eigen/LU>

#include <functional>

#include <charconv>
#include <deque>
#include <fstream>
#include <map>
#include <sstream>
#include <string_view>
#include <vector>

namespace slamcore {
namespace {

std::vector<std::string_view> SplitFields(std::string_view line) {
  std::vector<std::string_view> fields;
  std::size_t position = 0;
  while (position < line.size()) {
    const std::size_t start = line.find_first_not_of(" \t\r", position);
    if (start == std::string_view::npos) break;
    const std::size_t end = line.find_first_of(" \t\r", start);
    fields.push_back(
        line.substr(start, end == std::string_view::npos ? std::string_view::npos : end - start));
    position = end == std::string_view::npos ? line.size() : end;
  }
  return fields;
}

/// Parses one line's fields; every error names the field by its position and text.
class LineParser {
 public:
  LineParser(const std::vector<std::string_view>& fields, std::string location)
      : fields_(fields), location_(std::move(location)) {}

  Status ExpectCount(std::size_t count) const {
    if (fields_.size() != count) {
      return InvalidArgument(location_ + ": " + std::string(fields_[0]) + " needs " +
                             std::to_string(count - 1) + " fields, found " +
                             std::to_string(fields_.size() - 1));
    }
    return Status::Ok();
  }

  Status Id(std::size_t index, std::int64_t* out) const {
    const std::string_view text = fields_[index];
    const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), *out);
    if (error != std::errc() || end != text.data() + text.size()) {
      return InvalidArgument(location_ + ": field " + std::to_string(index) + " '" + std::string(text) +
                             "' is not an integer id");
    }
    return Status::Ok();
  }

  Status Number(std::size_t index, double* out) const {
    const std::string_view text = fields_[index];
    const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), *out);
    if (error != std::errc() || end != text.data() + text.size()) {
      return InvalidArgument(location_ + ": field " + std::to_string(index) + " '" + std::string(text) +
                             "' is not a number");
    }
    if (!std::isfinite(*out)) {
      return InvalidArgument(location_ + ": field " + std::to_string(index) + " '" + std::string(text) +
                             "' is not finite");
    }
    return Status::Ok();
  }

  Status Numbers(std::size_t first, std::size_t count, double* out) const {
    for (std::size_t k = 0; k < count; ++k) RETURN_IF_ERROR(Number(first + k, &out[k]));
    return Status::Ok();
  }

  const std::string& location() const { return location_; }

 private:
  const std::vector<std::string_view>& fields_;
  std::string location_;
};

struct ParsedEdge {
  Edge edge;
  std::string location;
};

/// Initial poses for a file without vertices: from the smallest id, a spanning tree that uses as few
/// observation edges as it can (0-1 breadth-first search: motion edges cost 0, observations 1), since
/// composing odometry is the better initial guess.
void InitialiseBySpanningTree(const std::map<NodeId, std::size_t>& ids, const std::vector<ParsedEdge>& edges,
                              std::map<NodeId, SE2>* poses) {
  struct Step {
    NodeId node;
    NodeId parent;
    SE2 parent_T_node;
  };
  std::multimap<NodeId, std::pair<Step, bool>> adjacency;  // node → (step to a neighbour, is motion)
  for (const ParsedEdge& parsed : edges) {
    const Edge& edge = parsed.edge;
    const bool motion = edge.kind == EdgeKind::kMotion;
    adjacency.emplace(edge.from, std::pair{Step{edge.to, edge.from, edge.measurement}, motion});
    adjacency.emplace(edge.to, std::pair{Step{edge.from, edge.to, edge.measurement.inverse()}, motion});
  }
  for (const auto& [root, unused] : ids) {
    if (poses->contains(root)) continue;
    std::deque<Step> queue{
        Step{root, root, SE2::Identity()}};  // each disconnected piece starts at the origin
    while (!queue.empty()) {
      const Step step = queue.front();
      queue.pop_front();
      if (poses->contains(step.node)) continue;
      (*poses)[step.node] = step.node == root ? SE2::Identity() : poses->at(step.parent) * step.parent_T_node;
      const auto [begin, end] = adjacency.equal_range(step.node);
      for (auto it = begin; it != end; ++it) {
        const auto& [next, motion] = it->second;
        if (poses->contains(next.node)) continue;
        if (motion) {
          queue.push_front(next);
        } else {
          queue.push_back(next);
        }
      }
    }
  }
}

/// How far out a pose or a measurement (x, y, θ) reaches: its larger coordinate, in metres.
double Reach(const double* pose) { return std::max(std::abs(pose[0]), std::abs(pose[1])); }

/// Why a tag is refused, naming what is read instead: a user handing us a 3D or a landmark graph learns that
/// it is the kind of graph, not a typo, that is refused.
std::string UnknownTagReason(std::string_view tag) {
  std::string reason = "unknown tag '" + std::string(tag) + "'";
  const bool three_d = tag.find("SE3") != std::string_view::npos || tag == "VERTEX3" || tag == "EDGE3" ||
                       tag.find("XYZ") != std::string_view::npos;
  const bool landmark =
      tag.starts_with("VERTEX_XY") || (tag.starts_with("EDGE_") && tag.find("XY") != std::string_view::npos);
  if (three_d) return reason + ": a 3D graph; only 2D pose graphs (SE(2)) are read";
  if (landmark) return reason + ": landmarks are not read, only poses and the edges between them";
  return reason + " (read: VERTEX_SE2, EDGE_SE2, FIX; TORO's VERTEX2, EDGE2)";
}

}  // namespace

Result<PoseGraph> ReadPoseGraph(std::istream& input, const std::string& source_name) {
  std::map<NodeId, SE2> vertex_poses;
  std::map<NodeId, std::string> vertex_locations;
  std::vector<std::pair<NodeId, std::string>> fixes;
  std::vector<ParsedEdge> edges;
  std::optional<GraphFormat> format;

  std::string line;
  std::size_t line_number = 0;
  while (std::getline(input, line)) {
    ++line_number;
    const std::vector<std::string_view> fields = SplitFields(line);
    if (fields.empty() || fields[0].front() == '#') continue;
    const std::string location = source_name + ":" + std::to_string(line_number);
    const LineParser parser(fields, location);
    const std::string_view tag = fields[0];
    const bool g2o_tag = tag == "VERTEX_SE2" || tag == "EDGE_SE2" || tag == "FIX";
    const bool toro_tag = tag == "VERTEX2" || tag == "EDGE2";
    if (!g2o_tag && !toro_tag) return InvalidArgument(location + ": " + UnknownTagReason(tag));
    const GraphFormat line_format = g2o_tag ? GraphFormat::kG2o : GraphFormat::kToro;
    if (format && *format != line_format) {
      return InvalidArgument(location + ": tag '" + std::string(tag) + "' mixes g2o and TORO formats");
    }
    format = line_format;

    if (tag == "VERTEX_SE2" || tag == "VERTEX2") {
      RETURN_IF_ERROR(parser.ExpectCount(5));
      NodeId id;
      double pose[3];
      RETURN_IF_ERROR(parser.Id(1, &id));
      RETURN_IF_ERROR(parser.Numbers(2, 3, pose));
      if (const double reach = Reach(pose); reach > kMaxFileCoordinateM) {
        return InvalidArgument(location + ": vertex " + std::to_string(id) + " lies " + MessageNumber(reach) +
                               " m out, beyond the " + MessageNumber(kMaxFileCoordinateM) + " m a pose may");
      }
      if (vertex_poses.contains(id)) {
        return InvalidArgument(location + ": vertex " + std::to_string(id) + " already declared at " +
                               vertex_locations[id]);
      }
      vertex_poses.emplace(id, SE2(pose[0], pose[1], pose[2]));
      vertex_locations.emplace(id, location);
    } else if (tag == "FIX") {
      RETURN_IF_ERROR(parser.ExpectCount(2));
      NodeId id;
      RETURN_IF_ERROR(parser.Id(1, &id));
      fixes.emplace_back(id, location);
    } else {  // EDGE_SE2 or EDGE2
      RETURN_IF_ERROR(parser.ExpectCount(12));
      Edge edge;
      double values[9];
      RETURN_IF_ERROR(parser.Id(1, &edge.from));
      RETURN_IF_ERROR(parser.Id(2, &edge.to));
      RETURN_IF_ERROR(parser.Numbers(3, 9, values));
      if (edge.from == edge.to)
        return InvalidArgument(location + ": edge joins vertex " + std::to_string(edge.from) + " to itself");
      edge.measurement = SE2(values[0], values[1], values[2]);
      Matrix3& info = edge.information;
      if (line_format == GraphFormat::kG2o) {  // I11 I12 I13 I22 I23 I33
        info << values[3], values[4], values[5], values[4], values[6], values[7], values[5], values[7],
            values[8];
      } else {  // I11 I12 I22 I33 I13 I23
        info << values[3], values[4], values[7], values[4], values[5], values[8], values[7], values[8],
            values[6];
      }
      if (const Status status = CheckPositiveDefinite(info, "information"); !status.ok()) {
        return InvalidArgument(location + ": " + status.message());
      }
      if (const double reach = Reach(values); reach > kMaxFileCoordinateM) {
        return InvalidArgument(location + ": the edge's measurement reaches " + MessageNumber(reach) +
                               " m, beyond the " + MessageNumber(kMaxFileCoordinateM) + " m a pose may");
      }
      // An information this large or this small makes the optimiser's weights overflow, or the edge's
      // covariance infinite: no sensor is that sure, or that unsure.
      const Matrix3 covariance = info.inverse();
      const double largest_information = info.cwiseAbs().maxCoeff();
      const double largest_covariance = covariance.cwiseAbs().maxCoeff();
      if (largest_information > kMaxFileInformation || !covariance.allFinite() ||
          largest_covariance > kMaxFileInformation) {
        return InvalidArgument(location + ": information " + MessageNumber(largest_information) +
                               " at most, covariance " + MessageNumber(largest_covariance) +
                               ": each must stay within " + MessageNumber(kMaxFileInformation));
      }
      edge.kind = edge.to == edge.from + 1 ? EdgeKind::kMotion : EdgeKind::kObservation;
      edges.push_back({edge, location});
    }
  }
  if (input.bad()) return DataLoss(source_name + ": read error");

  const bool implicit_vertices = vertex_poses.empty() && !edges.empty();
  std::map<NodeId, std::size_t> ids;
  for (const auto& [id, pose] : vertex_poses) ids.emplace(id, 0);
  for (const ParsedEdge& parsed : edges) {
    for (const NodeId id : {parsed.edge.from, parsed.edge.to}) {
      if (!implicit_vertices && !vertex_poses.contains(id)) {
        return NotFound(parsed.location + ": edge refers to vertex " + std::to_string(id) +
                        ", which is not declared");
      }
      ids.emplace(id, 0);
    }
  }
  if (implicit_vertices) InitialiseBySpanningTree(ids, edges, &vertex_poses);

  PoseGraph graph;
  for (const auto& [id, pose] : vertex_poses) {
    Node node;
    node.id = id;
    node.pose = pose;
    RETURN_IF_ERROR(graph.AddNode(node));
  }
  for (const auto& [id, location] : fixes) {
    if (!graph.HasNode(id))
      return NotFound(location + ": FIX of vertex " + std::to_string(id) + ", which is not declared");
    graph.mutable_node(id).fixed = true;
  }
  for (const ParsedEdge& parsed : edges) {
    const Result<std::size_t> added = graph.AddEdge(parsed.edge);
    if (!added.ok()) return InvalidArgument(parsed.location + ": " + added.status().message());
  }
  return graph;
}

Result<PoseGraph> ReadPoseGraph(const std::filesystem::path& path) {
  std::ifstream input(path);
  if (!input) return NotFound(path.string() + ": cannot open file");
  return ReadPoseGraph(input, path.string());
}

void WritePoseGraph(const PoseGraph& graph, std::ostream& output, GraphFormat format) {
  const bool g2o = format == GraphFormat::kG2o;
  char buffer[512];
  for (const Node& node : graph.nodes()) {
    std::snprintf(buffer, sizeof buffer, "%s %lld %.17g %.17g %.17g\n", g2o ? "VERTEX_SE2" : "VERTEX2",
                  static_cast<long long>(node.id), node.pose.x(), node.pose.y(), node.pose.theta());
    output << buffer;
  }
  for (const Edge& edge : graph.edges()) {
    const Matrix3& i = edge.information;
    const SE2& z = edge.measurement;
    if (g2o) {
      std::snprintf(buffer, sizeof buffer,
                    "EDGE_SE2 %lld %lld %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g\n",
                    static_cast<long long>(edge.from), static_cast<long long>(edge.to), z.x(), z.y(),
                    z.theta(), i(0, 0), i(0, 1), i(0, 2), i(1, 1), i(1, 2), i(2, 2));
    } else {
      std::snprintf(buffer, sizeof buffer,
                    "EDGE2 %lld %lld %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g\n",
                    static_cast<long long>(edge.from), static_cast<long long>(edge.to), z.x(), z.y(),
                    z.theta(), i(0, 0), i(0, 1), i(1, 1), i(2, 2), i(0, 2), i(1, 2));
    }
    output << buffer;
  }
  if (g2o) {
    for (const Node& node : graph.nodes()) {
      if (node.fixed) output << "FIX " << node.id << "\n";
    }
  }
}

Status WriteFileReplacing(const std::filesystem::path& path,
                          const std::function<void(std::ostream&)>& write) {
  // Write to a temporary file and rename, so a failed write never leaves a half-written file behind.
  const std::filesystem::path temporary = path.string() + ".tmp";
  const auto discard = [&](Status failure) {
    std::error_code ignored;
    std::filesystem::remove(temporary, ignored);
    return failure;
  };
  {
    std::ofstream output(temporary, std::ios::binary | std::ios::trunc);
    if (!output) return NotFound(temporary.string() + ": cannot open for writing");
    write(output);
    output.flush();
    if (!output) return discard(DataLoss(temporary.string() + ": write failed"));
  }
  std::error_code error;
  std::filesystem::rename(temporary, path, error);
  if (error) return discard(DataLoss(path.string() + ": " + error.message()));
  return Status::Ok();
}

Status WritePoseGraph(const PoseGraph& graph, const std::filesystem::path& path, GraphFormat format) {
  return WriteFileReplacing(path, [&](std::ostream& output) { WritePoseGraph(graph, output, format); });
}

}  // namespace slamcore
