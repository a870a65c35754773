// Stability analysis, part 1: eigen-structure helpers, FMO blocks, links and the exact test of
// Marelli et al. (docs/stability.md 3.5).
#include "networked_estimation/stability/stability.hpp"
#include "networked_estimation/common/index_select.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <sstream>

namespace networked_estimation
{

namespace
{

constexpr double kPi = 3.14159265358979323846;

struct Cluster
{
  std::complex<double> center;
  int multiplicity = 0;
};

/// Distinct eigenvalues (clusters of numerically equal ones) with their algebraic multiplicity.
std::vector<Cluster> clusters(const Eigen::VectorXcd& ev, double rel_tol)
{
  std::vector<Cluster> out;
  for (int i = 0; i < ev.size(); ++i)
  {
    bool placed = false;
    for (Cluster& c : out)
      if (std::abs(ev[i] - c.center) <= rel_tol * std::max(1.0, std::abs(c.center)))
      {
        c.center = (c.center * static_cast<double>(c.multiplicity) + ev[i]) / static_cast<double>(c.multiplicity + 1);
        ++c.multiplicity;
        placed = true;
        break;
      }
    if (!placed)
      out.push_back({ev[i], 1});
  }
  return out;
}

Eigen::MatrixXcd shifted(const Eigen::MatrixXd& A, std::complex<double> lambda)
{
  Eigen::MatrixXcd M = A.cast<std::complex<double>>();
  M.diagonal().array() -= lambda;
  return M;
}

/// Rank tolerance used on A - lambda I with a computed (slightly inexact) eigenvalue.
double shiftTolerance(const StabilityTolerances& tol)
{
  return std::max(tol.eigen_cluster * 1e-2, 1e-7);
}

/// Smallest q <= qmax with |q x - round(q x)| <= eps, 0 when none.
int denominator(double x, int qmax, double eps)
{
  for (int q = 1; q <= qmax; ++q)
    if (std::abs(q * x - std::round(q * x)) <= eps * q)
      return q;
  return 0;
}

double spectralRadiusSmall(const Eigen::MatrixXd& M)
{
  if (M.rows() == 1)
    return std::abs(M(0, 0));
  return Eigen::EigenSolver<Eigen::MatrixXd>(M, false).eigenvalues().cwiseAbs().maxCoeff();
}

}  // namespace

std::string toString(Verdict::Kind kind)
{
  switch (kind)
  {
    case Verdict::Kind::STABLE:
      return "stable";
    case Verdict::Kind::UNSTABLE:
      return "unstable";
    case Verdict::Kind::UNDECIDED:
      return "undecided";
    case Verdict::Kind::NOT_APPLICABLE:
      return "not applicable";
  }
  return "?";
}

std::string describe(const Verdict& verdict)
{
  return toString(verdict.kind) + ": " + verdict.reason;
}

Eigen::VectorXcd eigenvalues(const Eigen::MatrixXd& A)
{
  if (A.rows() == 0)
    return Eigen::VectorXcd();
  return Eigen::EigenSolver<Eigen::MatrixXd>(A, false).eigenvalues();
}

double spectralRadius(const Eigen::MatrixXd& A)
{
  return A.rows() == 0 ? 0.0 : eigenvalues(A).cwiseAbs().maxCoeff();
}

double mahlerMeasure(const Eigen::MatrixXd& A)
{
  return std::exp(topologicalEntropy(A));
}

double topologicalEntropy(const Eigen::MatrixXd& A)
{
  const Eigen::VectorXcd ev = eigenvalues(A);
  double h = 0.0;
  for (int i = 0; i < ev.size(); ++i)
    h += std::max(0.0, std::log(std::abs(ev[i])));
  return h;
}

int numericalRank(const Eigen::MatrixXcd& M, double rel_tol, double scale)
{
  if (M.size() == 0)
    return 0;
  Eigen::JacobiSVD<Eigen::MatrixXcd> svd(M);
  const Eigen::VectorXd sv = svd.singularValues();
  const double thr = rel_tol * std::max(scale, sv.size() ? sv[0] : 0.0);
  int r = 0;
  for (int i = 0; i < sv.size(); ++i)
    r += sv[i] > thr ? 1 : 0;
  return r;
}

Eigen::MatrixXcd nullSpace(const Eigen::MatrixXcd& M, double rel_tol, double scale)
{
  const int n = static_cast<int>(M.cols());
  if (M.rows() == 0)
    return Eigen::MatrixXcd::Identity(n, n);
  Eigen::JacobiSVD<Eigen::MatrixXcd> svd(M, Eigen::ComputeFullV);
  const Eigen::VectorXd sv = svd.singularValues();
  const double thr = rel_tol * std::max(scale, sv.size() ? sv[0] : 0.0);
  int r = 0;
  for (int i = 0; i < sv.size(); ++i)
    r += sv[i] > thr ? 1 : 0;
  return svd.matrixV().rightCols(n - r);
}

bool isDiagonalizable(const Eigen::MatrixXd& A, const StabilityTolerances& tol)
{
  const int n = static_cast<int>(A.rows());
  const double scale = std::max(1.0, A.norm());
  for (const Cluster& c : clusters(eigenvalues(A), tol.eigen_cluster))
  {
    const int geometric = n - numericalRank(shifted(A, c.center), shiftTolerance(tol), scale);
    if (geometric < c.multiplicity)
      return false;
  }
  return true;
}

bool isObservable(const Eigen::MatrixXd& A, const Eigen::MatrixXd& C, double rel_tol)
{
  const int n = static_cast<int>(A.rows());
  Eigen::MatrixXd O(C.rows() * n, n);
  Eigen::MatrixXd blk = C;
  for (int k = 0; k < n; ++k)
  {
    O.middleRows(k * C.rows(), C.rows()) = blk;
    blk = blk * A;
  }
  return numericalRank(O.cast<std::complex<double>>(), rel_tol) == n;
}

bool modesControllable(const Eigen::MatrixXd& A, const Eigen::MatrixXd& G, double min_modulus, double rel_tol)
{
  const int n = static_cast<int>(A.rows());
  StabilityTolerances tol;
  const double scale = std::max({1.0, A.norm(), G.norm()});
  for (const Cluster& c : clusters(eigenvalues(A), tol.eigen_cluster))
  {
    if (std::abs(c.center) < min_modulus * (1.0 - 1e-9))
      continue;
    Eigen::MatrixXcd M(n, n + G.cols());
    M << shifted(A, c.center), G.cast<std::complex<double>>();
    if (numericalRank(M, std::max(rel_tol, shiftTolerance(tol)), scale) < n)
      return false;
  }
  return true;
}

bool modesObservable(const Eigen::MatrixXd& A, const Eigen::MatrixXd& C, double min_modulus, double rel_tol)
{
  return modesControllable(A.transpose(), C.transpose(), min_modulus, rel_tol);
}

Verdict strongObservability(const Eigen::MatrixXd& A, const Eigen::MatrixXd& C, const StabilityTolerances& tol)
{
  Verdict v;
  if (!isDiagonalizable(A, tol))
  {
    v.kind = Verdict::Kind::NOT_APPLICABLE;
    v.reason = "A is not diagonalizable (strong observability is defined for diagonalizable A)";
    return v;
  }
  Eigen::EigenSolver<Eigen::MatrixXd> es(A);
  const Eigen::VectorXcd ev = es.eigenvalues();
  const Eigen::MatrixXcd Ct = C.cast<std::complex<double>>() * es.eigenvectors();
  const int n = static_cast<int>(A.rows());
  std::vector<bool> done(n, false);
  for (int i = 0; i < n; ++i)
  {
    if (done[i])
      continue;
    std::vector<int> group;
    for (int j = i; j < n; ++j)
      if (!done[j] && std::abs(std::abs(ev[j]) - std::abs(ev[i])) <= tol.modulus * std::max(1.0, std::abs(ev[i])))
      {
        group.push_back(j);
        done[j] = true;
      }
    const Eigen::MatrixXcd sub = selectCols(Ct, group);
    const int rank = numericalRank(sub, 1e-8, std::max(1.0, C.norm()));
    if (rank < static_cast<int>(group.size()))
    {
      std::ostringstream os;
      os << "(A, C) is not strongly observable: the " << group.size() << " eigenvalue(s) of modulus "
         << std::abs(ev[i]) << " give C V a column rank of " << rank;
      v.kind = Verdict::Kind::UNSTABLE;
      v.reason = os.str();
      v.numbers["modulus"] = std::abs(ev[i]);
      v.numbers["group size"] = static_cast<double>(group.size());
      v.numbers["rank"] = rank;
      return v;
    }
  }
  v.kind = Verdict::Kind::STABLE;
  v.reason = "(A, C) is strongly observable: every group of equal-modulus eigenvalues has C V of full column rank";
  return v;
}

std::vector<FmoBlock> fmoBlocks(const Eigen::MatrixXd& A, double min_modulus, const StabilityTolerances& tol)
{
  const int n = static_cast<int>(A.rows());
  const double scale = std::max(1.0, A.norm());
  std::vector<Cluster> cl;
  for (const Cluster& c : clusters(eigenvalues(A), tol.eigen_cluster))
    if (std::abs(c.center) >= min_modulus * (1.0 - tol.modulus))
      cl.push_back(c);
  // Union of clusters with equal modulus and rational argument difference.
  std::vector<int> parent(cl.size());
  std::iota(parent.begin(), parent.end(), 0);
  std::vector<int> q_of(cl.size(), 1);
  for (std::size_t i = 0; i < cl.size(); ++i)
  {
    if (parent[i] != static_cast<int>(i))
      continue;
    for (std::size_t j = i + 1; j < cl.size(); ++j)
    {
      if (parent[j] != static_cast<int>(j))
        continue;
      const double mi = std::abs(cl[i].center), mj = std::abs(cl[j].center);
      if (std::abs(mi - mj) > tol.modulus * std::max(1.0, mi))
        continue;
      const double d = (std::arg(cl[j].center) - std::arg(cl[i].center)) / (2.0 * kPi);
      const int q = denominator(d, tol.max_denominator, 1e-7);
      if (q > 0)
      {
        parent[j] = static_cast<int>(i);
        q_of[j] = q;
      }
    }
  }
  std::vector<FmoBlock> out;
  for (std::size_t i = 0; i < cl.size(); ++i)
  {
    if (parent[i] != static_cast<int>(i))
      continue;
    FmoBlock b;
    b.alpha = cl[i].center;
    b.modulus = std::abs(cl[i].center);
    std::vector<std::size_t> members;
    for (std::size_t j = 0; j < cl.size(); ++j)
      if (parent[j] == static_cast<int>(i))
      {
        members.push_back(j);
        b.order = std::lcm(b.order, q_of[j]);
      }
    b.single_eigenvalue = members.size() == 1;
    std::vector<Eigen::MatrixXcd> vecs, gen;
    std::vector<std::complex<double>> diag;
    for (std::size_t j : members)
    {
      const Cluster& c = cl[j];
      for (int k = 0; k < c.multiplicity; ++k)
        b.eigenvalues.push_back(c.center);
      const Eigen::MatrixXcd S = shifted(A, c.center);
      const Eigen::MatrixXcd E = nullSpace(S, shiftTolerance(tol), scale);
      if (E.cols() < c.multiplicity)
        b.diagonalizable = false;
      vecs.push_back(E);
      for (int k = 0; k < E.cols(); ++k)
        diag.push_back(c.center);
      Eigen::MatrixXcd P = S;
      for (int k = 1; k < c.multiplicity; ++k)
        P = P * S;
      gen.push_back(nullSpace(P, shiftTolerance(tol), std::pow(scale, c.multiplicity)));
      if (b.single_eigenvalue)
        b.eigenspace = E;
    }
    const std::vector<Eigen::MatrixXcd>& parts = b.diagonalizable ? vecs : gen;
    int cols = 0;
    for (const auto& p : parts)
      cols += static_cast<int>(p.cols());
    b.basis.resize(n, cols);
    int c0 = 0;
    for (const auto& p : parts)
    {
      b.basis.middleCols(c0, p.cols()) = p;
      c0 += static_cast<int>(p.cols());
    }
    if (b.diagonalizable)
      b.diagonal = Eigen::Map<const Eigen::VectorXcd>(diag.data(), static_cast<int>(diag.size()));
    out.push_back(b);
  }
  std::stable_sort(out.begin(), out.end(), [](const FmoBlock& a, const FmoBlock& b) { return a.modulus > b.modulus; });
  return out;
}

// ---------------------------------------------------------------------------------------------

LinkModel LinkModel::iid(double arrival_rate)
{
  LinkModel l;
  l.kind = Kind::IID;
  l.arrival = arrival_rate;
  return l;
}

LinkModel LinkModel::gilbertElliott(double p_, double r_, double loss_bad_, double loss_good_)
{
  LinkModel l;
  l.kind = Kind::GILBERT_ELLIOTT;
  l.p = p_;
  l.r = r_;
  l.loss_bad = loss_bad_;
  l.loss_good = loss_good_;
  return l;
}

LinkModel LinkModel::fromSettings(const ChannelSettings& s)
{
  if (s.model == LossModelKind::BERNOULLI)
    return iid(1.0 - s.loss);
  return gilbertElliott(s.p, s.r, s.loss_bad, s.loss_good);
}

Eigen::MatrixXd LinkModel::transition() const
{
  if (kind == Kind::IID)
    return Eigen::MatrixXd::Ones(1, 1);
  Eigen::MatrixXd P(2, 2);
  P << 1.0 - p, p, r, 1.0 - r;  // states: 0 = good, 1 = bad
  return P;
}

Eigen::VectorXd LinkModel::stateLoss() const
{
  if (kind == Kind::IID)
    return Eigen::VectorXd::Constant(1, 1.0 - arrival);
  return Eigen::Vector2d(loss_good, loss_bad);
}

namespace
{

/// Stationary law of the hidden chain (uniform start for a reducible chain without transitions).
Eigen::VectorXd stationary(const LinkModel& l)
{
  if (l.kind == LinkModel::Kind::IID)
    return Eigen::VectorXd::Ones(1);
  if (l.p + l.r <= 0.0)
    return Eigen::Vector2d(1.0, 0.0);
  return Eigen::Vector2d(l.r / (l.p + l.r), l.p / (l.p + l.r));
}

}  // namespace

double LinkModel::arrivalRate() const
{
  return 1.0 - stationary(*this).dot(stateLoss());
}

double LinkModel::recoveryRate() const
{
  if (kind == Kind::IID)
    return arrival;
  if (onOff())
    return r;
  // P(arrived at k | lost at k-1) = pi' diag(loss) P (1 - loss) / pi' loss.
  const Eigen::VectorXd pi = stationary(*this), loss = stateLoss();
  const double lost = pi.dot(loss);
  if (lost <= 0.0)
    return std::numeric_limits<double>::quiet_NaN();
  const Eigen::VectorXd w = loss.cwiseProduct(pi);
  return (w.transpose() * transition() * (Eigen::VectorXd::Ones(loss.size()) - loss))(0) / lost;
}

double LinkModel::lossPersistence() const
{
  return spectralRadiusSmall(stateLoss().asDiagonal() * transition());
}

// ---------------------------------------------------------------------------------------------

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

namespace
{

long gcdLong(long a, long b)
{
  while (b != 0)
  {
    const long t = a % b;
    a = b;
    b = t;
  }
  return a;
}

/// seen(e, j, s): does sensor j give information on lattice element e at shift s (s < order)?
/// A single-eigenvalue block is one element, seen at every shift by its relevant sensors.
bool seenAt(const BlockStructure& block, std::size_t e, std::size_t j, int s)
{
  if (block.method == BlockStructure::Method::SINGLE_EIGENVALUE)
    return block.relevant[j];
  return block.seen[e][j][static_cast<std::size_t>(s % block.block.order)];
}

}  // namespace

double blockPhiScheduled(const BlockStructure& block, const std::vector<LinkModel>& links, const Schedule& schedule,
                         std::string* why, std::size_t max_states)
{
  if (!schedule.active())
    return blockPhi(block, links);
  if (block.method == BlockStructure::Method::UNAVAILABLE)
    return std::numeric_limits<double>::quiet_NaN();
  const bool single = block.method == BlockStructure::Method::SINGLE_EIGENVALUE;
  const int N = single ? 1 : block.block.order;
  const std::size_t elements = single ? 1 : block.seen.size();
  const std::size_t S = links.size();
  double best = 0.0;
  if (schedule.kind == Schedule::Kind::PERIODIC)
  {
    const long tau = static_cast<long>(schedule.pattern.size());
    const long M = N / gcdLong(N, tau) * tau;
    for (long t0 = 0; t0 < tau; ++t0)
      for (std::size_t e = 0; e < elements; ++e)
      {
        double phi = 1.0;
        for (std::size_t j = 0; j < S; ++j)
        {
          const Eigen::MatrixXd P = links[j].transition();
          const Eigen::VectorXd loss = links[j].stateLoss();
          const Eigen::VectorXd ones = Eigen::VectorXd::Ones(loss.size());
          Eigen::MatrixXd prod = Eigen::MatrixXd::Identity(P.rows(), P.cols());
          for (long s = 0; s < M; ++s)
          {
            const bool on = schedule.pattern[static_cast<std::size_t>((t0 + s) % tau)][j];
            const Eigen::VectorXd& d = on && seenAt(block, e, j, static_cast<int>(s % N)) ? loss : ones;
            prod = prod * d.asDiagonal() * P;
          }
          phi *= std::pow(spectralRadiusSmall(prod), 1.0 / static_cast<double>(M));
        }
        best = std::max(best, phi);
      }
    return best;
  }
  // RANDOM: the joint chain (schedule state, link states), states enumerated with the schedule
  // state slowest and link j's state at stride prod_{i > j} |states_i|.
  const Eigen::Index K = schedule.transition.rows();
  std::vector<Eigen::Index> sizes(S);
  std::size_t total = static_cast<std::size_t>(K);
  for (std::size_t j = 0; j < S; ++j)
  {
    sizes[j] = links[j].transition().rows();
    total *= static_cast<std::size_t>(sizes[j]);
  }
  if (total > max_states)
  {
    if (why)
      *why = "the random schedule's joint chain (schedule state x link states) has " + std::to_string(total) +
             " states, more than " + std::to_string(max_states);
    return std::numeric_limits<double>::quiet_NaN();
  }
  Eigen::MatrixXd T = schedule.transition;
  for (std::size_t j = 0; j < S; ++j)
  {
    const Eigen::MatrixXd P = links[j].transition();
    Eigen::MatrixXd next(T.rows() * P.rows(), T.cols() * P.cols());
    for (Eigen::Index a = 0; a < T.rows(); ++a)
      for (Eigen::Index b = 0; b < T.cols(); ++b)
        next.block(a * P.rows(), b * P.cols(), P.rows(), P.cols()) = T(a, b) * P;
    T = next;
  }
  const Eigen::Index n = T.rows();
  for (std::size_t e = 0; e < elements; ++e)
  {
    Eigen::MatrixXd prod = Eigen::MatrixXd::Identity(n, n);
    for (int s = 0; s < N; ++s)
    {
      Eigen::VectorXd d(n);
      for (Eigen::Index x = 0; x < n; ++x)
      {
        // decode x -> (schedule state, link states)
        Eigen::Index rest = x;
        std::vector<Eigen::Index> state(S);
        for (std::size_t j = S; j-- > 0;)
        {
          state[j] = rest % sizes[j];
          rest /= sizes[j];
        }
        const std::vector<bool>& on = schedule.subsets[static_cast<std::size_t>(rest)];
        double p_none = 1.0;
        for (std::size_t j = 0; j < S; ++j)
          if (on[j] && seenAt(block, e, j, s))
            p_none *= links[j].stateLoss()[state[j]];
        d[x] = p_none;
      }
      prod = prod * d.asDiagonal() * T;
    }
    best = std::max(best, std::pow(spectralRadiusSmall(prod), 1.0 / N));
  }
  return best;
}

Schedule restrictSchedule(const Schedule& schedule, const std::vector<int>& set)
{
  Schedule out = schedule;
  auto restrict = [&](std::vector<std::vector<bool>>& masks) {
    for (std::vector<bool>& m : masks)
    {
      std::vector<bool> r;
      for (int i : set)
        r.push_back(m[static_cast<std::size_t>(i)]);
      m = r;
    }
  };
  restrict(out.pattern);
  restrict(out.subsets);
  return out;
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
