#pragma once

#include <map>

#include "estimator_common.hpp"
#include "networked_estimation/rseio.hpp"

namespace networked_estimation
{
namespace detail
{

/// Gram blocks of the sensitivity matrices for one set of received rows (cached: the model is LTI).
struct RseioGrams
{
  Eigen::MatrixXd Sss, Sst, Stt;  ///< S'S, S'T, T'T
  Eigen::MatrixXd Fs;             ///< Fs'Fs = Sss, rank(Sss) rows: Phat is a low-rank downdate of P
  Eigen::MatrixXd SBu, TBu;       ///< S'Sc Bu, T'Sc Bu: the known-input correction (section 2.5b)
  bool hasS = false, hasT = false, hasC = false;
};

class Rseio : public EstimatorBase
{
public:
  Rseio(const Model& model, double mu);
  void step(const Sample& sample) override;

private:
  const RseioGrams& grams();
  void arrivalPrediction(const RseioGrams& g, bool has_input, const Eigen::VectorXd& u);

  double lambda_;
  Eigen::MatrixXd Qinv_;
  RseioGrams all_;
  std::map<std::vector<int>, RseioGrams> partial_;
  // workspace
  KalmanUpdate phat_upd_;
  Eigen::MatrixXd RinvLam_, Phat_, PhSst_, Qi_, Qhat_, Bhat_, BhQh_;
  Eigen::VectorXd gx_, tmp_, tw_;
  Eigen::LLT<Eigen::MatrixXd> llt_;
};

}  // namespace detail
}  // namespace networked_estimation
