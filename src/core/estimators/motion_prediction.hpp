// The prediction through a built-in motion (docs/algorithms.md 7.4): xpred = f(x, dt),
// Ppred = F P F' + Q dt, then omni_3d's two_d_mode constraint. One implementation, used by ekfio
// (in its compiled sizes) and by predictAhead (predict_ahead.cpp, dynamic sizes).
#pragma once

#include <cmath>
#include <string>

#include "estimators/estimator_common.hpp"
#include "networked_estimation/common/error.hpp"
#include "networked_estimation/config/model.hpp"
#include "networked_estimation/estimators/estimator.hpp"
#include "networked_estimation/motion/motion.hpp"
#include "networked_estimation/motion/omni_motion.hpp"

namespace networked_estimation
{
namespace detail
{

/// The duration of a step: Sample::dt, or the model's period when it is 0. Throws InputError for a
/// dt that is negative or not finite.
inline double stepDuration(const Sample& sample, const Model& model)
{
  if (!(sample.dt >= 0.0) || !std::isfinite(sample.dt))
    throw InputError("dt: expected a finite step duration >= 0 s (0: the model's period), found " +
                     std::to_string(sample.dt));
  return sample.dt > 0.0 ? sample.dt : model.period;
}

template <class VecN, class MatN>
class MotionPrediction
{
public:
  explicit MotionPrediction(const Model& model) : motion_(model.motion), two_d_(model.two_d_mode)
  {
    if (motion_ != Motion::LINEAR)
      Q_ = model.Q;
  }

  /// xp = f(x, dt), F = df/dx, Pp = F P F' + Q dt (FP: workspace), constrained. For a motion model.
  void predict(const VecN& x, const MatN& P, double dt, VecN& xp, MatN& Pp, MatN& F, MatN& FP) const
  {
    const Eigen::Index n = x.size();
    xp.resize(n);
    F.resize(n, n);
    if (motion_ == Motion::OMNI_2D)
      omni::omni2dStep(x, dt, xp, &F);
    else
      omni::omni3dStep(x, dt, xp, &F);
    FP.noalias() = F * P;
    Pp = dt * Q_;
    Pp.noalias() += FP * F.transpose();
    symmetrise(Pp);
    constrain(xp, Pp);
  }

  /// two_d_mode (omni_3d): z, roll, pitch and their rates and az held at 0 with zero variance (the
  /// rows and columns of P zero); no-op otherwise.
  void constrain(VecN& x, MatN& P) const
  {
    if (!two_d_)
      return;
    for (const int i : planarConstrained())
    {
      x[i] = 0.0;
      P.row(i).setZero();
      P.col(i).setZero();
    }
  }

private:
  Motion motion_;
  bool two_d_;
  MatN Q_;  ///< per second
};

}  // namespace detail
}  // namespace networked_estimation
