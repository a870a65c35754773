// RSEIO, docs/algorithms.md 4.4 (Theorem 1, corrected, Gram form) and 4.6 (known input).
#include "estimators/rseio_estimator.hpp"
#include "estimators/estimator_common.hpp"
#include "networked_estimation/common/index_select.hpp"

#include <algorithm>
#include <cmath>
#include <map>
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
  const Eigen::MatrixXd info = pred.inverse() + Ctil.transpose() * Rtil.llt().solve(Ctil);
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
    throw ConfigError(model.name +
                      ": rseio analysis form: Acheck = A - lambda B Qcheck T'S is singular "
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
namespace
{

/// Gram blocks of the sensitivity matrices for one set of received rows (cached: the model is LTI),
/// in the types of the sizes S. The factors Fs, Fx, Fw have a data-dependent number of rows (a rank,
/// at most n): with fixed sizes they are padded to n rows with zero rows, which contribute exact
/// zeros everywhere (a zero row of the "C" of a Kalman update with a positive "R" changes nothing,
/// and in N = I + lam (...) it adds a unit row and column: KalmanUpdate, rankPrediction).
template <class S>
struct RseioGrams
{
  static constexpr int N = S::N, NW = S::NW;
  /// Fixed sizes: rank rows padded to N; dynamic: exactly the rank.
  static constexpr int RHO = S::kFixed ? S::N : kDynamic;
  Mat<N, N> Sss;          ///< S'S
  Mat<N, NW> Sst;         ///< S'T
  Mat<NW, NW> Stt;        ///< T'T
  Mat<RHO, N> Fs;         ///< Fs'Fs = Sss, rank(Sss) rows: Phat is a low-rank downdate of P
  Mat<N, kDynamic> SBu;   ///< S'Sc Bu: the known-input correction (docs/algorithms.md 4.6)
  Mat<NW, kDynamic> TBu;  ///< T'Sc Bu
  bool hasS = false, hasT = false, hasC = false;
  int rho = 0;  ///< rank form: the rows of Fx, Fw before the padding
  // Rank form: [Fx Fw]'[Fx Fw] = [S T]'[S T] with rho = rank rows (see rankPrediction); only held
  // when rho <= n.
  bool rankForm = false;
  Mat<RHO, N> Fx;        ///< rho x n
  Mat<RHO, NW> Fw;       ///< rho x nw
  Mat<RHO, N> FwQBt;     ///< Fw Q B' (rho x n)
  Mat<RHO, RHO> FwQFwt;  ///< Fw Q Fw' (rho x rho)

  /// The blocks computed in dynamic types (makeGrams), padded for fixed sizes.
  static RseioGrams sized(const RseioGrams<DynamicSizes>& d)
  {
    RseioGrams g;
    g.Sss = d.Sss;
    g.Sst = d.Sst;
    g.Stt = d.Stt;
    g.SBu = d.SBu;
    g.TBu = d.TBu;
    g.hasS = d.hasS;
    g.hasT = d.hasT;
    g.hasC = d.hasC;
    g.rankForm = d.rankForm;
    g.rho = d.rho;
    pad(g.Fs, d.Fs);
    pad(g.Fx, d.Fx);
    pad(g.Fw, d.Fw);
    pad(g.FwQBt, d.FwQBt);
    pad(g.FwQFwt, d.FwQFwt);
    return g;
  }

private:
  /// to <- from in the top-left corner, zero elsewhere.
  template <class To>
  static void pad(To& to, const Eigen::MatrixXd& from)
  {
    if constexpr (S::kFixed)
    {
      to.setZero();
      to.topLeftCorner(from.rows(), from.cols()) = from;
    }
    else
    {
      to = from;
    }
  }
};

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

template <class S>
class RseioFilter final : public EstimatorBase<S, RseioFilter<S>>, public Rseio
{
  using Base = EstimatorBase<S, RseioFilter<S>>;
  friend Base;
  using Base::A_;
  using Base::AP_;
  using Base::BQBt_;
  using Base::bu_;
  using Base::last_updated_;
  using Base::model_;
  using Base::P_;
  using Base::Ppred_;
  using Base::rows_;
  using Base::sel_;
  using Base::x_;
  using Base::xpred_;
  static constexpr int N = S::N, NW = S::NW;
  using Grams = RseioGrams<S>;

public:
  RseioFilter(const Model& model, double mu) : Base(model, Algorithm::RSEIO), lambda_(rseioLambda(mu))
  {
    Eigen::MatrixXd qinv = model_.Q.llt().solve(Eigen::MatrixXd::Identity(model_.nw(), model_.nw()));
    symmetrise(qinv);
    Qinv_ = qinv;
    B_ = model_.B;
    Q_ = model_.Q;
    all_ = Grams::sized(makeGrams(model_, {}));
  }
  std::unique_ptr<Estimator> clone() const override { return std::make_unique<RseioFilter>(*this); }
  const char* lastForm() const override { return last_form_; }
  /// P depends on which sensors arrived only. (The step still forms the prediction of the mean from x_,
  /// which stays at x0 in this mode: nothing accumulates.)
  bool setCovarianceOnly(bool on) override
  {
    this->covariance_only_ = on;
    return true;
  }

private:
  // EstimatorBase's halves of a step. The robust prediction depends on which rows arrived.
  static constexpr bool kPredictionReadsArrivals = true;
  void predictStep(const Sample& sample)
  {
    const bool has_input = this->commandEffect(sample);
    const Grams* g = rows_ > 0 && lambda_ > 0.0 ? &grams() : nullptr;
    form_ = nullptr;
    if (g && (g->hasS || g->hasT))
    {
      if (g->rankForm)
        rankPrediction(*g, has_input, sample.u);
      else
        arrivalPrediction(*g, has_input, sample.u);
      form_ = g->rankForm ? "rank" : "gram";
    }
    else
    {
      // dropped (or nothing uncertain, or mu = 1): the nominal prediction, exactly kfio's
      xpred_.noalias() = A_ * x_;
      if (has_input)
        xpred_ += bu_;
      this->predictCovariance(P_);
    }
  }
  void updateStep()
  {
    last_updated_ = rows_ > 0;
    if (form_)
      last_form_ = form_;
    this->updateAndCommit();
  }

private:
  const Grams& grams() { return sel_.all() ? all_ : partialGrams(); }

  /// The Gram blocks of the arrived rows when some sensors are missing (computed once per set).
  const Grams& partialGrams()
  {
    auto it = partial_.find(sel_.arrivedRows());
    if (it == partial_.end())
      it = partial_.emplace(sel_.arrivedRows(), Grams::sized(makeGrams(model_, sel_.arrivedRows()))).first;
    return it->second;
  }

  /// Theorem 1 in Gram form (docs/algorithms.md 4.4): Phat, Qhat, Bhat, Ahat. Used when rho > n.
  void arrivalPrediction(const Grams& g, bool has_input, const Eigen::VectorXd& u)
  {
    const auto& A = A_;
    const double lam = lambda_;
    // 1. Phat = (P^{-1} + lam Sss)^{-1}: a Kalman update of P with "C" = Fs and "R" = I / lam
    //    (Fs'Fs = Sss), so it shares the Cholesky form and the cancellation guard of the update.
    Phat_ = P_;
    if (g.hasS)
    {
      RinvLam_.setIdentity(g.Fs.rows(), g.Fs.rows());
      RinvLam_ /= lam;
      phat_upd_.factor(P_, g.Fs, RinvLam_);
      phat_upd_.downdate(Phat_);
    }
    // (I - lam Phat Sss) x
    gx_ = x_;
    if (g.hasS)
    {
      tmp_.noalias() = g.Sss * x_;
      gx_.noalias() -= lam * (Phat_ * tmp_);
    }
    // 5. Ppred = A Phat A' + Bhat Qhat Bhat'; 4. xpred = F gx with F = A - lam Bhat Qhat Sst'.
    // Qhat is never formed: with Qhat^{-1} = L L', Bhat Qhat Bhat' = Z'Z and Bhat Qhat v = Z' L^{-1} v
    // where Z = L^{-1} Bhat'.
    AP_.noalias() = A * Phat_;
    xpred_.noalias() = A * gx_;
    if (g.hasT)
    {
      // 2. Qhat^{-1} = Q^{-1} + lam Stt - lam^2 Sst' Phat Sst
      PhSst_.noalias() = Phat_ * g.Sst;
      Qi_ = Qinv_;
      Qi_ += lam * g.Stt;
      Qi_.noalias() -= (lam * lam) * (g.Sst.transpose() * PhSst_);
      lltq_.compute(Qi_);  // reads the lower triangle only (positive definite: Qhat^{-1} of (2))
      // 3. Bhat = B - lam A Phat Sst
      Bhat_ = B_;
      Bhat_.noalias() -= lam * (AP_ * g.Sst);
      Zt_ = Bhat_.transpose();
      lltq_.solveLower(Zt_);  // Z = L^{-1} Bhat'
      tw_.noalias() = g.Sst.transpose() * gx_;
      lltq_.solveLower(tw_);
      xpred_.noalias() -= lam * (Zt_.transpose() * tw_);
      Ppred_.noalias() = AP_ * A.transpose();
      Ppred_.noalias() += Zt_.transpose() * Zt_;
      mirrorLower(Ppred_);
    }
    else
    {
      Ppred_ = BQBt_;
      Ppred_.noalias() += AP_ * A.transpose();
      symmetrise(Ppred_);
    }
    if (has_input)
    {
      xpred_ += bu_;
      if (g.hasC)
      {
        // - lam (F Phat S'c + Bhat Qhat T'c), S'c = SBu u, T'c = TBu u
        applyInput(tmp_, g.SBu, u);
        gx_.noalias() = Phat_ * tmp_;  // Phat S'c
        xpred_.noalias() -= lam * (A * gx_);
        if (g.hasT)
        {
          // -lam (F Phat S'c + Bhat Qhat T'c) = -lam A Phat S'c + lam Bhat Qhat (lam Sst' Phat S'c - T'c)
          applyInput(tw_, g.TBu, u);
          tw_ = lam * (g.Sst.transpose() * gx_) - tw_;
          lltq_.solveLower(tw_);
          xpred_.noalias() += lam * (Zt_.transpose() * tw_);
        }
      }
    }
  }

  // With D = blkdiag(P^{-1}, Q^{-1}) and F = [Fx Fw] (F'F = [S T]'[S T]), the prior part of the cost
  // (2) has Hessian M = D + lam F'F, so by Woodbury
  //   Ppred = [A B] M^{-1} [A B]' = A P A' + B Q B' - lam H' N^{-1} H,
  //   H = Fx P A' + Fw Q B',  N = I + lam (Fx P Fx' + Fw Q Fw'),
  //   xpred = [A B] M^{-1} (D [x; 0] - lam [S T]'c) + Bu u
  //         = A x - lam H' N^{-1} Fx x + Bu u - lam ([A B] D^{-1} g - lam H' N^{-1} F D^{-1} g),
  // where g = [S T]'c = [SBu; TBu] u is the known-input term of docs/algorithms.md 4.6. Equal to Theorem 1
  // (checked against the brute-force minimiser in the tests) at O(n^2 rho + rho^2 n) on top of kfio.
  void rankPrediction(const Grams& g, bool has_input, const Eigen::VectorXd& u)
  {
    const auto& A = A_;
    const double lam = lambda_;
    AP_.noalias() = A * P_;
    FP_.noalias() = g.Fx * P_;  // Fx P
    Hm_ = g.FwQBt;
    Hm_.noalias() += FP_ * A.transpose();  // H
    Nm_ = g.FwQFwt;
    Nm_.noalias() += FP_ * g.Fx.transpose();
    Nm_ *= lam;
    Nm_.diagonal().array() += 1.0;  // N
    lltn_.compute(Nm_, g.rho);      // N >= I; its padding rows (fixed sizes) are unit rows
    lltn_.solveLower(Hm_);          // V = L^{-1} H
    Ppred_ = BQBt_;
    Ppred_.noalias() += AP_ * A.transpose();
    Ppred_.noalias() -= lam * (Hm_.transpose() * Hm_);
    mirrorLower(Ppred_);
    // both H' N^{-1} terms of xpred in one solve: t = Fx x - lam F D^{-1} g
    t_.noalias() = g.Fx * x_;
    xpred_.noalias() = A * x_;
    if (has_input)
    {
      xpred_ += bu_;
      if (g.hasC)
      {
        applyInput(g1_, g.SBu, u);
        applyInput(g2_, g.TBu, u);
        tmp_.noalias() = P_ * g1_;  // D^{-1} g, state part
        tw_.noalias() = Q_ * g2_;   // D^{-1} g, noise part
        xpred_.noalias() -= lam * (AP_ * g1_);
        xpred_.noalias() -= lam * (B_ * tw_);
        t_.noalias() -= lam * (g.Fx * tmp_);
        t_.noalias() -= lam * (g.Fw * tw_);
      }
    }
    lltn_.solveLower(t_);
    xpred_.noalias() -= lam * (Hm_.transpose() * t_);
    // cancellation guard, as in the measurement update: the Gram form keeps P positive where the
    // subtraction would not
    if (Ppred_.diagonal().minCoeff() < 0.0)
      arrivalPrediction(g, has_input, u);
  }

  const char* last_form_ = "";
  const char* form_ = nullptr;  ///< the form of the pending prediction (nullptr: the nominal one)
  double lambda_;
  Mat<N, NW> B_;
  Mat<NW, NW> Q_, Qinv_;
  Grams all_;
  std::map<std::vector<int>, Grams> partial_;
  // workspace
  static constexpr int RHO = Grams::RHO;
  Mat<RHO, N> FP_, Hm_;
  Mat<RHO, RHO> Nm_, RinvLam_;
  Mat<RHO, 1> t_;
  typename S::VecN g1_, gx_, tmp_;
  Mat<NW, 1> g2_, tw_;
  KalmanUpdate<N, RHO> phat_upd_;
  typename S::MatN Phat_;
  Mat<N, NW> PhSst_, Bhat_;
  Mat<NW, NW> Qi_;
  Mat<NW, N> Zt_;
  Cholesky<Mat<RHO, RHO>> lltn_;  ///< of N (rank form)
  Cholesky<Mat<NW, NW>> lltq_;    ///< of Qhat^{-1} (Gram form)
};

}  // namespace

std::unique_ptr<Estimator> makeRseio(const Model& model, double mu, SizeChoice choice)
{
  return makeSized<RseioFilter, Estimator>(RseioSizes(), choice, true, model, mu);
}

}  // namespace detail
}  // namespace networked_estimation
