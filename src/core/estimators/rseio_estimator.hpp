#pragma once

#include <map>

#include "estimators/estimator_common.hpp"
#include "networked_estimation/estimators/rseio.hpp"

namespace networked_estimation
{
namespace detail
{

/// Gram blocks of the sensitivity matrices for one set of received rows (cached: the model is LTI).
struct RseioGrams
{
  Eigen::MatrixXd Sss, Sst, Stt;  ///< S'S, S'T, T'T
  Eigen::MatrixXd Fs;             ///< Fs'Fs = Sss, rank(Sss) rows: Phat is a low-rank downdate of P
  Eigen::MatrixXd SBu, TBu;       ///< S'Sc Bu, T'Sc Bu: the known-input correction (docs/algorithms.md 4.6)
  bool hasS = false, hasT = false, hasC = false;
  // Rank form: [Fx Fw]'[Fx Fw] = [S T]'[S T] with rho = rank rows (see Rseio::rankPrediction).
  bool rankForm = false;
  Eigen::MatrixXd Fx, Fw;          ///< rho x n, rho x nw
  Eigen::MatrixXd FwQBt, FwQFwt;   ///< Fw Q B' (rho x n), Fw Q Fw' (rho x rho)
};

class Rseio : public EstimatorBase
{
public:
  Rseio(const Model& model, double mu);
  void step(const Sample& sample) override;
  std::unique_ptr<Estimator> clone() const override { return std::make_unique<Rseio>(*this); }

private:
  const RseioGrams& grams();
  /// Theorem 1 in Gram form (docs/algorithms.md 4.4): Phat, Qhat, Bhat, Ahat. Used when rho > n.
  void arrivalPrediction(const RseioGrams& g, bool has_input, const Eigen::VectorXd& u);
  /// The same prediction as a rank-rho downdate of the nominal one (used when rho <= n).
  void rankPrediction(const RseioGrams& g, bool has_input, const Eigen::VectorXd& u);

public:
  /// Which form the last arrival step used ("rank" or "gram"); for tests.
  const char* lastForm() const { return last_form_; }

private:
  const char* last_form_ = "";
  Eigen::MatrixXd FP_, Hm_, Nm_, PQg_;
  Eigen::VectorXd t_, g1_, g2_;

  double lambda_;
  Eigen::MatrixXd Qinv_;
  RseioGrams all_;
  std::map<std::vector<int>, RseioGrams> partial_;
  // workspace
  KalmanUpdate phat_upd_;
  Eigen::MatrixXd RinvLam_, Phat_, PhSst_, Qi_, Bhat_, Zt_;
  Eigen::VectorXd gx_, tmp_, tw_;
  Eigen::LLT<Eigen::MatrixXd> llt_;
};

}  // namespace detail
}  // namespace networked_estimation
