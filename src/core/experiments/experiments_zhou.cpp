// Experiments zhou_fig1, zhou_fig2 (Zhou's example, Section IV of the paper) and custom.
#include <map>
#include <memory>

#include <yaml-cpp/yaml.h>

#include "experiments/montecarlo_experiments.hpp"
#include "networked_estimation/common/angles.hpp"
#include "networked_estimation/simulation/lossy_run.hpp"
#include "networked_estimation/config/sensor_links.hpp"
#include "networked_estimation/common/error.hpp"
#include "networked_estimation/estimators/estimator.hpp"
#include "networked_estimation/channel/loss_model.hpp"
#include "networked_estimation/common/random.hpp"
#include "networked_estimation/config/channel_settings.hpp"
#include "networked_estimation/config/estimator_settings.hpp"
#include "networked_estimation/simulation/simulator.hpp"

namespace networked_estimation
{
namespace mc
{

namespace
{

const double kArrival = 0.8;  // gamma-bar of Zhou's example

EstimatorSettings settingsOf(Algorithm a, double mu = 1.0)
{
  EstimatorSettings s;
  s.algorithm = a;
  s.mu = mu;
  return s;
}

/// One estimator of a squared-error experiment: its settings and whether it is given every sample
/// as received (gamma forced to 1: RSE [27]).
struct ErrorFilter
{
  EstimatorSettings settings;
  bool force_gamma = false;
};

/// Advances a simulated run (PlantSimulator or LossyRun), naming run r in a rounding-floor error.
template <class Run>
const SimulatedSample& stepRun(Run& run, long r)
{
  try
  {
    return run.step();  // refuses a state beyond the rounding floor (simulator.hpp)
  }
  catch (const DivergenceError& err)
  {
    throw DivergenceError("run " + std::to_string(r) + ": " + err.what());
  }
}

/// Steps every filter on the sample (gamma forced for those that take every sample, ack_kf told
/// nu_k) and records filter j's squared error at out[j T + k - 1] (the differences of the angular states
/// `angles` wrapped).
void stepFilters(const std::vector<std::unique_ptr<Estimator>>& est, const std::vector<ErrorFilter>& filters,
                 const std::vector<int>& angles, Sample& sample, const SimulatedSample& s, long r, long k, long T,
                 double* out)
{
  const bool gamma = sample.gamma;
  for (std::size_t j = 0; j < est.size(); ++j)
  {
    Estimator& e = *est[j];
    sample.gamma = filters[j].force_gamma || gamma;
    sample.nu = e.algorithm() == Algorithm::ACK_KF ? (s.nu ? 1 : 0) : -1;
    try
    {
      e.step(sample);
    }
    catch (const DivergenceError& err)
    {
      throw DivergenceError(toString(e.algorithm()) + " diverged in run " + std::to_string(r) +
                            " at k = " + std::to_string(k) + ": " + err.what());
    }
    out[j * static_cast<std::size_t>(T) + static_cast<std::size_t>(k - 1)] = squaredError(s.x, e.state(), angles);
  }
  sample.gamma = gamma;
}

/// Squared error ||x_k - xhat_k||^2, k = 1..T, of several estimators fed the same simulated data
/// (plant of `model`, sensor link `channel`; y_k = v_k when a sample is lost). Values per run:
/// filter-major, T per filter. Run r: plant seed deriveSeed(rs, 0), channel seed deriveSeed(rs, 1)
/// with rs = deriveSeed(seed, r).
Moments squaredErrorRuns(const RunConfig& rc, const Model& model, const ChannelSettings& channel,
                         const std::vector<ErrorFilter>& filters, double window0, double window1)
{
  const long T = rc.steps;
  const std::uint64_t seed = rc.seed;
  const std::size_t nf = filters.size();
  WorkerFactory factory = [&model, &channel, &filters, T, seed]() -> RunFunction
  {
    struct State
    {
      std::vector<std::unique_ptr<Estimator>> est;
      std::unique_ptr<LossModel> loss;
      Sample sample;
    };
    auto st = std::make_shared<State>();
    for (const ErrorFilter& f : filters)
      st->est.push_back(makeEstimator(model, f.settings));
    st->loss = makeLossModel(channel, 0);
    st->sample.y.resize(model.m());
    if (model.hasControl())
      st->sample.u.resize(model.p());
    return [st, &model, &filters, T, seed](long r, double* out)
    {
      const std::uint64_t rs = deriveSeed(seed, static_cast<std::uint64_t>(r));
      PlantSimulator sim(model, deriveSeed(rs, 0));
      st->loss->reseed(deriveSeed(rs, 1));
      for (auto& e : st->est)
        e->reset();
      Sample& sample = st->sample;
      for (long k = 1; k <= T; ++k)
      {
        const SimulatedSample& s = stepRun(sim, r);
        const bool gamma = !st->loss->nextLost();
        sample.y = gamma ? s.y : s.v;
        if (model.hasControl())
          sample.u = s.u;
        sample.gamma = gamma;
        stepFilters(st->est, filters, model.angles, sample, s, r, k, T, out);
      }
    };
  };
  CallStatistics stats = callStatistics(rc);
  for (std::size_t j = 0; j < nf; ++j)
    addSpan(stats, j * static_cast<std::size_t>(T), stepAxis(T), window0, window1);
  return runMonteCarlo(rc.runs, nf * static_cast<std::size_t>(T), rc.threads, factory, rc.progress, nullptr, &stats,
                       rc.session);
}

std::string stem(const std::string& path)
{
  std::string base = path.substr(path.find_last_of('/') == std::string::npos ? 0 : path.find_last_of('/') + 1);
  const std::string::size_type dot = base.find_last_of('.');
  if (dot != std::string::npos && dot > 0)
    base = base.substr(0, dot);
  return base;
}

}  // namespace

ExperimentResult zhouFig1(const RunConfig& rc)
{
  ExperimentResult res;
  const long T = rc.steps;
  const double w0 = static_cast<double>(std::min<long>(80, T)), w1 = static_cast<double>(T);
  ChannelSettings channel;
  channel.model = LossModelKind::BERNOULLI;
  channel.loss = 1.0 - kArrival;
  if (rc.progress)
    rc.progress->setTotal(2 * rc.runs);

  const std::vector<double> x = stepAxis(T);
  auto addCase =
      [&](const std::string& name, const std::string& title, const Moments& m, const std::vector<std::size_t>& idx)
  {
    CaseResult c;
    c.name = name;
    c.title = title;
    c.x = x;
    const char* names[] = {"KF", "KFIO", "RSE", "RSEIO"};
    for (std::size_t i = 0; i < 4; ++i)
      c.series.push_back(
          makeSeries(names[i], m, idx[i] * static_cast<std::size_t>(T), static_cast<std::size_t>(T), w0, w1));
    res.cases.push_back(c);
  };

  // delta = 1: one simulation feeds KF, KFIO and RSE / RSEIO for both mu (the cases share the data)
  {
    const Model model = zhouExampleModel(1.0);
    const std::vector<ErrorFilter> filters = {
        {settingsOf(Algorithm::KF), false},         {settingsOf(Algorithm::KFIO), false},
        {settingsOf(Algorithm::RSEIO, 0.8), true},  {settingsOf(Algorithm::RSEIO, 0.8), false},
        {settingsOf(Algorithm::RSEIO, 0.95), true}, {settingsOf(Algorithm::RSEIO, 0.95), false},
    };
    const Moments m = squaredErrorRuns(rc, model, channel, filters, w0, w1);
    addCase("delta1_mu0.8", "delta = 1, mu = 0.8", m, {0, 1, 2, 3});
    addCase("delta1_mu0.95", "delta = 1, mu = 0.95", m, {0, 1, 4, 5});
  }
  {
    const Model model = zhouExampleModel(10.0);
    const std::vector<ErrorFilter> filters = {
        {settingsOf(Algorithm::KF), false},
        {settingsOf(Algorithm::KFIO), false},
        {settingsOf(Algorithm::RSEIO, 0.8), true},
        {settingsOf(Algorithm::RSEIO, 0.8), false},
    };
    const Moments m = squaredErrorRuns(rc, model, channel, filters, w0, w1);
    addCase("delta10_mu0.8", "delta = 10, mu = 0.8", m, {0, 1, 2, 3});
  }

  res.x_label = "k";
  res.y_label = "MSE_k = mean ||x_k - xhat_k|k||^2";
  res.log_y = true;
  // the paper's figure: the full horizon, and a zoom on 80 <= k <= 500 with the time averages
  res.plot.kind = PlotHints::Kind::AVERAGED;
  res.plot.zoom0 = 80.0;
  res.plot.zoom1 = 500.0;
  res.assumptions = {
      "plant of Zhou's example: eps_k ~ U[-delta, delta] fresh every step, A(eps)(1,2) = 0.0196 + 0.099 eps",
      "x_0 ~ N([1, 0]', I); xhat_0|0 = [1, 0]', P_0|0 = I; y_0 not used (first sample k = 1)",
      "gamma_k i.i.d. Bernoulli(0.8); when gamma_k = 0 the sample carries y_k = v_k",
      "KF and RSE use every sample (including the noise-only ones); RSE = rseio with gamma forced to 1",
      "run r uses seeds deriveSeed(deriveSeed(seed, r), 0) (plant) and (.., 1) (channel); the cases delta1_mu0.8 "
      "and delta1_mu0.95 share the same data (common random numbers), so their KF and KFIO series are identical",
  };
  res.notes = {"RSEMM is not specified by the paper and is not simulated",
               "time_average = mean of MSE_k over k in the window [80, steps]"};
  return res;
}

ExperimentResult zhouFig2(const RunConfig& rc)
{
  ExperimentResult res;
  const long T = rc.steps;
  const double mu = 0.8;
  const std::vector<double> p0s = {0.1, 1.0, 10.0, 100.0};
  const std::vector<std::string> names = {"P0_0.1", "P0_1", "P0_10", "P0_100"};
  if (rc.progress)
    rc.progress->setTotal(static_cast<long>(p0s.size()) * rc.runs);
  res.sample_columns = {"P11", "P12", "P21", "P22"};
  for (std::size_t c = 0; c < p0s.size(); ++c)
  {
    Model model = zhouExampleModel(10.0);
    model.P0 = p0s[c] * Eigen::MatrixXd::Identity(2, 2);
    const std::uint64_t seed = rc.seed;
    WorkerFactory factory = [&model, mu, T, seed]() -> RunFunction
    {
      struct State
      {
        std::unique_ptr<Estimator> est;
        BernoulliLoss loss{1.0 - kArrival, 0};
        Sample sample;
      };
      auto st = std::make_shared<State>();
      st->est = makeEstimator(model, settingsOf(Algorithm::RSEIO, mu));
      st->sample.y = Eigen::VectorXd::Zero(model.m());
      return [st, T, seed](long r, double* out)
      {
        const std::uint64_t rs = deriveSeed(seed, static_cast<std::uint64_t>(r));
        st->loss.reseed(deriveSeed(rs, 1));
        st->est->reset();
        for (long k = 1; k <= T; ++k)
        {
          st->sample.gamma = !st->loss.nextLost();
          st->est->step(st->sample);
        }
        const Eigen::MatrixXd& P = st->est->covariance();
        out[0] = P(0, 0);
        out[1] = P(0, 1);
        out[2] = P(1, 0);
        out[3] = P(1, 1);
      };
    };
    SampleSet samples;
    samples.case_name = names[c];
    const CallStatistics stats = callStatistics(rc);
    const Moments m = runMonteCarlo(rc.runs, 4, rc.threads, factory, rc.progress, &samples.values, &stats, rc.session);
    CaseResult cr;
    cr.name = names[c];
    cr.title = "P_0|0 = " + fmt(p0s[c]) + " I";
    cr.x = {static_cast<double>(T)};
    cr.series.push_back(makeSeries("P11", m, 0, 1, T, T));
    cr.series.push_back(makeSeries("P12", m, 1, 1, T, T));
    cr.series.push_back(makeSeries("P22", m, 3, 1, T, T));
    res.cases.push_back(cr);
    res.samples.push_back(std::move(samples));
  }
  res.x_label = "k";
  res.y_label = "element of P_k|k (RSEIO)";
  // the paper's figure: the empirical PDFs of P11, P12 and P22 at the last step, the P0 cases overlaid
  res.plot.kind = PlotHints::Kind::DENSITY;
  res.plot.tails = false;
  const std::string TT = std::to_string(T) + "|" + std::to_string(T);
  res.plot.density_title = "EPDF of the elements of $P_{" + TT + "}$";
  for (const char* ij : {"11", "12", "22"})
    res.plot.density_columns.push_back(
        {std::string("P") + ij, "$[P_{" + TT + "}]_{" + ij + "}$", std::string("$P_{") + ij + "}$"});
  for (std::size_t c = 0; c < p0s.size(); ++c)
    res.plot.case_labels.emplace_back(names[c], "$P_{0|0} = " + fmt(p0s[c]) + "\\,I_2$");
  res.assumptions = {
      "delta = 10, mu = 0.8, gamma_k i.i.d. Bernoulli(0.8) with the channel seed of zhou_fig1 "
      "(deriveSeed(deriveSeed(seed, r), 1)); P does not depend on the data, so only the arrivals are simulated",
  };
  res.notes = {
      "the CSV summarises the distribution of P_T|T (T = steps) across runs by mean and sd; "
      "zhou_fig2_samples.csv holds every run's P_T|T for the empirical PDFs"};
  return res;
}

namespace
{

/// The YAML of an input given as text (MonteCarloConfig::inline_inputs), its errors naming `label`.
YAML::Node inlineYaml(const std::string& label, const std::string& text)
{
  try
  {
    return YAML::Load(text);
  }
  catch (const YAML::Exception& e)
  {
    throw ConfigError(label + ": not valid YAML: " + e.what());
  }
}

}  // namespace

CustomSetup loadCustomSetup(const MonteCarloConfig& cfg, const std::string& experiment)
{
  if (cfg.model_path.empty() || cfg.settings_paths.empty())
    throw ConfigError("experiment " + experiment + ": needs a model and at least one settings file");
  const std::map<std::string, std::string>& text = cfg.inline_inputs;
  CustomSetup su;
  const auto model_text = text.find(cfg.model_path);
  su.model = model_text != text.end() ? parseModel(inlineYaml(cfg.model_path, model_text->second), cfg.model_path)
                                      : loadModel(cfg.model_path);
  su.links = resolveSensorLinks(su.model, cfg.channel_args,
                                [&text](const std::string& file)
                                {
                                  const auto it = text.find(file);
                                  return it != text.end() ? parseChannelSettings(inlineYaml(file, it->second), file)
                                                          : loadChannelSettings(file);
                                });
  su.options.sensor_links = su.links.link;
  if (su.model.hasControl())
    su.options.control = ControlSequence::parse("paper", "control");  // simulate's default sequence
  if (!cfg.actuator_channel_path.empty())
  {
    if (!su.model.hasControl())
      throw ConfigError("--actuator-channel: model '" + su.model.name + "' has no control input");
    su.options.actuator_link = loadChannelSettings(cfg.actuator_channel_path);
  }
  for (const std::string& p : cfg.settings_paths)
  {
    // settings given as text, an algorithm name (named after itself), or a file (named after its stem)
    const auto it = text.find(p);
    su.settings.push_back(it != text.end() ? parseEstimatorSettings(inlineYaml(p, it->second), p)
                                           : estimatorSettingsArgument(p));
    makeEstimator(su.model, su.settings.back());  // validates the combination before any run
    su.names.push_back(it != text.end() || isAlgorithmName(p) ? p : stem(p));
  }
  for (std::size_t j = 0; j < su.names.size(); ++j)
    for (std::size_t i = 0; i < j; ++i)
      if (su.names[i] == su.names[j])
        throw ConfigError("experiment " + experiment + ": two estimators named '" + su.names[j] + "' (settings '" +
                          cfg.settings_paths[i] + "' and '" + cfg.settings_paths[j] +
                          "'): the series need distinct names");
  return su;
}

ExperimentResult customExperiment(const RunConfig& rc)
{
  const MonteCarloConfig& cfg = *rc.config;
  const CustomSetup su = loadCustomSetup(cfg, "custom");
  const Model& model = su.model;
  const SensorLinks& links = su.links;
  const LossyRunOptions& options = su.options;
  const std::vector<std::string>& names = su.names;
  std::vector<ErrorFilter> filters;
  for (const EstimatorSettings& s : su.settings)
    filters.push_back({s, false});
  if (rc.progress)
    rc.progress->setTotal(rc.runs);
  const long T = rc.steps;
  const std::size_t nf = filters.size();
  const std::uint64_t seed = rc.seed;
  // Run r is exactly `simulate --seed seed + r` with the same links, replayed by every estimator
  // (replay's Sample: the received y and gamma, the commanded u; ack_kf is told nu_k).
  WorkerFactory factory = [&model, &filters, &options, T, seed]() -> RunFunction
  {
    auto est = std::make_shared<std::vector<std::unique_ptr<Estimator>>>();
    for (const ErrorFilter& f : filters)
      est->push_back(makeEstimator(model, f.settings));
    return [est, &model, &filters, &options, T, seed](long r, double* out)
    {
      LossyRun run(model, seed + static_cast<std::uint64_t>(r), options);
      for (auto& e : *est)
        e->reset();
      Sample sample;
      for (long k = 1; k <= T; ++k)
      {
        const SimulatedSample& s = stepRun(run, r);
        sample = run.received();
        stepFilters(*est, filters, model.angles, sample, s, r, k, T, out);
      }
    };
  };
  CallStatistics stats = callStatistics(rc);
  for (std::size_t j = 0; j < nf; ++j)
    addSpan(stats, j * static_cast<std::size_t>(T), stepAxis(T), 1.0, static_cast<double>(T));
  const Moments m = runMonteCarlo(rc.runs, nf * static_cast<std::size_t>(T), rc.threads, factory, rc.progress, nullptr,
                                  &stats, rc.session);
  ExperimentResult res;
  CaseResult c;
  c.name = model.name.empty() ? stem(cfg.model_path) : model.name;
  std::string described = links.describe();
  for (char& ch : described)
    if (ch == '\n')
      ch = ';';
  c.title = "model " + cfg.model_path + "; links " + described +
            (cfg.actuator_channel_path.empty() ? "" : " actuator " + cfg.actuator_channel_path);
  c.x = stepAxis(T);
  for (std::size_t j = 0; j < nf; ++j)
    c.series.push_back(makeSeries(names[j], m, j * static_cast<std::size_t>(T), static_cast<std::size_t>(T), 1.0,
                                  static_cast<double>(T)));
  res.cases.push_back(c);
  res.x_label = "k";
  res.y_label = "MSE_k = mean ||x_k - xhat_k|k||^2";
  res.log_y = true;
  res.assumptions = {
      "run r is exactly `simulate --seed S+r` with the same --channel / --actuator-channel options (S = --seed), "
      "replayed by every estimator: x_0 ~ N(x0, P0) of the model, the estimators start from x0, P0",
      "each sensor has its own independent loss stream (its own link, or lossless); gamma_k = 1 when at least "
      "one sensor arrived; a step where none arrived carries y_k = v_k (only kf uses it)",
      "with control: u_k = 1 + exp(-k/10) (paper sequence); a command lost on the actuator link applies zero "
      "input; ack_kf is told whether each command arrived",
  };
  res.notes = {"time_average = mean of MSE_k over k in [1, steps]"};
  return res;
}

}  // namespace mc
}  // namespace networked_estimation
