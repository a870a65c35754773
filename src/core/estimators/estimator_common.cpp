#include "estimators/estimator_common.hpp"

#include <cmath>
#include <sstream>

namespace networked_estimation
{
namespace detail
{

void throwDiverged(Algorithm algorithm, long step)
{
  std::ostringstream os;
  os << toString(algorithm) << ": covariance diverged at step " << step
     << " (trace no longer finite: the expected estimation error is unbounded on this link)";
  throw DivergenceError(os.str());
}

void throwSteppedAfterDivergence(Algorithm algorithm)
{
  throw DivergenceError(toString(algorithm) + ": stepped after divergence; reset() the estimator first");
}

void throwNotPositiveDefinite(double trace)
{
  throw DivergenceError(
      "covariance diverged: C P C' + R is no longer positive definite (P overflowed or its "
      "condition number exceeds double precision, trace " +
      std::to_string(trace) + "); the expected estimation error is unbounded on this link");
}

namespace
{

[[noreturn]] void throwSize(const char* what, int expected, Eigen::Index found)
{
  std::ostringstream os;
  os << what << ": expected " << expected << " values, found " << found;
  throw InputError(os.str());
}

}  // namespace

ArrivalSelector::ArrivalSelector(const Model& model) : sensors_(model.sensors), m_(model.m()), p_(model.p())
{
  idx_.reserve(model.m());
}

void ArrivalSelector::rejectInput(const Sample& sample) const
{
  if (sample.u.size() != p_)
    throwSize("input u", p_, sample.u.size());
  throw InputError("input u: not finite");
}

int ArrivalSelector::selectSome(const Sample& sample, bool ignore_gamma)
{
  const bool use = sample.gamma || ignore_gamma;
  if (use && sample.y.size() != 0 && sample.y.size() != m_)
    throwSize("measurement y", m_, sample.y.size());
  if (sample.gamma && sample.y.size() == 0)
    throw InputError("measurement y: gamma = 1 but no values given");
  idx_.clear();
  if (use && sample.y.size() != 0)
  {
    for (const Sensor& s : sensors_)
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
  rows_ = static_cast<int>(idx_.size());
  all_ = rows_ == m_;
  changed_ = false;
  if (rows_ > 0 && !all_ && idx_ != last_idx_)
  {
    changed_ = true;
    last_idx_ = idx_;
  }
  return rows_;
}

}  // namespace detail
}  // namespace networked_estimation

namespace networked_estimation
{

void Prior::begin(const Model& model, const Eigen::MatrixXd* step_R)
{
  model_ = &model;
  own_R_ = step_R != nullptr;
  if (own_R_)
    R_ = *step_R;
  const std::size_t sensors = model.sensors.size();
  S_.resize(sensors);
  have_S_.assign(sensors, 0);
}

const Eigen::MatrixXd& Prior::innovationCovariance(std::size_t sensor) const
{
  if (sensor >= S_.size())
    throw InputError("prior: sensor " + std::to_string(sensor) + ": expected an index below " +
                     std::to_string(S_.size()) + " (the model's sensors)");
  Eigen::MatrixXd& S = S_[sensor];
  if (!have_S_[sensor])
  {
    const Sensor& sn = model_->sensors[sensor];
    const auto C = model_->C.middleRows(sn.offset, sn.size);
    const Eigen::MatrixXd& R = own_R_ ? R_ : model_->R;
    S = R.block(sn.offset, sn.offset, sn.size, sn.size);
    S.noalias() += C * P_ * C.transpose();
    have_S_[sensor] = 1;
  }
  return S;
}

}  // namespace networked_estimation
