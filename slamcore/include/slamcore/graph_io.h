// Reading and writing pose graphs as g2o and TORO text files. Formats: docs/formats/pose-graph-files.md.
//
// g2o:  VERTEX_SE2 id x y θ | EDGE_SE2 i j dx dy dθ I11 I12 I13 I22 I23 I33 | FIX id
// TORO: VERTEX2 id x y θ     | EDGE2 i j dx dy dθ I11 I12 I22 I33 I13 I23
// Blank lines and lines starting with '#' are skipped. Any other problem (unknown tag, missing or extra
// fields, NaN/inf, information not positive definite, a number past the bounds below, an edge to a vertex
// that was not declared, a duplicate vertex) fails the whole read with "FILE:LINE: reason"; nothing is half-loaded.
// A file with edges but no vertex lines at all (e.g. the SE-Sync benchmarks) gets its initial poses by
// composing edge measurements along a breadth-first spanning tree from the smallest vertex id.
// Edges i→i+1 are read as motion edges, all others as observation edges.
//
// Thread safety: free functions without shared state.
#pragma once

#include <filesystem>
#include <functional>
#include <iosfwd>
#include <string>

#include "slamcore/pose_graph.h"

namespace slamcore {

enum class GraphFormat { kG2o, kToro };

/// Bounds on what a file may say (docs/formats/pose-graph-files.md): poses and measurements within
/// 10,000 km of the origin, information entries and their covariance's entries at most 10¹² (σ from a
/// micrometre to a thousand kilometres). The real graphs' largest information is 4·10⁸ (CSAIL).
inline constexpr double kMaxFileCoordinateM = 1e7;
inline constexpr double kMaxFileInformation = 1e12;

/// Reads a g2o or TORO file; the format is taken from the first tag in the file.
Result<PoseGraph> ReadPoseGraph(const std::filesystem::path& path);
/// Reads from a stream; `source_name` prefixes error messages.
Result<PoseGraph> ReadPoseGraph(std::istream& input, const std::string& source_name);

/// Writes every node, edge and FIX mark with full double precision, so that reading the file back
/// gives an identical graph. Fails only on I/O errors.
Status WritePoseGraph(const PoseGraph& graph, const std::filesystem::path& path, GraphFormat format);
void WritePoseGraph(const PoseGraph& graph, std::ostream& output, GraphFormat format);

/// Writes a file through `write` into a temporary beside it, then renames it over `path`: a failed write
/// leaves no half-written file. Fails (naming the file) when it cannot be opened, written or renamed.
Status WriteFileReplacing(const std::filesystem::path& path, const std::function<void(std::ostream&)>& write);

}  // namespace slamcore
