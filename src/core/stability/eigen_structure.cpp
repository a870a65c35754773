// Eigen-structure helpers and FMO blocks (eigen_structure.hpp; docs/stability.md 1.3).
#include "networked_estimation/stability/eigen_structure.hpp"
#include "networked_estimation/common/angles.hpp"
#include "networked_estimation/common/index_select.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <sstream>

namespace networked_estimation
{

namespace
{

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
    if (c.multiplicity == 1)
      continue;  // a simple eigenvalue has one eigenvector: no rank to check
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
  // A real matrix: its singular values in real arithmetic (a quarter of the complex SVD's work).
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(O);
  const Eigen::VectorXd sv = svd.singularValues();
  const double thr = rel_tol * (sv.size() ? sv[0] : 0.0);  // numericalRank's, with scale 0
  int r = 0;
  for (int i = 0; i < sv.size(); ++i)
    r += sv[i] > thr ? 1 : 0;
  return r == n;
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
  const EigenDecomposition es = eigenDecomposition(A);
  const Eigen::VectorXcd& ev = es.values;
  const Eigen::MatrixXcd Ct = C.cast<std::complex<double>>() * es.vectors;
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
      os << "(A, C) is not strongly observable: the " << group.size() << " eigenvalue(s) of modulus " << std::abs(ev[i])
         << " give C V a column rank of " << rank;
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

}  // namespace networked_estimation
