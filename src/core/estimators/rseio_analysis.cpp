// The model-level parts of RSEIO (docs/algorithms.md 4.3, 4.4, 4.9): lambda, the sensitivity
// matrices, their Gram blocks for the filter (makeGrams, in dynamic types: computed once per set of
// received rows, whatever sizes the filter is compiled for) and the Theorem 2 analysis form.
#include "estimators/rseio_impl.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace networked_estimation
{

double rseioLambda(double mu)
{
  if (!(mu > 0.0 && mu <= 1.0))
  {
    std::ostringstream os;
    os << "mu: expected a value in (0, 1], found " << mu;
    throw ConfigError(os.str());
  }
  return (1.0 - mu) / mu;
}

RseioSensitivity rseioSensitivity(const Model& model, const std::vector<int>& rows)
{
  std::vector<int> idx = rows;
  if (idx.empty())
    for (int i = 0; i < model.m(); ++i)
      idx.push_back(i);
  const int ma = static_cast<int>(idx.size());
  const int ne = model.ne();
  const Eigen::MatrixXd C = selectRows(model.C, idx);
  RseioSensitivity s;
  s.S.setZero(2 * ne * ma, model.n());
  s.T.setZero(2 * ne * ma, model.nw());
  s.Sc.setZero(2 * ne * ma, model.n());
  for (int k = 0; k < ne; ++k)
  {
    const Uncertainty& e = model.uncertainty[k];
    const Eigen::MatrixXd dC = selectRows(e.dC, idx);
    const int r0 = 2 * k * ma;
    s.S.middleRows(r0, ma) = C * e.dA;
    s.S.middleRows(r0 + ma, ma) = dC * model.A;
    s.T.middleRows(r0, ma) = C * e.dB;
    s.T.middleRows(r0 + ma, ma) = dC * model.B;
    s.Sc.middleRows(r0 + ma, ma) = dC;
  }
  return s;
}

Eigen::MatrixXd RseioAnalysisForm::arrivalCovariance(const Eigen::MatrixXd& P, const Eigen::MatrixXd& B) const
{
  const Eigen::MatrixXd pred = Atil * P * Atil.transpose() + B * Qtil * B.transpose();
  const Eigen::MatrixXd info =
      pred.inverse() + Ctil.transpose() * Rtil.llt().solve(Ctil);
  Eigen::MatrixXd out = info.inverse();
  return 0.5 * (out + out.transpose());
}

RseioAnalysisForm rseioAnalysisForm(const Model& model, double mu)
{
  const double lam = rseioLambda(mu);
  const RseioSensitivity s = rseioSensitivity(model);
  const Eigen::MatrixXd& A = model.A;
  const Eigen::MatrixXd& B = model.B;
  const int r = static_cast<int>(s.S.rows());
  RseioAnalysisForm f;
  f.Qcheck = (model.Q.inverse() + lam * s.T.transpose() * s.T).inverse();
  f.Acheck = A - lam * B * f.Qcheck * s.T.transpose() * s.S;
  Eigen::FullPivLU<Eigen::MatrixXd> lu(f.Acheck);
  if (!lu.isInvertible())
    throw ConfigError(model.name + ": rseio analysis form: Acheck = A - lambda B Qcheck T'S is singular "
                                   "(Theorem 2 needs it invertible)");
  const Eigen::MatrixXd AcheckInv = lu.inverse();
  const Eigen::MatrixXd M = Eigen::MatrixXd::Identity(r, r) + lam * s.T * model.Q * s.T.transpose();
  f.Stil = std::sqrt(lam) * M.llt().matrixL().solve(s.S);
  const Eigen::MatrixXd Btil = AcheckInv * B;
  const Eigen::MatrixXd StS = f.Stil.transpose() * f.Stil;
  f.Atil = f.Acheck + B * f.Qcheck * Btil.transpose() * StS;
  f.Qtil = f.Qcheck + f.Qcheck * Btil.transpose() * StS * Btil * f.Qcheck;
  f.Ctil.resize(r + model.m(), model.n());
  f.Ctil << f.Stil * AcheckInv, model.C;
  f.Rtil.setZero(r + model.m(), r + model.m());
  f.Rtil.topLeftCorner(r, r) =
      Eigen::MatrixXd::Identity(r, r) + f.Stil * Btil * f.Qcheck * Btil.transpose() * f.Stil.transpose();
  f.Rtil.bottomRightCorner(model.m(), model.m()) = model.R;
  return f;
}

namespace detail
{

/// The Gram blocks, computed once per set of rows in dynamic types.
RseioGrams<DynamicSizes> makeGrams(const Model& model, const std::vector<int>& rows)
{
  const RseioSensitivity s = rseioSensitivity(model, rows);
  RseioGrams<DynamicSizes> g;
  g.Sss = s.S.transpose() * s.S;
  g.Sst = s.S.transpose() * s.T;
  g.Stt = s.T.transpose() * s.T;
  symmetrise(g.Sss);
  symmetrise(g.Stt);
  g.hasS = !g.Sss.isZero(0.0);
  g.hasT = !s.T.isZero(0.0);
  // Fs = diag(sqrt(ev)) V' over the numerically non-zero eigenvalues of Sss.
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(g.Sss);
  const Eigen::VectorXd ev = es.eigenvalues();
  const double tol = 1e-14 * std::max(1.0, ev.cwiseAbs().maxCoeff()) * model.n();
  int rank = 0;
  for (int i = 0; i < ev.size(); ++i)
    rank += ev[i] > tol ? 1 : 0;
  g.Fs.resize(rank, model.n());
  for (int i = 0, j = 0; i < ev.size(); ++i)
    if (ev[i] > tol)
      g.Fs.row(j++) = std::sqrt(ev[i]) * es.eigenvectors().col(i).transpose();
  // Rank form: factor the joint Gram [S T]'[S T] = F'F (F = diag(sqrt(ev)) V' over the non-zero
  // eigenvalues); worth it when its rank rho does not exceed n.
  {
    const int n = model.n(), nw = model.nw();
    Eigen::MatrixXd G(s.S.rows(), n + nw);
    G << s.S, s.T;
    Eigen::MatrixXd GtG = G.transpose() * G;
    symmetrise(GtG);
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eg(GtG);
    const Eigen::VectorXd gv = eg.eigenvalues();
    const double gtol = 1e-14 * std::max(1.0, gv.cwiseAbs().maxCoeff()) * (n + nw);
    int rho = 0;
    for (int i = 0; i < gv.size(); ++i)
      rho += gv[i] > gtol ? 1 : 0;
    g.rankForm = rho <= n;
    g.rho = rho;
    g.Fx.resize(0, n);
    g.Fw.resize(0, nw);
    g.FwQBt.resize(0, n);
    g.FwQFwt.resize(0, 0);
    if (g.rankForm)
    {
      Eigen::MatrixXd F(rho, n + nw);
      for (int i = 0, j = 0; i < gv.size(); ++i)
        if (gv[i] > gtol)
          F.row(j++) = std::sqrt(gv[i]) * eg.eigenvectors().col(i).transpose();
      g.Fx = F.leftCols(n);
      g.Fw = F.rightCols(nw);
      g.FwQBt = g.Fw * model.Q * model.B.transpose();
      g.FwQFwt = g.Fw * model.Q * g.Fw.transpose();
    }
  }
  g.SBu.resize(model.n(), 0);
  g.TBu.resize(model.nw(), 0);
  if (model.p() > 0)
  {
    const Eigen::MatrixXd ScBu = s.Sc * model.Bu;
    g.hasC = !ScBu.isZero(0.0);
    g.SBu = s.S.transpose() * ScBu;
    g.TBu = s.T.transpose() * ScBu;
  }
  return g;
}

}  // namespace detail
}  // namespace networked_estimation
