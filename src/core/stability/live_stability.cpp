// The live link stability diagnostic (live_stability.hpp).
#include "networked_estimation/stability/live_stability.hpp"

#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "networked_estimation/stability/stability.hpp"

namespace networked_estimation
{
namespace
{

std::string number(double v)
{
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

std::string rate(const RateEstimate& e, const char* unit)
{
  char buf[128];
  std::snprintf(buf, sizeof buf, "%g [%g, %g] (%zu %s)", e.value, e.lower, e.upper, e.trials, unit);
  return buf;
}

/// "arrival rate >= 0.111 (now 0.5)", the stable intervals, or why there is no such rate.
std::string describeNeed(const SensorMargin& m)
{
  if (m.quantity.empty())
    return m.note;
  std::string out = m.quantity;
  if (m.half_line)
  {
    if (!std::isfinite(m.band.converges_at))
      return out + ": " + m.note;
    out += " >= " + number(m.band.converges_at);
  }
  else
  {
    out += " in";
    for (const RateInterval& r : m.stable)
      out += " [" + number(r.lower) + ", " + number(r.upper) + "]";
    if (m.stable.empty())
      out += " no interval";
  }
  return out + " (now " + number(m.value) + ")";
}

/// Margins need an estimate for every sensor.
bool everySensorEstimated(const JointLinkStatus& js)
{
  for (const SensorLinkEstimate& e : js.sensors)
    if (e.arrival.trials == 0)
      return false;
  return !js.sensors.empty();
}

}  // namespace

LiveStability::LiveStability(const Model& model, const EstimatorSettings& settings, const LiveStabilityOptions& options)
  : model_(&model), options_(options), joint_(model, options.window, options.markov, options.min_samples)
{
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
  joint_.add(arrived);
  addTheorem1(gamma, P, restarted);
}

void LiveStability::add(const std::vector<bool>& arrived, const std::vector<bool>& due, bool gamma,
                        const Eigen::MatrixXd& P, bool restarted)
{
  joint_.add(arrived, due);
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
  joint_.clear();
  if (theorem1_)
    theorem1_->start(predictedFromPrior());
}

LiveStabilityReport LiveStability::evaluate() const
{
  LiveStabilityReport out;
  const JointLinkStatus js = joint_.evaluate();
  out.status = js.status;
  auto add = [&out](const std::string& key, const std::string& value) { out.values.emplace_back(key, value); };
  add("link model", options_.markov ? "markov (failure p and recovery r estimated per sensor)"
                                    : "iid (arrival rate estimated per sensor)");
  for (const SensorLinkEstimate& e : js.sensors)
  {
    if (options_.markov)
    {
      add(e.sensor + " failure rate p", rate(e.failure, "transitions"));
      add(e.sensor + " recovery rate r", rate(e.recovery, "transitions"));
    }
    else
    {
      add(e.sensor + " arrival rate", rate(e.arrival, "samples"));
    }
  }
  // Per sensor: the rate it needs, the other links at their estimates (the same bisection or scan
  // as analyze's per-sensor margins).
  if (everySensorEstimated(js))
  {
    AnalysisOptions margin_options;
    margin_options.per_sensor = false;
    const std::vector<SensorMargin> margins = sensorMargins(*model_, js.point_links, margin_options);
    for (std::size_t i = 0; i < margins.size(); ++i)
      add(js.sensors[i].sensor + " needs", describeNeed(margins[i]));
  }
  add("verdict at the estimates", toString(js.point.kind) + ": " + js.point.reason);
  add("verdict at the low ends", toString(js.pessimistic.kind));
  add("verdict at the high ends", toString(js.optimistic.kind));
  if (thresholds_ && !js.sensors.empty())
  {
    const RateEstimate& r = js.sensors[0].arrival;
    add("quantity", thresholds_->quantity);
    add("estimate", number(r.value));
    add("95% lower", number(r.lower));
    add("95% upper", number(r.upper));
    add("samples", std::to_string(r.trials));
    add("critical (necessary)", number(thresholds_->necessary));
    add("critical (sufficient)", number(thresholds_->sufficient));
    add("margin", number(r.value - thresholds_->sufficient));
  }
  // Gan and Liu: evidence for any loss pattern (no i.i.d. or Markov assumption) from each scalar
  // sensor's window; A3 is very conservative, so a failure is no evidence of instability.
  const Model& m = *model_;
  for (std::size_t si = 0; si < m.sensors.size(); ++si)
  {
    const Sensor& sensor = m.sensors[si];
    const std::vector<bool> window = joint_.sensor(si).window();
    if (sensor.size != 1 || window.size() < static_cast<std::size_t>(m.n()))
      continue;
    const ExcitationReport gl =
        ganLiuTrace(m.A, m.C.middleRows(sensor.offset, 1), m.R(sensor.offset, sensor.offset), window, m.n(), 2);
    add(sensor.name + " Gan-Liu excitation", "lambda " + number(gl.lambda) + " (h = " + std::to_string(gl.h) +
                                                 ", smallest block " + number(gl.lambda_block) + ")");
    add(sensor.name + " Gan-Liu A3 (printed / proof)", "p = 1: " + number(gl.a3[0].printed) + " / " +
                                                           number(gl.a3[0].proof) + "; p = 2: " +
                                                           number(gl.a3[1].printed) + " / " + number(gl.a3[1].proof));
    add(sensor.name + " Gan-Liu verdict", toString(gl.verdict.kind) + ": " + gl.verdict.reason);
  }
  if (theorem1_)
  {
    const Theorem1Check& t1 = theorem1_->check();
    const bool failed = theorem1_->violations() > 0;
    add("Gan-Liu Theorem 1 (runtime invariant)", std::string(failed ? "FAILED" : "holds") + " over " +
                                                     std::to_string(t1.blocks) + " blocks (worst lhs - rhs " +
                                                     number(t1.worst) + ")");
    if (failed && out.status.level == LinkStatus::Level::OK)
    {
      out.status.level = LinkStatus::Level::WARN;
      out.status.message += "; Gan and Liu's Theorem 1 inequality failed (a numerical problem of the filter)";
    }
  }
  else
  {
    add("Gan-Liu Theorem 1 (runtime invariant)", theorem1_note_);
  }
  return out;
}

}  // namespace networked_estimation
