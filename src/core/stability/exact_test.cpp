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

using stability_internal::spectralRadiusSmall;

std::vector<BlockStructure> analyseBlocks(const Eigen::MatrixXd& A, const std::vector<Eigen::MatrixXd>& H,
                                          const StabilityTolerances& tol, std::size_t lattice_cap)
{
  std::vector<BlockStructure> out;
  const std::size_t ns = H.size();
  for (const FmoBlock& blk : fmoBlocks(A, 1.0, tol))
  {
    BlockStructure bs;
    bs.block = blk;
    const Eigen::MatrixXcd& V = blk.basis;
    const int nk = static_cast<int>(V.cols());
    std::vector<double> hscale(ns);
    for (std::size_t j = 0; j < ns; ++j)
    {
      hscale[j] = std::max(1.0, H[j].norm());
      bs.relevant.push_back((H[j].cast<std::complex<double>>() * V).norm() > 1e-8 * hscale[j]);
    }
    std::ostringstream where;
    where << "block |alpha| = " << blk.modulus;
    if (blk.diagonalizable)
    {
      // Proposition 24: atoms ker(H_j V D^s), s < N_k, closed under intersection.
      const int N = blk.order;
      Eigen::VectorXcd unit = blk.diagonal / blk.modulus;
      std::vector<std::vector<Eigen::MatrixXcd>> M(ns, std::vector<Eigen::MatrixXcd>(N));
      for (std::size_t j = 0; j < ns; ++j)
      {
        Eigen::VectorXcd d = Eigen::VectorXcd::Ones(nk);
        for (int s = 0; s < N; ++s)
        {
          M[j][s] = H[j].cast<std::complex<double>>() * V * d.asDiagonal();
          d = d.cwiseProduct(unit);
        }
      }
      std::vector<Eigen::MatrixXcd> elems;
      std::vector<Eigen::MatrixXcd> proj;
      auto add = [&](const Eigen::MatrixXcd& U) {
        if (U.cols() == 0)
          return false;
        const Eigen::MatrixXcd P = U * U.adjoint();
        for (const auto& Q : proj)
          if ((P - Q).norm() < 1e-6)
            return false;
        elems.push_back(U);
        proj.push_back(P);
        return true;
      };
      add(Eigen::MatrixXcd::Identity(nk, nk));
      for (std::size_t j = 0; j < ns; ++j)
        for (int s = 0; s < N; ++s)
          add(nullSpace(M[j][s], 1e-9, hscale[j]));
      bool grew = true, capped = false;
      while (grew && !capped)
      {
        grew = false;
        const std::size_t count = elems.size();
        for (std::size_t a = 0; a < count && !capped; ++a)
          for (std::size_t b = a + 1; b < count && !capped; ++b)
          {
            Eigen::MatrixXcd S(2 * nk, nk);
            S << Eigen::MatrixXcd::Identity(nk, nk) - proj[a], Eigen::MatrixXcd::Identity(nk, nk) - proj[b];
            if (add(nullSpace(S, 1e-8, 1.0)))
              grew = true;
            capped = elems.size() > lattice_cap;
          }
      }
      if (capped)
      {
        bs.method = BlockStructure::Method::UNAVAILABLE;
        bs.reason = where.str() + ": kernel lattice larger than " + std::to_string(lattice_cap) + " elements";
      }
      else
      {
        bs.method = BlockStructure::Method::LATTICE;
        bs.reason = where.str() + ": Proposition 24 (kernel lattice of " + std::to_string(elems.size()) +
                    " non-trivial elements, order N = " + std::to_string(N) + ")";
        for (const auto& U : elems)
        {
          std::vector<std::vector<bool>> seen(ns, std::vector<bool>(N));
          for (std::size_t j = 0; j < ns; ++j)
            for (int s = 0; s < N; ++s)
              seen[j][s] = (M[j][s] * U).norm() > 1e-8 * hscale[j];
          bs.seen.push_back(seen);
        }
      }
    }
    else if (blk.single_eigenvalue)
    {
      bool ok = true;
      std::ostringstream why;
      for (std::size_t j = 0; j < ns && ok; ++j)
      {
        if (!bs.relevant[j])
          continue;
        const Eigen::MatrixXcd HE = H[j].cast<std::complex<double>>() * blk.eigenspace;
        if (numericalRank(HE, 1e-8, hscale[j]) < blk.eigenspace.cols())
        {
          ok = false;
          why << where.str() << " (not diagonalizable): sensor " << j
              << " sees the block but does not observe it alone; neither Proposition 24 nor Corollary 26 applies";
        }
      }
      if (ok)
      {
        bs.method = BlockStructure::Method::SINGLE_EIGENVALUE;
        bs.reason = where.str() + ": single eigenvalue, every sensor that sees it observes it alone "
                                  "(Corollary 26: Phi = product of loss persistences)";
      }
      else
      {
        bs.method = BlockStructure::Method::UNAVAILABLE;
        bs.reason = why.str();
      }
    }
    else
    {
      bs.method = BlockStructure::Method::UNAVAILABLE;
      bs.reason = where.str() + ": not diagonalizable with several eigenvalues of a common order "
                                "(Proposition 24 needs A_k^N = alpha^N I)";
    }
    out.push_back(bs);
  }
  return out;
}

double blockPhi(const BlockStructure& block, const std::vector<LinkModel>& links)
{
  switch (block.method)
  {
    case BlockStructure::Method::UNAVAILABLE:
      return std::numeric_limits<double>::quiet_NaN();
    case BlockStructure::Method::SINGLE_EIGENVALUE:
    {
      double phi = 1.0;
      for (std::size_t j = 0; j < links.size(); ++j)
        if (block.relevant[j])
          phi *= links[j].lossPersistence();
      return phi;
    }
    case BlockStructure::Method::LATTICE:
    {
      const int N = block.block.order;
      double best = 0.0;
      for (const auto& seen : block.seen)
      {
        double phi = 1.0;
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
          phi *= std::pow(spectralRadiusSmall(prod), 1.0 / N);
        }
        best = std::max(best, phi);
      }
      return best;
    }
  }
  return std::numeric_limits<double>::quiet_NaN();
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
  for (std::size_t k = 0; k < blocks.size(); ++k)
  {
    std::string why;
    const bool scheduled = schedule && schedule->active();
    const double phi = scheduled ? blockPhiScheduled(blocks[k], links, *schedule, &why) : blockPhi(blocks[k], links);
    if (std::isnan(phi))
    {
      v.kind = Verdict::Kind::NOT_APPLICABLE;
      v.reason = "Theorem 14 not computable: " + (why.empty() ? blocks[k].reason : why);
      v.numbers["block modulus"] = blocks[k].block.modulus;
      return v;
    }
    const double g = blocks[k].block.modulus * blocks[k].block.modulus * phi;
    v.numbers["Phi[" + std::to_string(k) + "]"] = phi;
    if (k == 0 || g > worst)
    {
      worst = g;
      worst_k = k;
    }
  }
  v.numbers["max |alpha|^2 Phi"] = worst;
  v.numbers["|alpha|"] = blocks[worst_k].block.modulus;
  std::ostringstream os;
  os << "Theorem 14 (Marelli et al.): max |alpha_k|^2 Phi_k = " << worst << " at |alpha| = " << blocks[worst_k].block.modulus;
  if (schedule && schedule->active())
    os << " (with the sensor schedule, tau = " << schedule->period() << ")";
  if (worst < 1.0 - tol.decision)
  {
    v.kind = Verdict::Kind::STABLE;
    os << " < 1";
  }
  else if (worst > 1.0 + tol.decision)
  {
    v.kind = Verdict::Kind::UNSTABLE;
    os << " > 1";
  }
  else
  {
    v.kind = Verdict::Kind::UNDECIDED;
    os << " = 1 (equality is inconclusive, Remark 15)";
  }
  v.reason = os.str();
  return v;
}

double exactCriticalArrivalRate(const std::vector<BlockStructure>& blocks)
{
  double rate = 0.0;
  for (const BlockStructure& b : blocks)
  {
    double e = 0.0;
    if (b.method == BlockStructure::Method::UNAVAILABLE)
      return std::numeric_limits<double>::quiet_NaN();
    if (b.method == BlockStructure::Method::SINGLE_EIGENVALUE)
    {
      for (bool r : b.relevant)
        e += r ? 1.0 : 0.0;
    }
    else
    {
      double best = std::numeric_limits<double>::infinity();
      for (const auto& seen : b.seen)
      {
        double count = 0.0;
        for (const auto& row : seen)
          for (bool x : row)
            count += x ? 1.0 : 0.0;
        best = std::min(best, count);
      }
      e = best / b.block.order;
    }
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
  auto growth = [&](double r) {
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
