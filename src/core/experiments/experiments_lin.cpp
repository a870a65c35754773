// Experiments lin_fig2 .. lin_fig5 (Lin et al., Theorem 3 and Section 7): OE / AOE / ACK covariances and the
// upper sequence S_k of (27) on the example of Lin et al.
#include <cmath>
#include <limits>
#include <memory>

#include "experiments/montecarlo_experiments.hpp"
#include "networked_estimation/common/error.hpp"
#include "networked_estimation/estimators/estimator.hpp"
#include "networked_estimation/channel/loss_model.hpp"
#include "networked_estimation/common/random.hpp"
#include "networked_estimation/config/estimator_settings.hpp"
#include "networked_estimation/simulation/simulator.hpp"

namespace networked_estimation
{
namespace mc
{

namespace
{

/// Stream of the fixed Gamma realisation of lin_fig4 (not used by any run).
const std::uint64_t kFixedGammaStream = 1ULL << 62;

struct LinParams
{
  double rho = 1.2910;
  double p1 = 0.8, p2 = 0.5;  ///< sensor link: recovery, failure (Lin et al.'s p1, p2)
  double q1 = 0.5, q2 = 0.5;  ///< actuator link
  long steps = 30;            ///< simulated steps (AOE, ACK, S run over all of them)
  long oe_steps = 0;          ///< OE steps (0: no OE)
  std::size_t cap = 4096;     ///< OE max_components
  bool aoe = true, ack = true;
  const std::vector<char>* fixed_gamma = nullptr;  ///< null: Markov Gamma drawn per run
};

/// Values per run: 4 traces of `steps` values: [tr P_ACK | tr P (OE, 0 after oe_steps) |
/// tr P^e (AOE) | tr S_k]. Run r: plant seed deriveSeed(rs, 0), sensor link deriveSeed(rs, 1),
/// actuator link deriveSeed(rs, 2), rs = deriveSeed(seed, r).
enum Trace
{
  ACK = 0,
  OE = 1,
  AOE = 2,
  S = 3
};

/// The upper bound U >= B u_k u_k' B' for k >= 1 with u_k = 1 + exp(-k/10): (1 + e^{-0.1})^2 Bu Bu'.
Eigen::MatrixXd boundU(const Model& model)
{
  const double umax = 1.0 + std::exp(-0.1);
  return umax * umax * model.Bu * model.Bu.transpose();
}

Moments linRuns(const RunConfig& rc, const LinParams& lp)
{
  const long T = lp.steps;
  const std::uint64_t seed = rc.seed;
  WorkerFactory factory = [lp, T, seed]() -> RunFunction
  {
    struct State
    {
      Model model;
      std::unique_ptr<Estimator> ack, oe, aoe;
      Sample sample;
      Eigen::MatrixXd U4, S, Sbar, K, Sy;
    };
    auto st = std::make_shared<State>();
    st->model = aoeExampleModel(lp.rho);
    EstimatorSettings s;
    s.has_control_link = true;
    s.recovery = lp.q1;
    s.failure = lp.q2;
    s.algorithm = Algorithm::ACK_KF;
    st->ack = makeEstimator(st->model, s);
    s.algorithm = Algorithm::AOE;
    st->aoe = makeEstimator(st->model, s);
    if (lp.oe_steps > 0)
    {
      s.algorithm = Algorithm::OE;
      s.max_components = lp.cap;
      st->oe = makeEstimator(st->model, s);
    }
    st->U4 = 0.25 * boundU(st->model);
    return [st, lp, T, seed](long r, double* out)
    {
      const Model& m = st->model;
      const std::uint64_t rs = deriveSeed(seed, static_cast<std::uint64_t>(r));
      ControlSequence control;
      control.kind = ControlSequence::Kind::PAPER;
      control.value = 1.0;
      PlantSimulator sim(m, deriveSeed(rs, 0), control,
                         std::make_unique<GilbertElliottLoss>(lp.q2, lp.q1, 1.0, 0.0, deriveSeed(rs, 2)));
      // These experiments report covariance traces, not errors against the state; the rho = 1.826
      // plant of lin_fig2 reaches the rounding floor near k = 46 of its 50 steps (stated in the
      // assumptions), so the floor check is off here.
      sim.setStateLimit(std::numeric_limits<double>::infinity());
      GilbertElliottLoss sensor(lp.p2, lp.p1, 1.0, 0.0, deriveSeed(rs, 1));
      st->ack->reset();
      st->aoe->reset();
      if (st->oe)
        st->oe->reset();
      st->S = m.P0;
      Sample& sample = st->sample;
      const std::size_t uT = static_cast<std::size_t>(T);
      for (long k = 1; k <= T; ++k)
      {
        const std::size_t i = static_cast<std::size_t>(k - 1);
        const SimulatedSample* sp = nullptr;
        try
        {
          sp = &sim.step();  // refuses a state beyond the rounding floor (simulator.hpp)
        }
        catch (const DivergenceError& e)
        {
          throw DivergenceError("run " + std::to_string(r) + ": " + e.what());
        }
        const SimulatedSample& ss = *sp;
        const bool gamma = lp.fixed_gamma ? (*lp.fixed_gamma)[i] != 0 : !sensor.nextLost();
        sample.gamma = gamma;
        sample.y = ss.y;
        sample.u = ss.u;
        try
        {
          sample.nu = ss.nu ? 1 : 0;
          st->ack->step(sample);
          sample.nu = -1;
          st->aoe->step(sample);
          if (st->oe && k <= lp.oe_steps)
            st->oe->step(sample);
        }
        catch (const DivergenceError& e)
        {
          throw DivergenceError("run " + std::to_string(r) + ", k = " + std::to_string(k) + ": " + e.what());
        }
        out[ACK * uT + i] = st->ack->covariance().trace();
        out[AOE * uT + i] = st->aoe->covariance().trace();
        out[OE * uT + i] = st->oe && k <= lp.oe_steps ? st->oe->covariance().trace() : 0.0;
        // (27): Sbar = A S A' + Q + U/4, S = phi(Sbar, gamma)
        st->Sbar = m.A * st->S * m.A.transpose() + m.B * m.Q * m.B.transpose() + st->U4;
        if (gamma)
        {
          st->Sy = m.C * st->Sbar * m.C.transpose() + m.R;
          st->K = st->Sbar * m.C.transpose() * st->Sy.inverse();
          st->S = st->Sbar - st->K * m.C * st->Sbar;
          st->S = 0.5 * (st->S + st->S.transpose()).eval();
        }
        else
          st->S = st->Sbar;
        out[S * uT + i] = st->S.trace();
      }
    };
  };
  CallStatistics stats = callStatistics(rc);
  for (std::size_t j = 0; j < 4; ++j)
    addSpan(stats, j * static_cast<std::size_t>(T), stepAxis(T), 1.0, static_cast<double>(T));
  return runMonteCarlo(rc.runs, 4 * static_cast<std::size_t>(T), rc.threads, factory, rc.progress, nullptr, &stats,
                       rc.session);
}

std::vector<std::string> commonAssumptions()
{
  return {
      "model of Lin et al.'s example (their Section 7) with C = [[1, -1], [0, 1]] (reading of the garbled C), "
      "Q = R = 20 I, Bu = [-1; 1]",
      "xbar_0 = 0, P_0 = I (x_0 ~ N(0, I)), nuhat_0 = pi_nu; u_k = 1 + exp(-k/10), zero input when lost",
      "Markov links start in their stationary law (gamma_1 ~ pi_gamma, nu_1 ~ pi_nu)",
      "U = (1 + e^{-0.1})^2 Bu Bu' = 3.628406 [[1, -1], [-1, 1]] (tightest bound for k >= 1) in S_k of (27)",
      "traces of the filters' internal covariances (P_k, P^e_k, P^ACK_k), averaged over runs",
      "the simulator's rounding-floor check is off: no error against the state is reported; at rho = 1.826 "
      "(lin_fig2) the state reaches the floor near k = 46, where its rounding is at most about 1 % of the "
      "noise standard deviation and enters only the AOE/OE mixture weights",
  };
}

/// One value (index v of the moments) as the point i of a sweep series.
void setPoint(SeriesResult& s, std::size_t i, const Moments& m, std::size_t v)
{
  s.mean[i] = m.mean[v];
  s.sd[i] = m.sd[v];
  s.n = m.n;
  if (s.exceed.size() != m.thresholds.size() || (s.p5.empty() && !m.sketches.empty()))
    resizeTails(s, s.mean.size(), m);
  setTails(s, i, m, v);
}

SeriesResult sweepSeries(const std::string& name, const std::vector<double>& x)
{
  SeriesResult s;
  s.name = name;
  s.mean.assign(x.size(), 0.0);
  s.sd.assign(x.size(), 0.0);
  s.window0 = x.front();
  s.window1 = x.back();
  return s;
}

std::string gammaString(const std::vector<char>& g)
{
  std::string s;
  for (char c : g)
    s += c ? '1' : '0';
  return s;
}

}  // namespace

ExperimentResult linFig4(const RunConfig& rc)
{
  const long T = rc.steps;
  LinParams lp;
  lp.rho = 1.2910;
  lp.steps = T;
  lp.oe_steps = T;
  lp.cap = 4096;
  // one fixed Gamma realisation from the Markov chain p1 = 0.8, p2 = 0.5 (stationary start)
  std::vector<char> gamma(static_cast<std::size_t>(T));
  GilbertElliottLoss chain(lp.p2, lp.p1, 1.0, 0.0, deriveSeed(rc.seed, kFixedGammaStream));
  for (char& g : gamma)
    g = chain.nextLost() ? 0 : 1;
  lp.fixed_gamma = &gamma;
  if (rc.progress)
    rc.progress->setTotal(rc.runs);
  const Moments m = linRuns(rc, lp);
  const std::size_t uT = static_cast<std::size_t>(T);
  ExperimentResult res;
  CaseResult c;
  c.name = "fixed_gamma";
  c.title = "rho_A = 1.2910, q1 = q2 = 0.5, one fixed Gamma (Markov p1 = 0.8, p2 = 0.5)";
  c.x = stepAxis(T);
  c.series.push_back(makeSeries("tr P_ACK", m, ACK * uT, uT, 1, T));
  c.series.push_back(makeSeries("tr E[P] (OE)", m, OE * uT, uT, 1, T));
  c.series.push_back(makeSeries("tr E[P^e] (AOE)", m, AOE * uT, uT, 1, T));
  c.series.push_back(makeSeries("tr S_k", m, S * uT, uT, 1, T));
  c.series[0].bound = c.series[3].bound = true;
  res.cases.push_back(c);
  res.x_label = "k";
  res.y_label = "trace";
  res.log_y = true;
  res.assumptions = commonAssumptions();
  res.assumptions.push_back(
      "Gamma fixed for all runs, drawn from the chain with seed deriveSeed(seed, 2^62) (see notes)");
  res.assumptions.push_back("OE capped at max_components = 4096 (largest weights kept; exact while 2^k <= 4096)");
  res.notes = {"Theorem 3 (28): tr P_ACK <= tr E[P] <= tr S_k and tr P_ACK <= tr E[P^e] <= tr S_k",
               "gamma_k (k = 1..T) = " + gammaString(gamma)};
  return res;
}

ExperimentResult linFig5(const RunConfig& rc)
{
  const long T = rc.steps;
  LinParams lp;
  lp.rho = 1.2910;
  lp.steps = T;
  lp.oe_steps = 0;
  if (rc.progress)
    rc.progress->setTotal(rc.runs);
  const Moments m = linRuns(rc, lp);
  const std::size_t uT = static_cast<std::size_t>(T);
  ExperimentResult res;
  CaseResult c;
  c.name = "random_gamma";
  c.title = "rho_A = 1.2910, p1 = 0.8, p2 = 0.5, q1 = q2 = 0.5, Gamma random per run";
  c.x = stepAxis(T);
  c.series.push_back(makeSeries("tr E[P^e] (AOE)", m, AOE * uT, uT, 1, T));
  c.series.push_back(makeSeries("tr E[S_k]", m, S * uT, uT, 1, T));
  c.series.push_back(makeSeries("tr E[P_ACK]", m, ACK * uT, uT, 1, T));
  c.series[1].bound = c.series[2].bound = true;
  res.cases.push_back(c);
  res.x_label = "k";
  res.y_label = "trace";
  res.log_y = true;
  res.assumptions = commonAssumptions();
  res.notes = {"expectations over Gamma, nu, x_0 and the noises (E_{I_k}); the OE is omitted as in the paper"};
  return res;
}

ExperimentResult linFig2(const RunConfig& rc)
{
  const long T = rc.steps;
  const long T2 = T + 20;
  const std::size_t cap = 256;
  const std::vector<double> rhos = {1.2910, 1.8257};
  const std::vector<std::string> names = {"rho1.291", "rho1.826"};
  const int points = 10;
  if (rc.progress)
    rc.progress->setTotal(static_cast<long>(rhos.size()) * points * rc.runs);
  ExperimentResult res;
  for (std::size_t c = 0; c < rhos.size(); ++c)
  {
    const double pt = 1.0 - 1.0 / (rhos[c] * rhos[c]);
    CaseResult cr;
    cr.name = names[c];
    char pt_text[32];
    std::snprintf(pt_text, sizeof pt_text, "%.4f", pt);  // 0.4000, not the 0.40000516 of %.10g
    cr.title = "rho_A = " + fmt(rhos[c]) + ", p_t = " + pt_text + ", p2 = q1 = q2 = 0.5";
    for (int i = 0; i < points; ++i)
      cr.x.push_back(pt + 0.02 + (1.0 - pt - 0.02) * i / (points - 1));
    SeriesResult oe = sweepSeries("OE tr E[P_" + std::to_string(T) + "]", cr.x);
    SeriesResult aoe = sweepSeries("AOE tr E[P^e_" + std::to_string(T) + "]", cr.x);
    SeriesResult aoe2 = sweepSeries("AOE tr E[P^e_" + std::to_string(T2) + "]", cr.x);
    for (int i = 0; i < points; ++i)
    {
      LinParams lp;
      lp.rho = rhos[c];
      lp.p1 = cr.x[static_cast<std::size_t>(i)];
      lp.p2 = lp.q1 = lp.q2 = 0.5;
      lp.steps = T2;
      lp.oe_steps = T;
      lp.cap = cap;
      const Moments m = linRuns(rc, lp);
      const std::size_t uT = static_cast<std::size_t>(T2), pi = static_cast<std::size_t>(i);
      setPoint(oe, pi, m, OE * uT + static_cast<std::size_t>(T - 1));
      setPoint(aoe, pi, m, AOE * uT + static_cast<std::size_t>(T - 1));
      setPoint(aoe2, pi, m, AOE * uT + static_cast<std::size_t>(T2 - 1));
    }
    cr.series = {oe, aoe, aoe2};
    res.cases.push_back(cr);
  }
  res.x_label = "p1";
  res.y_label = "trace";
  res.log_y = true;
  res.assumptions = commonAssumptions();
  res.assumptions.push_back("p1 grid: 10 points from p_t + 0.02 to 1, p_t = 1 - rho_A^-2; p2 = q1 = q2 = 0.5");
  res.notes = {"OE capped at max_components = " + std::to_string(cap) +
                   " (largest weights kept): an approximation of the exact OE beyond k = 8",
               "the paper's E_{I_30}[P^e_50] (Section 7; its indices disagree) is read as k = " + std::to_string(T) +
                   "; k = " + std::to_string(T2) + " is reported too",
               "time_average of a sweep series = mean over the grid points"};
  return res;
}

ExperimentResult linFig3(const RunConfig& rc)
{
  const long T = rc.steps;
  const std::size_t cap = 256;
  const std::vector<std::string> names = {"q1", "q2", "p2"};
  std::vector<double> grid;
  for (int i = 1; i <= 9; ++i)
    grid.push_back(0.1 * i);
  if (rc.progress)
    rc.progress->setTotal(static_cast<long>(names.size() * grid.size()) * rc.runs);
  ExperimentResult res;
  for (const std::string& name : names)
  {
    CaseResult cr;
    cr.name = name;
    cr.title = "rho_A = 1.2910, p1 = 0.8, sweeping " + name + " (others 0.5)";
    cr.x = grid;
    SeriesResult oe = sweepSeries("OE tr E[P_" + std::to_string(T) + "]", grid);
    for (std::size_t i = 0; i < grid.size(); ++i)
    {
      LinParams lp;
      lp.rho = 1.2910;
      lp.p1 = 0.8;
      lp.p2 = name == "p2" ? grid[i] : 0.5;
      lp.q1 = name == "q1" ? grid[i] : 0.5;
      lp.q2 = name == "q2" ? grid[i] : 0.5;
      lp.steps = T;
      lp.oe_steps = T;
      lp.cap = cap;
      const Moments m = linRuns(rc, lp);
      setPoint(oe, i, m, OE * static_cast<std::size_t>(T) + static_cast<std::size_t>(T - 1));
    }
    cr.series = {oe};
    res.cases.push_back(cr);
  }
  res.x_label = "parameter";
  res.y_label = "trace";
  res.log_y = true;
  res.assumptions = commonAssumptions();
  res.assumptions.push_back(
      "p1 = 0.8; the swept parameter over 0.1 .. 0.9, the others 0.5; q1, q2 are both the "
      "simulated actuator link and the estimator's control_link");
  res.notes = {"OE capped at max_components = " + std::to_string(cap) + " (largest weights kept)",
               "time_average of a sweep series = mean over the grid points"};
  return res;
}

}  // namespace mc
}  // namespace networked_estimation
