#include "incremental_solver.h"

#include <Eigen/Cholesky>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <bit>
#include <cmath>
#include <span>

#include "cholmod_cholesky.h"

namespace slamcore::internal {
namespace {

bool SameEdge(const Edge& a, const Edge& b) {
  return a.from == b.from && a.to == b.to && a.measurement.x() == b.measurement.x() &&
         a.measurement.y() == b.measurement.y() && a.measurement.theta() == b.measurement.theta();
}

/// The normal equations' sparse Cholesky: Eigen's simplicial LDLᵀ for small regions (no set-up cost),
/// CHOLMOD's (cholmod_cholesky.h) for large ones. The symbolic analysis is done once per region, its
/// pattern fixed across iterations. A small region's H comes already in a fill-reducing order (the columns
/// SolveRegion gives its nodes) and as its upper triangle, which the simplicial LDLᵀ factorises as it is;
/// a large one's comes as its lower triangle, in region order, and CHOLMOD orders it.
class NormalEquations {
 public:
  explicit NormalEquations(int size) : large_(IsLarge(size)) {}
  static bool IsLarge(int size) { return size >= kLargeColumns; }

  /// Which triangle of H Factorize expects.
  bool upper() const { return !large_; }
  bool Factorize(Eigen::SparseMatrix<double>& triangle) {
    if (large_) {
      if (!analysed_ && !cholmod_->Analyze(triangle)) return false;
      analysed_ = true;
      return cholmod_->Factorize(triangle);
    }
    if (!analysed_) simplicial_.analyzePattern(triangle);
    analysed_ = true;
    simplicial_.factorize(triangle);
    return simplicial_.info() == Eigen::Success;
  }
  Eigen::VectorXd Solve(const Eigen::VectorXd& rhs) {
    if (large_) return cholmod_->Solve(rhs);
    return simplicial_.solve(rhs);
  }
  /// CHOLMOD's factorisation (large systems only), given up.
  std::unique_ptr<CholmodCholesky> Release() { return large_ ? std::move(cholmod_) : nullptr; }

 private:
  static constexpr int kLargeColumns = 600;  // 200 nodes: where CHOLMOD's set-up starts to pay
  bool large_, analysed_ = false;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Upper, Eigen::NaturalOrdering<int>> simplicial_;
  std::unique_ptr<CholmodCholesky> cholmod_ = std::make_unique<CholmodCholesky>();
};

/// `variables` (graph indices; variables[k] has column[·] = 3k) in the order an approximate minimum degree
/// ordering (Amestoy, Davis, Duff, SIAM J. Matrix Anal. Appl. 1996; Eigen's) eliminates them, over the graph
/// of their shared edges: the ordering of H's 3×3 blocks, as CHOLMOD's analysis orders a large system's
/// (cholmod_cholesky.cc), on a pattern nine times smaller than H's.
std::vector<std::size_t> FillReducingOrder(std::span<const std::pair<std::size_t, std::size_t>> edge_ends,
                                           const std::vector<std::size_t>& variables,
                                           const std::vector<int>& column) {
  const int count = static_cast<int>(variables.size());
  std::vector<Eigen::Triplet<double>> entries;
  entries.reserve(variables.size() + 2 * edge_ends.size());
  for (int k = 0; k < count; ++k) entries.emplace_back(k, k, 1.0);
  for (const auto& [from_index, to_index] : edge_ends) {
    const int from = column[from_index], to = column[to_index];
    if (from >= 0 && to >= 0 && from != to) {
      entries.emplace_back(from / 3, to / 3, 1.0);
      entries.emplace_back(to / 3, from / 3, 1.0);
    }
  }
  Eigen::SparseMatrix<double> pattern(count, count);
  pattern.setFromTriplets(entries.begin(), entries.end());
  Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> eliminated;  // k-th eliminated ← its index
  Eigen::AMDOrdering<int>()(pattern, eliminated);
  std::vector<std::size_t> ordered(variables.size());
  for (int k = 0; k < count; ++k) ordered[static_cast<std::size_t>(k)] = variables[eliminated.indices()[k]];
  return ordered;
}

}  // namespace

void IncrementalSolver::SyncAdjacency(const PoseGraph& graph) {
  const std::span<const Edge> edges = graph.edges();
  if (edges.size() < known_edges_ || (known_edges_ > 0 && !SameEdge(edges[known_edges_ - 1], last_edge_))) {
    incident_.clear();  // edges were removed or G replaced: start over
    ends_.clear();
    known_edges_ = 0;
  }
  incident_.resize(graph.num_nodes());
  node_rotation_t_.resize(graph.num_nodes());
  ends_.resize(edges.size());
  measurement_rotation_t_.resize(edges.size());
  for (std::size_t k = known_edges_; k < edges.size(); ++k) {
    const std::size_t from = graph.IndexOf(edges[k].from), to = graph.IndexOf(edges[k].to);
    ends_[k] = {static_cast<std::uint32_t>(from), static_cast<std::uint32_t>(to)};
    measurement_rotation_t_[k] = edges[k].measurement.rotation().transpose();
    incident_[from].push_back(static_cast<std::uint32_t>(k));
    if (to != from) incident_[to].push_back(static_cast<std::uint32_t>(k));
  }
  known_edges_ = edges.size();
  if (known_edges_ > 0) last_edge_ = edges.back();
}

const Matrix2& IncrementalSolver::RotationT(std::size_t index, const SE2& pose) {
  NodeRotation& kept = node_rotation_t_[index];
  // The same bits, not an equal value: −0 and +0 compare equal but give sines of opposite sign.
  const auto bits = std::bit_cast<std::uint64_t>(pose.theta());
  if (!kept.valid || kept.theta_bits != bits) {
    kept.transposed = pose.rotation().transpose();
    kept.theta_bits = bits;
    kept.valid = true;
  }
  return kept.transposed;
}

IncrementalSummary IncrementalSolver::Update(PoseGraph& graph, const std::vector<NodeId>& seeds,
                                             Start start) {
  return Run(graph, seeds, start, std::nullopt);
}

IncrementalSummary IncrementalSolver::SolveComponents(PoseGraph& graph, const std::vector<NodeId>& seeds) {
  return Run(graph, seeds, Start::kLocalUnlessFar,
             Convergence{.max_iterations = 10 * options_.max_iterations, .relative_cost_decrease = 1e-10});
}

IncrementalSummary IncrementalSolver::SolveWeightedComponent(PoseGraph& graph, NodeId seed,
                                                             const std::vector<double>& edge_weights,
                                                             int max_iterations,
                                                             double relative_cost_decrease) {
  return Run(graph, {seed}, Start::kWhole,
             Convergence{.max_iterations = max_iterations,
                         .relative_cost_decrease = relative_cost_decrease,
                         .edge_weights = &edge_weights});
}

std::optional<ComponentFactorisation> IncrementalSolver::TakeComponentFactorisation() {
  return std::exchange(component_factorisation_, std::nullopt);
}

IncrementalSummary IncrementalSolver::Run(PoseGraph& graph, const std::vector<NodeId>& seeds, Start start,
                                          std::optional<Convergence> whole) {
  IncrementalSummary summary;
  component_factorisation_.reset();
  SyncAdjacency(graph);
  // Marks persist between updates (all zero / −1 outside one), so an update costs what its region costs.
  in_region_.resize(graph.num_nodes(), 0);
  column_.resize(graph.num_nodes(), -1);
  original_.resize(graph.num_nodes());
  ++updates_;  // the terms kept from earlier updates are stale
  if (start_terms_.size() < 2 * graph.num_edges()) start_terms_.resize(2 * graph.num_edges());
  std::vector<std::size_t> region;
  for (const NodeId seed : seeds) {
    if (!graph.HasNode(seed)) continue;
    const std::size_t index = graph.IndexOf(seed);
    if (in_region_[index] || graph.nodes()[index].fixed) continue;
    in_region_[index] = 1;
    original_[index] = graph.nodes()[index].pose;
    region.push_back(index);
  }
  if (region.empty()) return summary;
  // An edge far from the current estimate (a long loop closed) moves much of the map, and a small region
  // held at its boundary would absorb the correction by bending: such an update starts from the whole
  // component, as a batch solve would.
  double largest_seed_chi2 = 0.0;
  for (const std::size_t index : start == Start::kLocalUnlessFar ? region : std::vector<std::size_t>{}) {
    for (const std::uint32_t e : incident_[index]) {
      largest_seed_chi2 = std::max(largest_seed_chi2, EdgeChi2(graph, graph.edges()[e]));
    }
  }
  const bool large =
      whole.has_value() || start == Start::kWhole || largest_seed_chi2 > options_.whole_component_edge_chi2;
  summary.whole_start = large;
  Grow(graph, region, region,
       large ? graph.num_nodes() : static_cast<std::size_t>(options_.initial_region_nodes));

  for (;;) {
    // Held nodes next to the region anchor it; without any the region is a whole free component.
    bool anchored = false, free_neighbour = false;
    for (const std::size_t index : region) {
      for (const std::uint32_t e : incident_[index]) {
        for (const std::size_t other : {ends_[e].from, ends_[e].to}) {
          if (in_region_[other]) continue;
          anchored = true;
          free_neighbour = free_neighbour || !graph.nodes()[other].fixed;
        }
      }
    }
    // A region with no held neighbour is a whole component: its final factorisation (of the edges' own
    // information) is worth keeping.
    const bool keep = !anchored && !(whole && whole->edge_weights);
    summary.iterations +=
        SolveRegion(graph, region, !anchored, whole, keep ? &component_factorisation_ : nullptr);
    ++summary.rounds;
    summary.region_nodes = static_cast<int>(region.size());
    summary.full = !free_neighbour;
    if (summary.full) break;
    const std::vector<std::size_t> moving = MovingNeighbours(graph, region);
    if (moving.empty()) break;
    // Doubling: a long loop needs few rounds. Past half the component a partial region saves little and its
    // held boundary slows convergence on a large correction: the whole component is solved instead.
    const bool take_all = 2 * (2 * region.size()) > graph.ComponentSize(graph.nodes()[region.front()].id);
    Grow(graph, region, moving, take_all ? graph.num_nodes() : region.size());
  }
  for (const std::size_t index : region) in_region_[index] = 0;
  return summary;
}

void IncrementalSolver::Grow(const PoseGraph& graph, std::vector<std::size_t>& region,
                             const std::vector<std::size_t>& from, std::size_t count) {
  // Breadth-first from `from` (region members or held nodes), admitting up to `count` new nodes.
  std::vector<std::size_t> queue(from.begin(), from.end());  // a copy first: `from` may be `region`
  std::size_t added = 0;
  const std::size_t starts = queue.size();
  for (std::size_t k = 0; k < starts; ++k) {
    const std::size_t index = queue[k];
    if (!in_region_[index] && !graph.nodes()[index].fixed) {
      in_region_[index] = 1;
      original_[index] = graph.nodes()[index].pose;
      region.push_back(index);
      ++added;
    }
  }
  for (std::size_t head = 0; head < queue.size() && added < count; ++head) {
    for (const std::uint32_t e : incident_[queue[head]]) {
      for (const std::size_t index : {ends_[e].from, ends_[e].to}) {
        if (in_region_[index] || graph.nodes()[index].fixed || added >= count) continue;
        in_region_[index] = 1;
        original_[index] = graph.nodes()[index].pose;
        region.push_back(index);
        queue.push_back(index);
        ++added;
      }
    }
  }
}

int IncrementalSolver::SolveRegion(PoseGraph& graph, const std::vector<std::size_t>& region, bool hold_gauge,
                                   const std::optional<Convergence>& to_convergence,
                                   std::optional<ComponentFactorisation>* converged) {
  // Columns: 3 per region node; the gauge (the component's first node) is held when nothing else is.
  std::vector<int>& column = column_;
  int columns = 0;
  const std::size_t gauge = hold_gauge ? *std::min_element(region.begin(), region.end()) : graph.num_nodes();
  for (const std::size_t index : region) {
    if (index != gauge) column[index] = 3 * columns++;
  }
  if (columns == 0) return 0;
  struct ResetColumns {
    std::vector<int>& column;
    const std::vector<std::size_t>& region;
    ~ResetColumns() {
      for (const std::size_t index : region) column[index] = -1;
    }
  } reset{column, region};
  // Every edge touching the region once: from its `from` end when that is in the region, else from `to`.
  std::vector<std::uint32_t> edges;
  for (const std::size_t index : region) {
    for (const std::uint32_t e : incident_[index]) {
      const std::size_t from = ends_[e].from;
      if (from == index || !in_region_[from]) edges.push_back(e);
    }
  }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  // A weighted solve scales each edge's information by its weight (weight 0 leaves the edge out); the
  // updates read the edges' own.
  const std::vector<double>* weights = to_convergence ? to_convergence->edge_weights : nullptr;
  std::vector<Matrix3> weighted_information;
  if (weights != nullptr) {
    std::erase_if(edges, [&](std::uint32_t e) { return (*weights)[e] == 0.0; });
    weighted_information.reserve(edges.size());
    for (const std::uint32_t e : edges)
      weighted_information.push_back((*weights)[e] * graph.edges()[e].information);
  }
  // Each edge's ends (graph indices).
  std::vector<std::pair<std::size_t, std::size_t>> ends;
  ends.reserve(edges.size());
  for (const std::uint32_t e : edges) ends.emplace_back(ends_[e].from, ends_[e].to);
  NormalEquations normal_equations(3 * columns);
  if (!NormalEquations::IsLarge(3 * columns)) {
    // A small region's columns in a fill-reducing order (column[] holds region order: the positions).
    std::vector<std::size_t> variables;
    variables.reserve(static_cast<std::size_t>(columns));
    for (const std::size_t index : region) {
      if (index != gauge) variables.push_back(index);
    }
    const std::vector<std::size_t> ordered = FillReducingOrder(ends, variables, column);
    for (std::size_t k = 0; k < ordered.size(); ++k) column[ordered[k]] = 3 * static_cast<int>(k);
  }
  const auto information = [&](std::size_t k) -> const Matrix3& {
    return weights != nullptr ? weighted_information[k] : graph.edges()[edges[k]].information;
  };

  // Each edge's error and Jacobians at the current poses: the χ² that judges a step is computed with the
  // Jacobians the next iteration linearises with, once per pose set.
  struct Linearised {
    Vector3 error;
    Matrix3 d_from, d_to;
  };
  const auto linearise = [&](std::vector<Linearised>& out) {
    out.resize(edges.size());
    double sum = 0.0;
    for (std::size_t k = 0; k < edges.size(); ++k) {
      const Edge& edge = graph.edges()[edges[k]];
      Linearised& at = out[k];
      const SE2& from = graph.nodes()[ends[k].first].pose;
      at.error = EdgeError(from, RotationT(ends[k].first, from), graph.nodes()[ends[k].second].pose,
                           edge.measurement, measurement_rotation_t_[edges[k]], &at.d_from, &at.d_to);
      sum += at.error.dot(information(k) * at.error);
    }
    return sum;
  };
  Eigen::SparseMatrix<double> hessian(3 * columns, 3 * columns);
  // H's pattern is the same in every iteration: it is built from the first iteration's triplets; from the
  // second on (most local updates take one), each entry is added straight into its slot of H's values, in
  // the triplets' order, so each sum is the one setFromTriplets forms, term for term.
  std::vector<Eigen::Triplet<double>> triplets;
  std::vector<int> slots;  // by triplet: its index in H's values
  Eigen::VectorXd gradient(3 * columns);
  std::vector<Linearised> current, trial;
  const bool upper = normal_equations.upper();
  // Levenberg–Marquardt damping λ (H's diagonal scaled by 1 + λ), 0 until a step is rejected: Nielsen's
  // update (Madsen, Nielsen, Tingleff, "Methods for non-linear least squares problems", 2004, §3.2), which
  // lowers λ by the gain ratio ρ of the accepted step, at most 3×, and raises it by a growing factor ν on
  // a rejection. Dividing λ by 10 on every success, as before, made badly conditioned weighted solves
  // alternate between an accepted and a rejected step for dozens of iterations. λ returns to 0 (small
  // enough) only until an undamped step has failed: near a weak direction the undamped step overshoots
  // again, and restarting from 1e-4 cost ten factorisations of creeping back each time.
  double cost = linearise(current), damping = 0.0, damping_growth = 2.0;
  bool undamped_failed = false;
  const auto reject = [&] {
    if (damping == 0.0) undamped_failed = true;
    damping = damping == 0.0 ? 1e-4 : damping * damping_growth;
    damping_growth *= 2.0;
  };
  // The last undamped factorisation, H at the solution to within the tolerances, for whoever asked for it.
  const auto keep_factorisation = [&] {
    if (converged == nullptr) return;
    if (std::unique_ptr<CholmodCholesky> cholesky = normal_equations.Release()) {
      ComponentFactorisation kept{.cholesky = std::move(cholesky), .first_column = {}};
      for (const std::size_t index : region)
        kept.first_column.emplace_back(graph.nodes()[index].id, column[index]);
      *converged = std::move(kept);
    }
  };
  int iterations = 0;
  std::vector<SE2> saved(region.size());
  const int max_iterations = to_convergence ? to_convergence->max_iterations : options_.max_iterations;
  const double relative_cost_decrease =
      to_convergence ? to_convergence->relative_cost_decrease : options_.relative_cost_decrease;
  for (int iteration = 0; iteration < max_iterations; ++iteration) {
    // Normal equations H δ = −g with H = Σ Jᵀ Ω J, g = Σ Jᵀ Ω e over the region's columns (lower triangle).
    gradient.setZero();
    if (iteration == 1 && !triplets.empty()) {  // a second pass over the pattern: index the slots
      slots.reserve(triplets.size());
      for (const Eigen::Triplet<double>& entry : triplets) {
        const int* const begin = hessian.innerIndexPtr() + hessian.outerIndexPtr()[entry.col()];
        const int* const end = hessian.innerIndexPtr() + hessian.outerIndexPtr()[entry.col() + 1];
        slots.push_back(
            static_cast<int>(std::lower_bound(begin, end, entry.row()) - hessian.innerIndexPtr()));
      }
      triplets = {};
    }
    const bool pattern_known = !slots.empty();
    if (pattern_known) std::fill_n(hessian.valuePtr(), hessian.nonZeros(), 0.0);
    double* const values = hessian.valuePtr();
    std::size_t next_slot = 0;
    const auto add_block = [&](int row, int col, const Matrix3& block) {  // H's lower triangle, or its mirror
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) {
          if (row + r < col + c) continue;
          if (pattern_known) {
            values[slots[next_slot++]] += block(r, c);
          } else if (upper) {
            triplets.emplace_back(col + c, row + r, block(r, c));
          } else {
            triplets.emplace_back(row + r, col + c, block(r, c));
          }
        }
      }
    };
    for (std::size_t k = 0; k < edges.size(); ++k) {
      const Matrix3& omega = information(k);
      const Linearised& at = current[k];
      const int a = column[ends[k].first], b = column[ends[k].second];
      const Vector3 weighted = omega * at.error;
      if (a >= 0) {
        add_block(a, a, at.d_from.transpose() * omega * at.d_from);
        gradient.segment<3>(a) += at.d_from.transpose() * weighted;
      }
      if (b >= 0) {
        add_block(b, b, at.d_to.transpose() * omega * at.d_to);
        gradient.segment<3>(b) += at.d_to.transpose() * weighted;
      }
      if (a >= 0 && b >= 0) {
        if (a > b) add_block(a, b, at.d_from.transpose() * omega * at.d_to);
        if (b > a) add_block(b, a, at.d_to.transpose() * omega * at.d_from);
      }
    }
    if (!pattern_known) hessian.setFromTriplets(triplets.begin(), triplets.end());
    Eigen::VectorXd diagonal;  // H's own, for the predicted decrease of a damped step
    if (damping > 0.0) {
      diagonal = hessian.diagonal();
      hessian.diagonal() *= 1.0 + damping;
    }
    ++iterations;
    const bool undamped = damping == 0.0;
    if (!normal_equations.Factorize(hessian)) {
      reject();
      if (damping > 1e8) break;
      continue;
    }
    const Eigen::VectorXd step = normal_equations.Solve(-gradient);
    // The decrease the linearisation predicts: −gᵀδ + λ δᵀ diag(H) δ (of Σ eᵀΩe, with (H + λ diag H) δ = −g).
    double predicted = -gradient.dot(step);
    if (damping > 0.0) predicted += damping * step.dot(diagonal.cwiseProduct(step));
    double largest_position = 0.0, largest_angle = 0.0;
    for (std::size_t k = 0; k < region.size(); ++k) {
      Node& node = graph.mutable_nodes()[region[k]];
      saved[k] = node.pose;
      const int c = column[region[k]];
      if (c < 0) continue;
      node.pose = SE2(node.pose.x() + step(c), node.pose.y() + step(c + 1), node.pose.theta() + step(c + 2));
      largest_position = std::max({largest_position, std::abs(step(c)), std::abs(step(c + 1))});
      largest_angle = std::max(largest_angle, std::abs(step(c + 2)));
    }
    const double new_cost = linearise(trial);
    const double scale = std::max(cost, 1e-300);
    if (!(new_cost <= cost)) {
      for (std::size_t k = 0; k < region.size(); ++k) graph.mutable_nodes()[region[k]].pose = saved[k];
      // An undamped step that promised less than the tolerance and did not deliver it is rounding at the
      // minimum: converged. (Damping it further only confirms that, at a factorisation per try.)
      if (undamped && predicted < relative_cost_decrease * scale) {
        keep_factorisation();
        break;
      }
      reject();
      if (damping > 1e8) break;
      continue;
    }
    const double actual = cost - new_cost;
    const double decrease = actual / scale;
    // How far the decrease strayed from the one the linearisation predicted, relative to the cost.
    const double model_error = std::abs(actual - predicted) / scale;
    const double gain_ratio = predicted > 0.0 ? actual / predicted : 1.0;
    cost = new_cost;
    std::swap(current, trial);
    damping *= std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * gain_ratio - 1.0, 3));
    damping_growth = 2.0;
    if (damping < 1e-8 && !undamped_failed) damping = 0.0;
    const bool tiny_step = largest_position < 1e-2 * options_.position_tolerance &&
                           largest_angle < 1e-2 * options_.angle_tolerance;
    // The stopping rules are at the top of incremental_solver.h. The linear step applies only to a region
    // held at its boundary: a whole component's last factorisation stands for H at the solution
    // (ComponentFactorisation), so it iterates until the step is tiny.
    const bool linear_enough =
        undamped && !to_convergence && converged == nullptr && model_error < relative_cost_decrease;
    if (decrease < relative_cost_decrease || (tiny_step && !to_convergence) || linear_enough) {
      if (undamped) keep_factorisation();
      break;
    }
  }
  return iterations;
}

std::vector<std::size_t> IncrementalSolver::MovingNeighbours(const PoseGraph& graph,
                                                             const std::vector<std::size_t>& region) {
  std::vector<std::size_t> moving;
  std::vector<std::size_t> checked;
  for (const std::size_t index : region) {
    for (const std::uint32_t e : incident_[index]) {
      for (const std::size_t held : {ends_[e].from, ends_[e].to}) {
        if (in_region_[held] || graph.nodes()[held].fixed || column_[held] == -2) continue;
        column_[held] = -2;  // checked (column_ is rebuilt by the next solve)
        checked.push_back(held);
        // What this update changed in the held node's own Gauss–Newton step (everything else where it is):
        // its step with the region where it is now against its step with the region where it was.
        const Vector3 change = LoneStepChange(graph, held);
        if (std::hypot(change.x(), change.y()) > options_.position_tolerance ||
            std::abs(change.z()) > options_.angle_tolerance) {
          moving.push_back(held);
        }
      }
    }
  }
  for (const std::size_t held : checked) column_[held] = -1;
  return moving;
}

Vector3 IncrementalSolver::LoneStepChange(const PoseGraph& graph, std::size_t held) {
  // The held node's Gauss–Newton step over its own edges, −H⁻¹g, with the region's poses as they are now
  // and as they were when the update admitted them. Both sums run over the same edges in the same order.
  // Only region nodes move during an update, and a region node's pose "as it was" is where the update found
  // it: so an edge's term "as before", and its term "now" when it does not touch the region, is its term at
  // the poses the update started from. That term is computed once per update and kept (start_terms_): the
  // same held nodes are checked again after every round.
  // Edge `e`'s term, its ends by graph index (`from`, `to`).
  const auto term = [&](std::uint32_t e, std::size_t from, std::size_t to, bool region_as_before,
                        Matrix3& block, Vector3& gradient) {
    const Edge& edge = graph.edges()[e];
    const auto pose = [&](std::size_t index) -> const SE2& {
      return region_as_before && in_region_[index] ? original_[index] : graph.nodes()[index].pose;
    };
    Matrix3 d_from, d_to;
    const SE2& from_pose = pose(from);
    const Vector3 error = EdgeError(from_pose, RotationT(from, from_pose), pose(to), edge.measurement,
                                    measurement_rotation_t_[e], &d_from, &d_to);
    const Matrix3& jacobian = from == held ? d_from : d_to;
    block = jacobian.transpose() * edge.information * jacobian;
    gradient = jacobian.transpose() * edge.information * error;
  };
  Matrix3 block_now = Matrix3::Zero(), block_before = Matrix3::Zero();
  Vector3 gradient_now = Vector3::Zero(), gradient_before = Vector3::Zero();
  Matrix3 block;
  Vector3 gradient;
  for (const std::uint32_t e : incident_[held]) {
    const std::size_t from = ends_[e].from, to = ends_[e].to;
    StartTerm& start = start_terms_[2 * e + (from == held ? 0 : 1)];
    if (start.update != updates_) {
      term(e, from, to, true, start.block, start.gradient);
      start.update = updates_;
    }
    if (in_region_[from] || in_region_[to]) {
      term(e, from, to, false, block, gradient);
      block_now += block;
      gradient_now += gradient;
    } else {
      block_now += start.block;
      gradient_now += start.gradient;
    }
    block_before += start.block;
    gradient_before += start.gradient;
  }
  return -block_now.ldlt().solve(gradient_now) + block_before.ldlt().solve(gradient_before);
}

}  // namespace slamcore::internal
