// Loss processes of the links (link_model.hpp; docs/stability.md 1.2).
#include "networked_estimation/stability/link_model.hpp"

#include <cmath>
#include <limits>

#include "networked_estimation/link/channel_trace.hpp"
#include "stability_internal.hpp"

namespace networked_estimation
{

using stability_internal::spectralRadiusSmall;

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
  if (s.model == LossModelKind::TRACE && s.replay)  // the loss model fitted to the trace (fit_link's)
    return fromSettings(s.replay->fitted);
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

}  // namespace networked_estimation
