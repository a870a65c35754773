#include "estimators/estimator_common.hpp"
#include "networked_estimation/common/index_select.hpp"

#include <cmath>
#include <sstream>

namespace networked_estimation
{
namespace detail
{

ArrivalSelector::ArrivalSelector(const Model& model) : model_(model)
{
  idx_.reserve(model.m());
  ya_.resize(model.m());
}

void ArrivalSelector::checkInput(const Sample& sample) const
{
  if (sample.u.size() != 0 && sample.u.size() != model_.p())
  {
    std::ostringstream os;
    os << "input u: expected " << model_.p() << " values, found " << sample.u.size();
    throw InputError(os.str());
  }
  if (sample.u.size() != 0 && !sample.u.allFinite())
    throw InputError("input u: not finite");
}

int ArrivalSelector::select(const Sample& sample, bool ignore_gamma)
{
  idx_.clear();
  const bool use = sample.gamma || ignore_gamma;
  if (use && sample.y.size() != 0)
  {
    if (sample.y.size() != model_.m())
    {
      std::ostringstream os;
      os << "measurement y: expected " << model_.m() << " values, found " << sample.y.size();
      throw InputError(os.str());
    }
    for (const Sensor& s : model_.sensors)
    {
      int missing = 0;
      for (int i = s.offset; i < s.offset + s.size; ++i)
      {
        const double v = sample.y[i];
        if (std::isnan(v))
          ++missing;
        else if (!std::isfinite(v))
          throw InputError("measurement y of sensor '" + s.name + "': infinite value");
      }
      if (missing == 0)
        for (int i = s.offset; i < s.offset + s.size; ++i)
          idx_.push_back(i);
      else if (missing != s.size)
        throw InputError("measurement y of sensor '" + s.name + "': partly missing (" + std::to_string(missing) +
                         " of " + std::to_string(s.size) + " values)");
    }
  }
  else if (sample.gamma && sample.y.size() == 0)
  {
    throw InputError("measurement y: gamma = 1 but no values given");
  }
  rows_ = static_cast<int>(idx_.size());
  all_ = rows_ == model_.m();
  if (rows_ == 0)
    return 0;
  if (all_)
  {
    ya_ = sample.y;
    return rows_;
  }
  ya_.resize(rows_);
  for (int i = 0; i < rows_; ++i)
    ya_[i] = sample.y[idx_[i]];
  if (idx_ != last_idx_)
  {
    Ca_ = selectRows(model_.C, idx_);
    Ra_ = selectBlock(model_.R, idx_, idx_);
    last_idx_ = idx_;
  }
  return rows_;
}

void KalmanUpdate::factor(const Eigen::MatrixXd& P, const Eigen::MatrixXd& C, const Eigen::MatrixXd& R)
{
  C_ = &C;
  R_ = &R;
  W_.noalias() = C * P;  // C P
  S_ = R;
  S_.noalias() += W_ * C.transpose();
  llt_.compute(S_);
  if (llt_.info() != Eigen::Success)
    throw DivergenceError("covariance diverged: C P C' + R is no longer positive definite (P overflowed or its "
                          "condition number exceeds double precision, trace " + std::to_string(P.trace()) +
                          "); the expected estimation error is unbounded on this link");
  solveLower(llt_, W_);  // W = L^{-1} C P
}

void KalmanUpdate::downdate(Eigen::MatrixXd& P) const
{
  const double prior_trace = P.trace();
  prior_ = P;
  // A plain product (coefficient-based for small sizes, GEMM for large ones) is cheaper than
  // selfadjointView().rankUpdate at the sizes of most filters; mirroring makes P exactly symmetric.
  P.noalias() -= W_.transpose() * W_;
  mirrorLower(P);
  if (P.diagonal().minCoeff() < 0.0 || prior_trace > 1e6 * P.trace())
    joseph(P);
}

void KalmanUpdate::joseph(Eigen::MatrixXd& P) const
{
  ++joseph_;
  const Eigen::Index n = prior_.rows();
  // K' = S^{-1} C P = L^{-T} W
  const Eigen::MatrixXd Kt = llt_.matrixU().solve(W_);
  Eigen::MatrixXd IKC = Eigen::MatrixXd::Identity(n, n);
  IKC.noalias() -= Kt.transpose() * (*C_);
  P.noalias() = IKC * prior_ * IKC.transpose();
  P.noalias() += Kt.transpose() * (*R_) * Kt;
  symmetrise(P);
}

EstimatorBase::EstimatorBase(const Model& model, Algorithm algorithm)
  : model_(model), algorithm_(algorithm), sel_(model_)
{
  BQBt_ = model_.B * model_.Q * model_.B.transpose();
  symmetrise(BQBt_);
  bu_ = Eigen::VectorXd::Zero(model_.n());
  x_ = model_.x0;
  P_ = model_.P0;
  Ppred_.resize(model_.n(), model_.n());
  AP_.resize(model_.n(), model_.n());
}

void EstimatorBase::reset()
{
  x_ = model_.x0;
  P_ = model_.P0;
  steps_ = 0;
  last_updated_ = false;
  diverged_ = false;
}

void EstimatorBase::predictCovariance(const Eigen::MatrixXd& Pin)
{
  AP_.noalias() = model_.A * Pin;
  Ppred_ = BQBt_;
  Ppred_.noalias() += AP_ * model_.A.transpose();
  symmetrise(Ppred_);
}

bool EstimatorBase::commandEffect(const Sample& sample)
{
  if (sample.u.size() == 0 || model_.p() == 0)
  {
    bu_.setZero();
    return false;
  }
  bu_.noalias() = model_.Bu * sample.u;
  return !bu_.isZero(0.0);
}

void EstimatorBase::updateMean(Eigen::VectorXd& x)
{
  innov_ = sel_.y();
  innov_.noalias() -= sel_.C() * x;
  upd_.whiten(innov_);
  x.noalias() += upd_.W().transpose() * innov_;
}

void EstimatorBase::updateAndCommit()
{
  if (last_updated_)
  {
    upd_.factor(Ppred_, sel_.C(), sel_.R());
    updateMean(xpred_);
    upd_.downdate(Ppred_);
  }
  x_.swap(xpred_);
  P_.swap(Ppred_);
}

void EstimatorBase::checkNotDiverged() const
{
  if (diverged_)
    throw DivergenceError(toString(algorithm_) + ": stepped after divergence; reset() the estimator first");
}

void EstimatorBase::checkFinite()
{
  if (!P_.allFinite() || !x_.allFinite())
  {
    diverged_ = true;
    std::ostringstream os;
    os << toString(algorithm_) << ": covariance diverged at step " << steps_
       << " (trace no longer finite: the expected estimation error is unbounded on this link)";
    throw DivergenceError(os.str());
  }
}

}  // namespace detail
}  // namespace networked_estimation
