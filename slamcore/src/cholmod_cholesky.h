// The sparse Cholesky of a pose graph's normal equations, shared by the incremental back-end's large
// regions and the marginal covariances: CHOLMOD (Chen, Davis, Hager, Rajamanickam, "Algorithm 887:
// CHOLMOD", ACM TOMS 2008), on the calling thread only (calling_thread_only.h). CHOLMOD picks a
// supernodal or a simplicial factorisation by its own rule (supernodal when the factor's flops per entry
// reach 40): the supernodal one pays on maps with many loops (a city), the simplicial one on the long
// chains with few loops of a home's runs, where supernodes are a few columns wide and each BLAS call costs
// more than it computes (the analysis of a simulated hour of a robot-vacuum home: see README, sim_bench).
//
// The fill-reducing ordering is AMD (Amestoy, Davis, Duff, "An approximate minimum degree ordering
// algorithm", SIMAX 1996) on the pattern of the nodes, each node's three columns kept together: a ninth of
// the entries of the scalar pattern to order, for the same kind of ordering (AMD alone: nested dissection
// rarely repays its cost on a pose graph).
//
// Thread safety: one object per thread.
#pragma once

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <memory>

struct cholmod_factor_struct;  // cholmod.h's cholmod_factor, kept out of this header's includers

namespace slamcore::internal {

class CholmodCholesky {
 public:
  CholmodCholesky();
  ~CholmodCholesky();
  CholmodCholesky(const CholmodCholesky&) = delete;
  CholmodCholesky& operator=(const CholmodCholesky&) = delete;

  /// The symbolic analysis of the symmetric matrix whose lower triangle is `lower` (compressed; columns
  /// 3k, 3k + 1, 3k + 2 belong to node k). False when CHOLMOD fails (out of memory).
  bool Analyze(Eigen::SparseMatrix<double>& lower);
  /// The numeric factorisation of a matrix with the analysed pattern; false when it is not positive
  /// definite.
  bool Factorize(Eigen::SparseMatrix<double>& lower);
  /// x with H x = rhs, after a successful Factorize.
  Eigen::VectorXd Solve(const Eigen::VectorXd& rhs);
  /// The factor as a simplicial, packed LLᵀ (column j holds its diagonal first, then the rows below it,
  /// in the permuted order), for walks along columns; a supernodal or LDLᵀ factor is converted. Null on
  /// failure.
  const cholmod_factor_struct* ToSimplicial();
  /// The elimination order: permutation()[k] is the original column eliminated k-th.
  const int* permutation() const;

 private:
  struct State;  // CHOLMOD's workspace and factor
  std::unique_ptr<State> state_;
};

}  // namespace slamcore::internal
