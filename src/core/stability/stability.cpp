// Stability analysis, part 3: the top-level report (analyzeStability).
#include "networked_estimation/stability/stability.hpp"

#include <future>

#include <cmath>
#include <sstream>

namespace networked_estimation
{

namespace
{

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string num(double v)
{
  std::ostringstream os;
  os.precision(6);
  os << v;
  return os.str();
}

/// Whitened sensor matrices H_i = L_i^{-1} C_i with R_i = L_i L_i'.
std::vector<Eigen::MatrixXd> whitenedSensors(const Model& model)
{
  std::vector<Eigen::MatrixXd> H;
  for (const Sensor& s : model.sensors)
  {
    const Eigen::MatrixXd Ri = model.R.block(s.offset, s.offset, s.size, s.size);
    const Eigen::MatrixXd Ci = model.C.middleRows(s.offset, s.size);
    H.push_back(Eigen::LLT<Eigen::MatrixXd>(Ri).matrixL().solve(Ci));
  }
  return H;
}

struct Context
{
  const Model* model = nullptr;
  Eigen::MatrixXd Qn;                  ///< B Q B'
  std::vector<Eigen::MatrixXd> H;      ///< whitened, all sensors
  double rho = 0.0;
  bool excited = true;                 ///< unstable modes controllable from the noise
  bool has_channel = false;
  LinkModel link;
  const AnalysisOptions* options = nullptr;
};

RateAnalysis analyseSet(const Context& ctx, const std::vector<int>& set, const std::string& name)
{
  const Model& model = *ctx.model;
  const AnalysisOptions& opt = *ctx.options;
  RateAnalysis ra;
  ra.name = name;
  ra.sensors = set;
  const int N = static_cast<int>(set.size());
  std::vector<Eigen::MatrixXd> H;
  int rows = 0;
  for (int i : set)
  {
    H.push_back(ctx.H[i]);
    rows += static_cast<int>(ctx.H[i].rows());
  }
  Eigen::MatrixXd Hs(rows, model.n());
  {
    int r0 = 0;
    for (const auto& h : H)
    {
      Hs.middleRows(r0, h.rows()) = h;
      r0 += static_cast<int>(h.rows());
    }
  }
  const bool stable_A = ctx.rho < 1.0;
  const bool detectable = modesObservable(model.A, Hs, 1.0, 1e-9);

  ra.lower_bound = sinopoliLowerBound(ctx.rho, N);
  ra.recovery_lower_bound = ra.lower_bound;  // rho^2 (1 - r)^N >= 1: all sensors lost (same formula)
  ra.blocks = analyseBlocks(model.A, H, opt.tol);
  ra.exact_rate = exactCriticalArrivalRate(ra.blocks);
  if (stable_A)
    ra.exact_method = "A is stable: bounded at every rate";
  else if (std::isnan(ra.exact_rate))
  {
    for (const BlockStructure& b : ra.blocks)
      if (b.method == BlockStructure::Method::UNAVAILABLE)
        ra.exact_method = "unavailable: " + b.reason;
  }
  else if (std::isinf(ra.exact_rate))
    ra.exact_method = "an eigenvalue with |lambda| >= 1 is seen by no sensor of the set: unbounded at every rate";
  else
  {
    ra.exact_method = "Theorem 14 of Marelli et al.:";
    for (const BlockStructure& b : ra.blocks)
      ra.exact_method += " " + b.reason + ";";
    ra.exact_method.pop_back();
  }
  const EntropySplit split = entropySplit(model.A, H);
  ra.closed_form_upper = stable_A ? 0.0 : split.common_rate;

  if (stable_A)
  {
    ra.mare.converges_at = 0.0;
  }
  else if (detectable && ctx.excited)
  {
    ra.mare = mareCriticalRate(model.A, ctx.Qn, H, ra.lower_bound, 1.0, opt.bisection_tolerance, opt.mare);
  }

  const double p_markov = ctx.has_channel && ctx.link.kind == LinkModel::Kind::GILBERT_ELLIOTT ? ctx.link.p : 0.5;
  ra.recovery_exact = stable_A ? 0.0 : exactCriticalRecoveryRate(ra.blocks, p_markov);

  // Lin et al.'s Theorem 5: one packet carrying the whole measurement of the set.
  if (!ctx.has_channel)
  {
    ra.aoe_theorem5.kind = Verdict::Kind::NOT_APPLICABLE;
    ra.aoe_theorem5.reason = "no channel given";
    ra.aoe_theorem5.numbers["p_t"] = aoeRecoveryThreshold(ctx.rho);
  }
  else if (N != 1)
  {
    ra.aoe_theorem5.kind = Verdict::Kind::NOT_APPLICABLE;
    ra.aoe_theorem5.reason =
        std::to_string(N) + " sensors on independent links; Lin et al.'s Theorem 5 covers one packet";
    ra.aoe_theorem5.numbers["p_t"] = aoeRecoveryThreshold(ctx.rho);
  }
  else if (ctx.link.kind == LinkModel::Kind::GILBERT_ELLIOTT && !ctx.link.onOff())
  {
    ra.aoe_theorem5.kind = Verdict::Kind::NOT_APPLICABLE;
    ra.aoe_theorem5.reason = "the arrivals of a Gilbert-Elliott chain with loss_good > 0 or loss_bad < 1 are not "
                             "the two-state Markov chain of Lin et al.";
    ra.aoe_theorem5.numbers["p_t"] = aoeRecoveryThreshold(ctx.rho);
  }
  else
  {
    // An i.i.d. link is the Markov chain with recovery = arrival and failure = 1 - arrival.
    const double rec = ctx.link.kind == LinkModel::Kind::IID ? ctx.link.arrival : ctx.link.r;
    const double fail = ctx.link.kind == LinkModel::Kind::IID ? 1.0 - ctx.link.arrival : ctx.link.p;
    const Sensor& s = model.sensors[set[0]];
    ra.aoe_theorem5 = aoeTheorem5(model.A, model.C.middleRows(s.offset, s.size), ctx.Qn,
                                  model.R.block(s.offset, s.offset, s.size, s.size), rec, fail, opt.tol);
  }

  // Thresholds and margin for the channel.
  const bool markov = ctx.has_channel && ctx.link.kind == LinkModel::Kind::GILBERT_ELLIOTT;
  if (!markov)
  {
    ra.margin_quantity = "arrival rate";
    const bool exact = std::isfinite(ra.exact_rate);
    ra.necessary_threshold = exact ? ra.exact_rate : ra.lower_bound;
    ra.sufficient_threshold = exact ? ra.exact_rate : ra.mare.converges_at;
    if (ctx.has_channel)
      ra.channel_value = ctx.link.arrival;
  }
  else
  {
    ra.margin_quantity = "recovery rate";
    if (ctx.link.onOff())
    {
      const bool exact = std::isfinite(ra.recovery_exact);
      ra.necessary_threshold = exact ? ra.recovery_exact : ra.recovery_lower_bound;
      ra.sufficient_threshold = ra.recovery_exact;
      ra.channel_value = ctx.link.r;
    }
  }
  ra.margin = ra.channel_value - ra.sufficient_threshold;

  // Verdict for the channel.
  Verdict& v = ra.verdict;
  if (!ctx.has_channel)
  {
    v.kind = Verdict::Kind::NOT_APPLICABLE;
    v.reason = "no channel given";
    return ra;
  }
  const std::vector<LinkModel> links(N, ctx.link);
  v.numbers["rho(A)"] = ctx.rho;
  v.numbers[ra.margin_quantity] = ra.channel_value;
  if (stable_A)
  {
    v.kind = Verdict::Kind::STABLE;
    v.reason = "A is stable (rho(A) = " + num(ctx.rho) + " < 1): the expected error covariance is bounded at every rate";
    return ra;
  }
  if (!ctx.excited)
  {
    v.kind = Verdict::Kind::NOT_APPLICABLE;
    v.reason = "(A, B Q^1/2) has an uncontrollable mode with |lambda| >= 1; the critical-rate results assume "
               "(A, Q^1/2) controllable";
    return ra;
  }
  if (!detectable)
  {
    v.kind = Verdict::Kind::UNSTABLE;
    v.reason = "a mode with |lambda| >= 1 is not observable from the sensors: unbounded at every rate";
    return ra;
  }
  const Verdict exact = marelliTest(ra.blocks, links, opt.tol);
  if (exact.kind != Verdict::Kind::NOT_APPLICABLE)
  {
    v.kind = exact.kind;
    v.reason = exact.reason;
    for (const auto& kv : exact.numbers)
      v.numbers[kv.first] = kv.second;
    if (std::isfinite(ra.sufficient_threshold))
    {
      std::ostringstream os;
      os << " (" << ra.margin_quantity << " " << num(ra.channel_value) << " vs critical " << num(ra.sufficient_threshold)
         << ")";
      v.reason += os.str();
    }
    return ra;
  }
  // Necessary condition: all sensors lost in a window (Yang Theorem 1 for i.i.d. links).
  double persistence = 1.0;
  for (const LinkModel& l : links)
    persistence *= l.lossPersistence();
  const double necessary = ctx.rho * ctx.rho * persistence;
  v.numbers["rho^2 prod persistence"] = necessary;
  if (markov ? necessary > 1.0 + opt.tol.decision : necessary >= 1.0 - opt.tol.decision)
  {
    v.kind = Verdict::Kind::UNSTABLE;
    v.reason = "necessary condition fails: rho(A)^2 times the probability growth rate of losing every sensor = " +
               num(necessary) + (markov ? " > 1 (Theorem 14, all-lost event)" : " >= 1 (Yang et al. Theorem 1)") +
               "; " + exact.reason;
    return ra;
  }
  if (!markov)
  {
    const Mare mare(model.A, ctx.Qn, H, std::vector<double>(N, ctx.link.arrival));
    const MareResult mr = solveMare(mare, opt.mare, true);
    v.numbers["MARE iterations"] = mr.iterations;
    v.numbers["MARE certificate rho(T)"] = mr.certificate;
    if (mr.status == MareResult::Status::CONVERGED)
    {
      v.kind = Verdict::Kind::STABLE;
      v.reason = "the MARE upper bound converges (certificate rho(T) = " + num(mr.certificate) +
                 " < 1, Yang et al. Theorem 4); " + exact.reason;
      return ra;
    }
    v.kind = Verdict::Kind::UNDECIDED;
    v.reason = std::string("above the necessary lower bound but the MARE upper bound ") +
               (mr.status == MareResult::Status::DIVERGED ? "diverges" : "is undecided") +
               " (a diverging upper bound does not prove instability); " + exact.reason;
    return ra;
  }
  v.kind = Verdict::Kind::UNDECIDED;
  v.reason = "above the necessary condition, no exact test available; " + exact.reason;
  return ra;
}

}  // namespace

StabilityReport analyzeStability(const Model& model, const ChannelSettings* sensor_link,
                                 const EstimatorSettings* estimator, const AnalysisOptions& options)
{
  StabilityReport rep;
  rep.model_name = model.name;
  rep.eigenvalues = eigenvalues(model.A);
  rep.spectral_radius = spectralRadius(model.A);
  rep.entropy = topologicalEntropy(model.A);
  rep.mahler_measure = std::exp(rep.entropy);
  rep.log_abs_det = std::log(std::abs(model.A.determinant()));
  rep.diagonalizable = isDiagonalizable(model.A, options.tol);
  rep.strong_observability = strongObservability(model.A, model.C, options.tol);

  Context ctx;
  ctx.model = &model;
  ctx.options = &options;
  ctx.Qn = model.B * model.Q * model.B.transpose();
  ctx.Qn = 0.5 * (ctx.Qn + ctx.Qn.transpose());
  ctx.H = whitenedSensors(model);
  ctx.rho = rep.spectral_radius;
  const Eigen::MatrixXd G = model.B * Eigen::LLT<Eigen::MatrixXd>(model.Q).matrixL().toDenseMatrix();
  ctx.excited = modesControllable(model.A, G, 1.0, 1e-9);
  rep.noise_excites_unstable_modes = ctx.excited;
  rep.detectable = modesObservable(model.A, model.C, 1.0, 1e-9);
  if (sensor_link)
  {
    ctx.has_channel = true;
    ctx.link = LinkModel::fromSettings(*sensor_link);
    rep.has_channel = true;
    rep.link = ctx.link;
    rep.arrival_rate = ctx.link.arrivalRate();
    rep.recovery_rate = ctx.link.recoveryRate();
    std::vector<double> rates(model.sensors.size(), std::min(rep.arrival_rate, 1.0 - 1e-300));
    std::vector<int> rows;
    for (const Sensor& s : model.sensors)
      rows.push_back(s.size);
    rep.capacity = transmissionCapacity(model.A, rates, rows);
  }
  rep.entropy_split = entropySplit(model.A, ctx.H);

  std::vector<int> all;
  for (std::size_t i = 0; i < model.sensors.size(); ++i)
    all.push_back(static_cast<int>(i));
  // The sets are independent (analyseSet reads ctx only): the per-sensor analyses run in parallel
  // with the model's, a thread each (the MARE bisections dominate for unstable models).
  std::vector<std::future<RateAnalysis>> per_sensor;
  if (options.per_sensor && model.sensors.size() > 1)
    for (std::size_t i = 0; i < model.sensors.size(); ++i)
      per_sensor.push_back(std::async(std::launch::async, [&ctx, &model, i] {
        return analyseSet(ctx, {static_cast<int>(i)}, model.sensors[i].name);
      }));
  rep.model = analyseSet(ctx, all, "model");
  for (auto& f : per_sensor)
    rep.sensors.push_back(f.get());
  if (options.per_sensor && model.sensors.size() == 1)
    rep.sensors.push_back(rep.model), rep.sensors.back().name = model.sensors[0].name;

  const Algorithm alg = estimator ? estimator->algorithm : Algorithm::KFIO;
  rep.estimator = toString(alg);
  switch (alg)
  {
    case Algorithm::KFIO:
      rep.estimator_note = "the verdicts concern E[P] of the Kalman filter with intermittent observations";
      break;
    case Algorithm::AOE:
    case Algorithm::OE:
    case Algorithm::ACK_KF:
      rep.estimator_note = "OE, AOE and the ACK Kalman filter are stable together (Lin et al.'s Theorem 4); the "
                           "verdicts concern that Kalman filter with intermittent observations";
      break;
    case Algorithm::RSEIO:
      rep.estimator_note = "the rate verdicts concern the Kalman filter with intermittent observations (rseio with mu "
                           "= 1); the rseio verdict is Zhou's Theorem 5";
      break;
    case Algorithm::KF:
      rep.estimator_note = "kf treats lost samples as measurements: its covariance is that of a Kalman filter without "
                           "losses, and these verdicts do not describe its error";
      break;
  }
  if (alg == Algorithm::RSEIO && sensor_link)
    rep.rseio = rseioTheorem5(model, estimator->mu, ctx.link, options.tol);
  else
  {
    rep.rseio.kind = Verdict::Kind::NOT_APPLICABLE;
    rep.rseio.reason = alg == Algorithm::RSEIO ? "no channel given" : "the estimator is not rseio";
  }
  return rep;
}

}  // namespace networked_estimation
