// The live link stability diagnostic (live_stability.hpp).
#include "networked_estimation/stability/live_stability.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <stdexcept>

#include "networked_estimation/stability/stability.hpp"
#include "io/tokens.hpp"

namespace networked_estimation
{
namespace
{

std::string liveNumber(double v)
{
  return tokens::format(v, 6);
}

std::string rate(const RateEstimate& e, const char* unit)
{
  char buf[128];
  std::snprintf(buf, sizeof buf, "%g [%g, %g] (%zu %s)", e.value, e.lower, e.upper, e.trials, unit);
  return buf;
}

/// "arrival rate >= 0.111 (now 0.5)", "> 0" (any positive rate), "any" (the others cover its
/// modes), the stable intervals, or why there is no such rate.
std::string describeNeed(const SensorMargin& m)
{
  if (m.quantity.empty())
    return m.note;
  std::string out = m.quantity;
  if (m.half_line)
  {
    if (!std::isfinite(m.band.converges_at))
      return out + ": " + m.note;
    if (m.any_positive)
      out += " > 0 (any positive rate; unbounded at 0)";
    else if (m.band.converges_at == 0.0)
      out += ": any, the other sensors cover its modes";
    else
      out += " >= " + liveNumber(m.band.converges_at);
  }
  else
  {
    out += " in";
    for (const RateInterval& r : m.stable)
      out += " [" + liveNumber(r.lower) + ", " + liveNumber(r.upper) + "]";
    if (m.stable.empty())
      out += " no interval";
  }
  return out + " (now " + liveNumber(m.value) + ")";
}

/// Margins need an estimate for every sensor.
bool everySensorEstimated(const JointLinkStatus& js)
{
  for (const SensorLinkEstimate& e : js.sensors)
    if (e.arrival.trials == 0)
      return false;
  return !js.sensors.empty();
}

bool sameLinks(const std::vector<LinkModel>& a, const std::vector<LinkModel>& b)
{
  if (a.size() != b.size())
    return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (a[i].kind != b[i].kind || a[i].arrival != b[i].arrival || a[i].p != b[i].p || a[i].r != b[i].r ||
        a[i].loss_bad != b[i].loss_bad || a[i].loss_good != b[i].loss_good)
      return false;
  return true;
}

/// The states that sensor `s` alone measures (a column of C non-zero in its rows and in no other
/// sensor's), by name: what its link alone keeps bounded.
std::string statesOnlyMeasuredBy(const Model& m, std::size_t s)
{
  const Sensor& own = m.sensors[s];
  std::string out;
  for (int j = 0; j < m.n(); ++j)
  {
    if (m.C.block(own.offset, j, own.size, 1).isZero(0.0))
      continue;
    bool others = false;
    for (std::size_t t = 0; t < m.sensors.size() && !others; ++t)
      others = t != s && !m.C.block(m.sensors[t].offset, j, m.sensors[t].size, 1).isZero(0.0);
    if (others)
      continue;
    out +=
        (out.empty() ? "" : ", ") + (static_cast<int>(m.states.size()) == m.n() ? m.states[static_cast<std::size_t>(j)]
                                                                                : "state " + std::to_string(j));
  }
  return out;
}

}  // namespace

/// The last evaluation: the whole report for a window version, and the per-sensor margins for a
/// set of estimated links (the verdicts themselves are cheap once the model's part is done).
struct LiveStability::Cache
{
  std::mutex mutex;
  bool has_report = false;
  std::uint64_t generation = 0;
  LiveStabilityReport report;
  bool has_margins = false;
  std::vector<LinkModel> margin_links;
  std::vector<SensorMargin> margins;
  std::uint64_t epoch = 0;
  std::vector<std::map<std::uint64_t, double>> gan_liu;  ///< per sensor: lambda_m by block index
};

LiveStability::LiveStability(const Model& model, const EstimatorSettings& settings, const LiveStabilityOptions& options)
  : model_(std::make_shared<const Model>(model)),
    settings_(settings),
    options_(options),
    joint_(*model_, options.window, options.markov, options.min_samples),
    cache_(std::make_shared<Cache>())
{
  cache_->gan_liu.resize(model.sensors.size());
  samples_.assign(model.sensors.size(), 0);
  gan_liu_.resize(model.sensors.size());
  for (std::size_t si = 0; si < model.sensors.size(); ++si)
  {
    const Sensor& sensor = model.sensors[si];
    if (sensor.size == 1)
      gan_liu_[si] = std::make_shared<const GanLiuBlocks>(model.A, model.C.middleRows(sensor.offset, 1),
                                                          model.R(sensor.offset, sensor.offset), model.n(), 2);
  }
  Qn_ = model.B * model.Q * model.B.transpose();
  if (!options.markov && model.sensors.size() == 1)
  {
    AnalysisOptions only_model;
    only_model.per_sensor = false;
    thresholds_ = linkThresholds(analyzeStability(model, nullptr, &settings, only_model), options.min_samples);
  }
  // Gan and Liu's Theorem 1 is about the Kalman filter of one scalar output along the sequence it
  // actually ran: kfio with late data dropped (a rewind rewrites the past).
  if (settings.algorithm == Algorithm::KFIO && model.sensors.size() == 1 && model.sensors[0].size == 1 &&
      options.late_data_dropped)
  {
    try
    {
      theorem1_.emplace(model.A, Qn_, model.C, model.R(0, 0), model.n());
      theorem1_->start(predictedFromPrior());
    }
    catch (const std::invalid_argument& e)
    {
      theorem1_.reset();
      theorem1_note_ = std::string("not applicable: ") + e.what();
    }
  }
  else
  {
    theorem1_note_ = "not applicable: checked for kfio on one scalar sensor with late_policy drop";
  }
}

Eigen::MatrixXd LiveStability::predictedFromPrior() const
{
  return model_->A * model_->P0 * model_->A.transpose() + Qn_;
}

void LiveStability::add(const std::vector<bool>& arrived, bool gamma, const Eigen::MatrixXd& P, bool restarted)
{
  ++generation_;
  for (std::uint64_t& count : samples_)
    ++count;
  joint_.add(arrived);
  addTheorem1(gamma, P, restarted);
}

void LiveStability::add(const std::vector<bool>& arrived, const std::vector<bool>& due, bool gamma,
                        const Eigen::MatrixXd& P, bool restarted)
{
  ++generation_;
  joint_.add(arrived, due);
  for (std::size_t si = 0; si < samples_.size(); ++si)
    samples_[si] += due[si] ? 1 : 0;
  addTheorem1(gamma, P, restarted);
}

void LiveStability::addTheorem1(bool gamma, const Eigen::MatrixXd& P, bool restarted)
{
  if (!theorem1_)
    return;
  if (restarted)
    theorem1_->start(predictedFromPrior());
  else
    theorem1_->add(gamma, model_->A * P * model_->A.transpose() + Qn_);
}

void LiveStability::clear()
{
  ++generation_;
  ++epoch_;
  std::fill(samples_.begin(), samples_.end(), 0);
  joint_.clear();
  if (theorem1_)
    theorem1_->start(predictedFromPrior());
}

LiveStability LiveStability::relinearised(const Model& local) const
{
  LiveStability out(local, settings_, options_);
  out.takeWindows(*this);
  return out;
}

void LiveStability::takeWindows(const LiveStability& from)
{
  joint_.takeWindows(from.joint_);
  generation_ = from.generation_;
  epoch_ = from.epoch_;
  samples_ = from.samples_;
}

LiveStabilityReport LiveStability::evaluate() const
{
  std::unique_lock<std::mutex> lock(cache_->mutex, std::defer_lock);
  if (options_.cache)
  {
    lock.lock();
    if (cache_->has_report && cache_->generation == generation_)
      return cache_->report;
  }
  LiveStabilityReport out;
  const JointLinkStatus js = joint_.evaluate();
  out.status = js.status;
  auto add = [&out](const std::string& key, const std::string& value) { out.values.emplace_back(key, value); };
  add("link model", options_.markov ? "markov (failure p and recovery r estimated per sensor)"
                                    : "iid (arrival rate estimated per sensor)");
  // Every sensor's arrival rate and on/off rates (p and r, estimated from the same window in
  // either mode); the link model says which of them the verdicts use.
  for (const SensorLinkEstimate& e : js.sensors)
  {
    add(e.sensor + " arrival rate", rate(e.arrival, "samples"));
    add(e.sensor + " failure rate p", rate(e.failure, "transitions"));
    add(e.sensor + " recovery rate r", rate(e.recovery, "transitions"));
    SensorLinkFigures f;
    f.sensor = e.sensor;
    f.arrival = e.arrival;
    f.failure = e.failure;
    f.recovery = e.recovery;
    out.sensors.push_back(f);
  }
  // Per sensor: the rate it needs, the other links at their estimates (the same bisection or scan
  // as analyze's per-sensor margins).
  if (everySensorEstimated(js))
  {
    std::vector<SensorMargin> fresh;
    const std::vector<SensorMargin>* margins = &fresh;
    if (!options_.cache)
      fresh = joint_.verdicts().margins(js.point_links, true);
    else
    {
      if (!cache_->has_margins || !sameLinks(cache_->margin_links, js.point_links))
      {
        cache_->margins = joint_.verdicts().margins(js.point_links, true);
        cache_->margin_links = js.point_links;
        cache_->has_margins = true;
      }
      margins = &cache_->margins;
    }
    for (std::size_t i = 0; i < margins->size() && i < out.sensors.size(); ++i)
    {
      out.sensors[i].needs = describeNeed((*margins)[i]);
      out.sensors[i].margin = (*margins)[i].margin;
      add(js.sensors[i].sensor + " needs", out.sensors[i].needs);
      add(js.sensors[i].sensor + " margin", liveNumber(out.sensors[i].margin));
    }
    // A sensor below the rate it needs: the status names what only it measures (an IMU that
    // delivers nothing: the attitude).
    if (out.status.level != LinkCondition::Level::OK)
      for (std::size_t i = 0; i < margins->size() && i < model_->sensors.size(); ++i)
      {
        const SensorMargin& g = (*margins)[i];
        const std::string alone = statesOnlyMeasuredBy(*model_, i);
        if (std::isfinite(g.margin) && g.margin <= 0.0 && !alone.empty())
          out.status.message += "; sensor '" + js.sensors[i].sensor + "' is below the rate it needs (" +
                                describeNeed(g) + "): " + alone + ", which only it measures, are not bounded";
      }
  }
  add("verdict at the estimates", toString(js.point.kind) + ": " + js.point.reason);
  if (!joint_.verdicts().deadReckoned().empty())
    add("dead-reckoned", joint_.verdicts().deadReckoned());
  add("verdict at the low ends", toString(js.pessimistic.kind));
  add("verdict at the high ends", toString(js.optimistic.kind));
  if (thresholds_ && !js.sensors.empty())
  {
    const RateEstimate& r = js.sensors[0].arrival;
    add("quantity", thresholds_->quantity);
    add("estimate", liveNumber(r.value));
    add("95% lower", liveNumber(r.lower));
    add("95% upper", liveNumber(r.upper));
    add("samples", std::to_string(r.trials));
    add("critical (necessary)", liveNumber(thresholds_->necessary));
    add("critical (sufficient)", liveNumber(thresholds_->sufficient));
    add("margin", liveNumber(r.value - thresholds_->sufficient));
  }
  // Gan and Liu: evidence for any loss pattern (no i.i.d. or Markov assumption) from each scalar
  // sensor's window; A3 is very conservative, so a failure is no evidence of instability. The
  // blocks are aligned on the sensor's sample count, so a block keeps its place as the window
  // slides and is computed once (the cache keeps it while it is in the window).
  const Model& m = *model_;
  if (options_.cache && cache_->epoch != epoch_)
  {
    for (auto& blocks : cache_->gan_liu)
      blocks.clear();
    cache_->epoch = epoch_;
  }
  for (std::size_t si = 0; si < m.sensors.size(); ++si)
  {
    const Sensor& sensor = m.sensors[si];
    if (!gan_liu_[si])
      continue;
    const GanLiuBlocks& gb = *gan_liu_[si];
    const std::vector<bool> window = joint_.sensor(si).window();
    const std::uint64_t h = static_cast<std::uint64_t>(gb.h());
    const std::uint64_t start = samples_[si] - window.size();                 // the window's first sample
    const std::uint64_t first = (start + h - 1) / h, end = samples_[si] / h;  // whole blocks [first, end)
    if (first >= end)
      continue;
    std::map<std::uint64_t, double> fresh;
    std::map<std::uint64_t, double>& known = options_.cache ? cache_->gan_liu[si] : fresh;
    known.erase(known.begin(), known.lower_bound(first));
    std::vector<double> lambdas;
    for (std::uint64_t b = first; b < end; ++b)
    {
      auto it = known.find(b);
      if (it == known.end())
        it = known.emplace(b, gb.block(window, static_cast<std::size_t>(b * h - start))).first;
      lambdas.push_back(it->second);
    }
    const ExcitationReport gl = gb.report(lambdas);
    add(sensor.name + " Gan-Liu excitation", "lambda " + liveNumber(gl.lambda) + " (h = " + std::to_string(gl.h) +
                                                 ", smallest block " + liveNumber(gl.lambda_block) + ")");
    add(sensor.name + " Gan-Liu A3 (printed / proof)",
        "p = 1: " + liveNumber(gl.a3[0].printed) + " / " + liveNumber(gl.a3[0].proof) +
            "; p = 2: " + liveNumber(gl.a3[1].printed) + " / " + liveNumber(gl.a3[1].proof));
    add(sensor.name + " Gan-Liu verdict", toString(gl.verdict.kind) + ": " + gl.verdict.reason);
  }
  if (theorem1_)
  {
    const Theorem1Check& t1 = theorem1_->check();
    const bool failed = theorem1_->violations() > 0;
    add("Gan-Liu Theorem 1 (runtime invariant)", std::string(failed ? "FAILED" : "holds") + " over " +
                                                     std::to_string(t1.blocks) + " blocks (worst lhs - rhs " +
                                                     liveNumber(t1.worst) + ")");
    if (failed && out.status.level == LinkCondition::Level::OK)
    {
      out.status.level = LinkCondition::Level::WARN;
      out.status.message += "; Gan and Liu's Theorem 1 inequality failed (a numerical problem of the filter)";
    }
  }
  else
  {
    add("Gan-Liu Theorem 1 (runtime invariant)", theorem1_note_);
  }
  if (options_.cache)
  {
    cache_->report = out;
    cache_->generation = generation_;
    cache_->has_report = true;
  }
  return out;
}

}  // namespace networked_estimation
