// Linear initialisation of a 2-D pose graph (the LAGO approach: Carlone et al., "A linear approximation
// for graph-based simultaneous localization and mapping", RSS 2011).
//
// Orientations first: a spanning tree (odometry preferred) unwraps every edge's angle so that the
// orientation problem becomes linear; a weighted linear least-squares solve gives all headings. With the
// headings fixed, the translation part of every edge error is linear in the positions: a second solve
// gives them. Both solves are sparse Cholesky factorisations (Eigen's SimplicialLDLT). The result is a
// starting point in the basin of the global optimum for typical SLAM noise, far better than composed
// odometry, so the nonlinear optimiser needs fewer iterations and avoids the local minima odometry leads
// into. Each component keeps its anchor (fixed node, or else its first node) where it was.
//
// Thread safety: writes the graph's poses; the caller serialises access to the graph.
#pragma once

#include <optional>

#include "slamcore/pose_graph.h"

namespace slamcore {

/// Replaces the poses of every node (or of one component's nodes) by the linear estimate.
Status InitializeLinear(PoseGraph& graph, std::optional<ComponentId> component = std::nullopt);

}  // namespace slamcore
