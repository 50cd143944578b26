#include "cholmod_cholesky.h"

#include <cholmod.h>

#include <algorithm>
#include <vector>

#include "calling_thread_only.h"

namespace slamcore::internal {
namespace {

// A CHOLMOD view of an Eigen matrix (no copy): the lower triangle, or only its pattern.
cholmod_sparse LowerView(Eigen::SparseMatrix<double>& lower, bool pattern_only) {
  cholmod_sparse view{};
  view.nrow = static_cast<std::size_t>(lower.rows());
  view.ncol = static_cast<std::size_t>(lower.cols());
  view.nzmax = static_cast<std::size_t>(lower.nonZeros());
  view.p = lower.outerIndexPtr();
  view.i = lower.innerIndexPtr();
  view.x = pattern_only ? nullptr : lower.valuePtr();
  view.stype = -1;  // lower triangle stored
  view.itype = CHOLMOD_INT;
  view.xtype = pattern_only ? CHOLMOD_PATTERN : CHOLMOD_REAL;
  view.dtype = CHOLMOD_DOUBLE;
  view.sorted = 1;
  view.packed = 1;
  return view;
}

}  // namespace

struct CholmodCholesky::State {
  cholmod_common common;
  cholmod_factor* factor = nullptr;
  State() { cholmod_start(&common); }
  ~State() {
    if (factor) cholmod_free_factor(&factor, &common);
    cholmod_finish(&common);
  }
  State(const State&) = delete;
  State& operator=(const State&) = delete;
};

CholmodCholesky::CholmodCholesky() : state_(std::make_unique<State>()) {}
CholmodCholesky::~CholmodCholesky() = default;

const int* CholmodCholesky::permutation() const { return static_cast<const int*>(state_->factor->Perm); }

bool CholmodCholesky::Analyze(Eigen::SparseMatrix<double>& lower) {
  const CallingThreadOnly calling_thread_only;
  const int blocks = static_cast<int>(lower.cols() / 3);
  // The nodes' pattern (lower triangle), ordered by AMD, each node expanded to its three columns.
  std::vector<Eigen::Triplet<double>> entries;
  entries.reserve(static_cast<std::size_t>(lower.nonZeros() / 9 + blocks));
  // Each 3×3 block of a pose graph's H is stored whole (its lower part on the diagonal): its first entry
  // stands for it.
  for (int column = 0; column < lower.outerSize(); column += 3) {
    for (Eigen::SparseMatrix<double>::InnerIterator it(lower, column); it; ++it) {
      if (it.row() % 3 == 0) entries.emplace_back(static_cast<int>(it.row()) / 3, column / 3, 1.0);
    }
  }
  for (int block = 0; block < blocks; ++block) entries.emplace_back(block, block, 1.0);
  Eigen::SparseMatrix<double> pattern(blocks, blocks);
  pattern.setFromTriplets(entries.begin(), entries.end());
  pattern.makeCompressed();
  cholmod_sparse pattern_view = LowerView(pattern, /*pattern_only=*/true);
  std::vector<int> block_order(static_cast<std::size_t>(blocks));
  if (!cholmod_amd(&pattern_view, nullptr, 0, block_order.data(), &state_->common)) return false;
  std::vector<int> ordering;
  ordering.reserve(static_cast<std::size_t>(3 * blocks));
  for (const int block : block_order) {
    for (int axis = 0; axis < 3; ++axis) ordering.push_back(3 * block + axis);
  }

  if (state_->factor) cholmod_free_factor(&state_->factor, &state_->common);
  state_->common.nmethods = 1;
  state_->common.method[0].ordering = CHOLMOD_GIVEN;
  state_->common.supernodal = CHOLMOD_AUTO;  // supernodal or simplicial by CHOLMOD's rule (see the header)
  cholmod_sparse view = LowerView(lower, /*pattern_only=*/false);
  state_->factor = cholmod_analyze_p(&view, ordering.data(), nullptr, 0, &state_->common);
  return state_->factor != nullptr;
}

bool CholmodCholesky::Factorize(Eigen::SparseMatrix<double>& lower) {
  if (!state_->factor) return false;
  const CallingThreadOnly calling_thread_only;
  cholmod_sparse view = LowerView(lower, /*pattern_only=*/false);
  return cholmod_factorize(&view, state_->factor, &state_->common) && state_->common.status == CHOLMOD_OK &&
         state_->factor->minor >= state_->factor->n;
}

Eigen::VectorXd CholmodCholesky::Solve(const Eigen::VectorXd& rhs) {
  Eigen::VectorXd copy = rhs;
  cholmod_dense right{};
  right.nrow = right.d = static_cast<std::size_t>(copy.size());
  right.ncol = 1;
  right.nzmax = right.nrow;
  right.x = copy.data();
  right.xtype = CHOLMOD_REAL;
  right.dtype = CHOLMOD_DOUBLE;
  cholmod_dense* solution = cholmod_solve(CHOLMOD_A, state_->factor, &right, &state_->common);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(copy.size());
  if (solution) {
    std::copy_n(static_cast<const double*>(solution->x), copy.size(), x.data());
    cholmod_free_dense(&solution, &state_->common);
  }
  return x;
}

const cholmod_factor_struct* CholmodCholesky::ToSimplicial() {
  if (!state_->factor || !cholmod_change_factor(CHOLMOD_REAL, 1, 0, 1, 1, state_->factor, &state_->common))
    return nullptr;
  return state_->factor;
}

}  // namespace slamcore::internal
