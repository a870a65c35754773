// Marelli et al.'s exact test (exact_test.hpp; docs/stability.md 3.5): the blocks' kernel lattices,
// Phi_k, the verdict and the exact critical rates.
#include "networked_estimation/stability/exact_test.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "stability_internal.hpp"

namespace networked_estimation
{

using stability_internal::linkGrowth;
using stability_internal::spectralRadiusSmall;

namespace
{

/// Orthonormal basis of the largest subspace of span(B) (orthonormal columns) that W maps into itself:
/// K <- {x in K : W x in K} until it stops shrinking. With K = ker M at the start this is the
/// unobservable subspace of (W, M) (docs/stability.md 3.5c).
Eigen::MatrixXcd invariantPart(Eigen::MatrixXcd B, const Eigen::MatrixXcd& W)
{
  const double scale = W.norm();
  if (scale == 0.0)
    return B;
  const Eigen::Index n = W.rows();
  while (B.cols() > 0)
  {
    const Eigen::MatrixXcd off = (Eigen::MatrixXcd::Identity(n, n) - B * B.adjoint()) * W * B;
    const Eigen::MatrixXcd z = nullSpace(off, 1e-9, scale);
    if (z.cols() == B.cols())
      break;
    B = B * z;
  }
  return B;
}

/// Integer power of a square matrix.
Eigen::MatrixXcd power(const Eigen::MatrixXcd& M, int k)
{
  Eigen::MatrixXcd out = Eigen::MatrixXcd::Identity(M.rows(), M.cols());
  for (int i = 0; i < k; ++i)
    out = out * M;
  return out;
}

}  // namespace

std::vector<BlockStructure> analyseBlocks(const Eigen::MatrixXd& A, const std::vector<Eigen::MatrixXd>& H,
                                          const StabilityTolerances& tol, std::size_t lattice_cap)
{
  return analyseBlocks(A, fmoBlocks(A, 1.0, tol), H, tol, lattice_cap);
}

std::vector<BlockStructure> analyseBlocks(const Eigen::MatrixXd& A, const std::vector<FmoBlock>& blocks,
                                          const std::vector<Eigen::MatrixXd>& H, const StabilityTolerances& tol,
                                          std::size_t lattice_cap)
{
  std::vector<BlockStructure> out;
  const std::size_t ns = H.size();
  for (const FmoBlock& blk : blocks)
  {
    BlockStructure bs;
    bs.block = blk;
    const Eigen::MatrixXcd& V = blk.basis;
    const int nk = static_cast<int>(V.cols());
    const Eigen::MatrixXcd Id = Eigen::MatrixXcd::Identity(nk, nk);
    std::vector<double> hscale(ns);
    for (std::size_t j = 0; j < ns; ++j)
    {
      hscale[j] = std::max(1.0, H[j].norm());
      bs.relevant.push_back((H[j].cast<std::complex<double>>() * V).norm() > 1e-8 * hscale[j]);
    }
    std::ostringstream where;
    where << "block |alpha| = " << blk.modulus;
    // The block's matrix A_k (A V = V A_k) and, with N its order, the phase rotations
    // U = A_k / |alpha| and the nilpotent part W = (A_k / alpha)^N - I (zero when diagonalizable).
    // A packet of sensor j at phase s of the period N reveals M_js = H_j V U^s; packets of (j, s) at
    // enough distinct periods reveal exactly the orthogonal complement of the unobservable subspace
    // K_js of (W, M_js) (docs/stability.md 3.5c), which is ker M_js when W = 0 (Proposition 24).
    const int N = blk.order;
    Eigen::MatrixXcd U, W = Eigen::MatrixXcd::Zero(nk, nk);
    if (blk.diagonalizable)
    {
      U = (blk.diagonal / blk.modulus).asDiagonal();
    }
    else
    {
      const Eigen::MatrixXcd Ak = V.colPivHouseholderQr().solve(A.cast<std::complex<double>>() * V);
      U = Ak / blk.modulus;
      W = power(Ak / blk.alpha, N) - Id;
    }
    std::vector<std::vector<Eigen::MatrixXcd>> M(ns, std::vector<Eigen::MatrixXcd>(N));
    std::vector<std::vector<Eigen::MatrixXcd>> K(ns, std::vector<Eigen::MatrixXcd>(N));
    for (std::size_t j = 0; j < ns; ++j)
    {
      Eigen::MatrixXcd rot = Id;
      for (int s = 0; s < N; ++s)
      {
        M[j][s] = H[j].cast<std::complex<double>>() * V * rot;
        K[j][s] = invariantPart(nullSpace(M[j][s], 1e-9, hscale[j]), W);
        rot = rot * U;
      }
    }
    // Does sensor j at phase s inform on the subspace spanned by the orthonormal columns of B?
    auto informs = [&](std::size_t j, int s, const Eigen::MatrixXcd& B)
    {
      if (blk.diagonalizable)
        return (M[j][s] * B).norm() > 1e-8 * hscale[j];
      const Eigen::MatrixXcd& Kjs = K[j][s];
      return ((Id - Kjs * Kjs.adjoint()) * B).norm() > 1e-8;
    };
    // The lattice: the whole block and the atoms K_js, closed under intersection.
    std::vector<Eigen::MatrixXcd> elems;
    std::vector<Eigen::MatrixXcd> proj;
    auto add = [&](const Eigen::MatrixXcd& B)
    {
      if (B.cols() == 0)
        return false;
      const Eigen::MatrixXcd P = B * B.adjoint();
      for (const auto& Q : proj)
        if ((P - Q).norm() < 1e-6)
          return false;
      elems.push_back(B);
      proj.push_back(P);
      return true;
    };
    add(Id);
    for (std::size_t j = 0; j < ns; ++j)
      for (int s = 0; s < N; ++s)
        add(K[j][s]);
    bool grew = true, capped = false;
    while (grew && !capped)
    {
      grew = false;
      const std::size_t count = elems.size();
      for (std::size_t a = 0; a < count && !capped; ++a)
        for (std::size_t b = a + 1; b < count && !capped; ++b)
        {
          Eigen::MatrixXcd S(2 * nk, nk);
          S << Id - proj[a], Id - proj[b];
          if (add(nullSpace(S, 1e-8, 1.0)))
            grew = true;
          capped = elems.size() > lattice_cap;
        }
    }
    if (capped)
    {
      bs.method = BlockStructure::Method::UNAVAILABLE;
      bs.reason = where.str() + ": kernel lattice larger than " + std::to_string(lattice_cap) + " elements";
      out.push_back(bs);
      continue;
    }
    for (const auto& B : elems)
    {
      std::vector<std::vector<bool>> seen(ns, std::vector<bool>(N));
      for (std::size_t j = 0; j < ns; ++j)
        for (int s = 0; s < N; ++s)
          seen[j][s] = informs(j, s, B);
      bs.seen.push_back(seen);
    }
    if (blk.diagonalizable)
    {
      bs.method = BlockStructure::Method::LATTICE;
      bs.reason = where.str() + ": Proposition 24 (kernel lattice of " + std::to_string(elems.size()) +
                  " non-trivial elements, order N = " + std::to_string(N) + ")";
    }
    else if (blk.single_eigenvalue && elems.size() == 1)
    {
      bs.method = BlockStructure::Method::SINGLE_EIGENVALUE;
      bs.reason = where.str() +
                  ": single eigenvalue, every sensor that sees it observes it alone "
                  "(Corollary 26: Phi = product of loss persistences)";
    }
    else
    {
      bs.method = BlockStructure::Method::LATTICE;
      bs.reason = where.str() + " (not diagonalizable): lattice of the unobservable subspaces of " +
                  std::to_string(elems.size()) + " non-trivial elements, order N = " + std::to_string(N) +
                  " (docs/stability.md 3.5c)";
    }
    out.push_back(bs);
  }
  return out;
}

namespace
{

/// For a nonnegative M whose rows sum to at most 1: rho(M) = 1 exactly when some set of states keeps
/// all its mass under M (the states that leak, and those that lead only to them, removed in turn).
bool keepsAllMass(const Eigen::MatrixXd& M)
{
  const Eigen::Index n = M.rows();
  std::vector<bool> in(static_cast<std::size_t>(n), true);
  bool changed = true;
  while (changed)
  {
    changed = false;
    for (Eigen::Index i = 0; i < n; ++i)
    {
      if (!in[static_cast<std::size_t>(i)])
        continue;
      double kept = 0.0;
      for (Eigen::Index j = 0; j < n; ++j)
        if (in[static_cast<std::size_t>(j)])
          kept += M(i, j);
      if (kept < 1.0 - 1e-14)
      {
        in[static_cast<std::size_t>(i)] = false;
        changed = true;
      }
    }
  }
  return std::find(in.begin(), in.end(), true) != in.end();
}

}  // namespace

namespace stability_internal
{

BlockGrowth linkGrowth(const Eigen::MatrixXd& product, double exponent)
{
  BlockGrowth g;
  g.phi = std::pow(spectralRadiusSmall(product), exponent);
  g.one = keepsAllMass(product);
  if (g.one)
    g.phi = 1.0;
  return g;
}

}  // namespace stability_internal

BlockGrowth blockGrowth(const BlockStructure& block, const std::vector<LinkModel>& links)
{
  BlockGrowth out;
  if (block.method == BlockStructure::Method::UNAVAILABLE)
    return out;
  const int N = block.block.order;
  out.phi = 0.0;
  for (const auto& seen : block.seen)
  {
    BlockGrowth element;
    element.phi = 1.0;
    element.one = true;
    for (std::size_t j = 0; j < links.size(); ++j)
    {
      // rho(D_0 P D_1 P ... D_{N-1} P)^{1/N}, D_s(e) = P(no information on K at shift s | state e).
      const Eigen::MatrixXd P = links[j].transition();
      const Eigen::VectorXd loss = links[j].stateLoss();
      Eigen::MatrixXd prod = Eigen::MatrixXd::Identity(P.rows(), P.cols());
      for (int s = 0; s < N; ++s)
      {
        const Eigen::VectorXd d = seen[j][s] ? loss : Eigen::VectorXd::Ones(loss.size());
        prod = prod * d.asDiagonal() * P;
      }
      const BlockGrowth g = linkGrowth(prod, 1.0 / N);
      element.phi *= g.phi;
      element.one = element.one && g.one;
    }
    out.phi = std::max(out.phi, element.phi);
    out.one = out.one || element.one;
  }
  return out;
}

double blockPhi(const BlockStructure& block, const std::vector<LinkModel>& links)
{
  return blockGrowth(block, links).phi;
}

Verdict marelliTest(const std::vector<BlockStructure>& blocks, const std::vector<LinkModel>& links,
                    const StabilityTolerances& tol, const Schedule* schedule)
{
  Verdict v;
  if (blocks.empty())
  {
    v.kind = Verdict::Kind::STABLE;
    v.reason = "no eigenvalue with |lambda| >= 1";
    return v;
  }
  double worst = 0.0;
  std::size_t worst_k = 0;
  // Each block is decided on its own: |alpha|^2 Phi against 1 (Theorem 14; equality undecided,
  // Remark 15), except on the unit circle, where Phi below 1 (not exactly 1) is bounded and Phi
  // exactly 1 unbounded (docs/stability.md 3.5d): below 1 the error, which grows polynomially
  // between observations, is outweighed by the geometric decay of the probability of a long gap;
  // at 1 some link state never delivers what the block needs, and the block's error grows from there.
  bool any_unstable = false, any_undecided = false;
  std::size_t lost_k = blocks.size();
  for (std::size_t k = 0; k < blocks.size(); ++k)
  {
    std::string why;
    const BlockGrowth growth = blockGrowth(blocks[k], links, schedule, &why);
    const double phi = growth.phi;
    if (std::isnan(phi))
    {
      v.kind = Verdict::Kind::NOT_APPLICABLE;
      v.reason = "Theorem 14 not computable: " + (why.empty() ? blocks[k].reason : why);
      v.numbers["block modulus"] = blocks[k].block.modulus;
      return v;
    }
    const double g = blocks[k].block.modulus * blocks[k].block.modulus * phi;
    v.numbers["Phi[" + std::to_string(k) + "]"] = phi;
    if (std::abs(blocks[k].block.modulus - 1.0) <= tol.modulus)
    {
      if (growth.one && lost_k == blocks.size())
        lost_k = k;
      any_unstable = any_unstable || growth.one;
    }
    else if (g > 1.0 + tol.decision)
      any_unstable = true;
    else if (g >= 1.0 - tol.decision)
      any_undecided = true;
    if (k == 0 || g > worst)
    {
      worst = g;
      worst_k = k;
    }
  }
  v.numbers["max |alpha|^2 Phi"] = worst;
  v.numbers["|alpha|"] = blocks[worst_k].block.modulus;
  std::ostringstream os;
  os << "Theorem 14 (Marelli et al.): max |alpha_k|^2 Phi_k = " << worst
     << " at |alpha| = " << blocks[worst_k].block.modulus;
  if (schedule && schedule->active())
    os << " (with the sensor schedule, tau = " << schedule->period() << ")";
  if (any_unstable)
  {
    v.kind = Verdict::Kind::UNSTABLE;
    if (worst > 1.0 + tol.decision)
      os << " > 1";
    else
      os << "; a block on the unit circle (|alpha| = " << blocks[lost_k].block.modulus
         << ") has Phi = 1: from some link state its information never arrives, and its error grows from there "
            "(docs/stability.md 3.5d)";
  }
  else if (any_undecided)
  {
    v.kind = Verdict::Kind::UNDECIDED;
    os << " = 1 (equality is inconclusive, Remark 15)";
  }
  else
  {
    v.kind = Verdict::Kind::STABLE;
    os << (worst < 1.0 - tol.decision ? " < 1" : " < 1 (|alpha| = 1 with Phi below 1, docs/stability.md 3.5d)");
  }
  v.reason = os.str();
  return v;
}

double exactCriticalArrivalRate(const std::vector<BlockStructure>& blocks)
{
  double rate = 0.0;
  for (const BlockStructure& b : blocks)
  {
    if (b.method == BlockStructure::Method::UNAVAILABLE)
      return std::numeric_limits<double>::quiet_NaN();
    double best = std::numeric_limits<double>::infinity();
    for (const auto& seen : b.seen)
    {
      double count = 0.0;
      for (const auto& row : seen)
        for (bool x : row)
          count += x ? 1.0 : 0.0;
      best = std::min(best, count);
    }
    const double e = best / b.block.order;
    if (e <= 0.0)
      return std::numeric_limits<double>::infinity();
    rate = std::max(rate, 1.0 - std::pow(b.block.modulus, -2.0 / e));
  }
  return rate;
}

double exactCriticalRecoveryRate(const std::vector<BlockStructure>& blocks, double p)
{
  if (blocks.empty())
    return 0.0;
  for (const BlockStructure& b : blocks)
    if (b.method == BlockStructure::Method::UNAVAILABLE)
      return std::numeric_limits<double>::quiet_NaN();
  const std::size_t ns = blocks.front().relevant.size();
  auto growth = [&](double r)
  {
    const std::vector<LinkModel> links(ns, LinkModel::gilbertElliott(p, r));
    double g = 0.0;
    for (const BlockStructure& b : blocks)
      g = std::max(g, b.block.modulus * b.block.modulus * blockPhi(b, links));
    return g;
  };
  if (growth(1.0) >= 1.0)
    return std::numeric_limits<double>::infinity();
  double lo = 0.0, hi = 1.0;
  if (growth(0.0) < 1.0)
    return 0.0;
  for (int it = 0; it < 60 && hi - lo > 1e-13; ++it)
  {
    const double mid = 0.5 * (lo + hi);
    (growth(mid) < 1.0 ? hi : lo) = mid;
  }
  // Every rate tried was stable (|alpha| = 1 blocks: growth 1 only at r = 0): the infimum is 0, not
  // the bracket's midpoint of a few 1e-14.
  if (lo == 0.0)
    return 0.0;
  return 0.5 * (lo + hi);
}

double corollary26Phi(const std::vector<double>& conditional_bad_probabilities)
{
  if (conditional_bad_probabilities.empty())
    return std::numeric_limits<double>::quiet_NaN();
  double logsum = 0.0;
  for (double q : conditional_bad_probabilities)
    logsum += std::log(q);
  return std::exp(logsum / static_cast<double>(conditional_bad_probabilities.size()));
}

}  // namespace networked_estimation
