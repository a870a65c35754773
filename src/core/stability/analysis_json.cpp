// analyze's JSON documents (analysis_json.hpp).
#include "networked_estimation/stability/analysis_json.hpp"

#include <cmath>
#include <sstream>

#include "networked_estimation/common/error.hpp"
#include "networked_estimation/io/json_writer.hpp"
#include "networked_estimation/motion/linearised_model.hpp"

namespace networked_estimation
{

bool unboundedAtEveryRate(double v)
{
  return std::isinf(v) && v > 0.0;
}

Model analysedModel(const Model& loaded, const Eigen::VectorXd* at, const std::string& at_label,
                    std::string& local_note)
{
  local_note.clear();
  if (!loaded.nonlinear())
  {
    if (at)
      throw ConfigError(at_label + " is only for a model with a built-in motion (model '" + loaded.name +
                        "' is linear)");
    return loaded;
  }
  const Eigen::VectorXd x = at ? *at : loaded.x0;
  std::ostringstream period;
  period.precision(6);
  period << loaded.period;
  local_note = "; model '" + loaded.name + "' has motion " + toString(loaded.motion) +
               ": a local verdict, for its linearisation at " + (at ? at_label : std::string("x0")) + " over " +
               period.str() + " s (docs/stability.md 5)";
  return linearisedModel(loaded, x, loaded.period);
}

std::vector<TraceEvidence> traceEvidence(const Model& model, const std::vector<std::vector<std::vector<bool>>>& traces,
                                         const std::vector<std::string>& labels, int h)
{
  std::vector<TraceEvidence> out;
  std::vector<std::string> given(model.sensors.size());  // per sensor: the trace that gave its arrivals
  for (std::size_t t = 0; t < traces.size(); ++t)
  {
    const std::string label = t < labels.size() ? labels[t] : "trace " + std::to_string(t);
    for (std::size_t s = 0; s < model.sensors.size() && s < traces[t].size(); ++s)
    {
      const std::vector<bool>& arrivals = traces[t][s];
      if (arrivals.empty())
        continue;
      const Sensor& sensor = model.sensors[s];
      if (!given[s].empty())
        throw InputError("sensor '" + sensor.name + "' has two traces (" + given[s] + " and " + label +
                         "); give one per sensor");
      given[s] = label;
      TraceEvidence e;
      e.sensor = sensor.name;
      e.samples = arrivals.size();
      if (sensor.size != 1)
        e.reason = "not applicable: Gan and Liu treat a scalar output (sensor " + sensor.name + " has " +
                   std::to_string(sensor.size) + " rows)";
      else if (e.samples < static_cast<std::size_t>(h))
        e.reason = "not applicable: the trace of " + sensor.name + " has " + std::to_string(e.samples) +
                   " samples, fewer than one block of h = " + std::to_string(h);
      else
      {
        e.applicable = true;
        e.report = ganLiuTrace(model.A, model.C.middleRows(sensor.offset, 1), model.R(sensor.offset, sensor.offset),
                               arrivals, h);
      }
      out.push_back(e);
    }
  }
  return out;
}

namespace
{

void jverdict(JsonWriter& w, const Verdict& v)
{
  w.beginObject().member("kind", toString(v.kind)).member("reason", v.reason).key("numbers").beginObject();
  for (const auto& kv : v.numbers)
    w.member(kv.first, kv.second);
  w.endObject().endObject();
}

void jintervals(JsonWriter& w, const std::vector<RateInterval>& v)
{
  w.beginArray();
  for (const RateInterval& in : v)
    w.beginArray().value(in.lower).value(in.upper).endArray();
  w.endArray();
}

void jlink(JsonWriter& w, const SensorLinkReport& l, const std::string& origin)
{
  const SensorMargin& m = l.margin;
  w.beginObject().member("sensor", l.sensor).member("origin", origin);
  w.member("kind", l.lossless ? "lossless" : l.link.kind == LinkModel::Kind::IID ? "bernoulli" : "gilbert_elliott");
  w.member("arrival_rate", l.arrival_rate).member("recovery_rate", l.recovery_rate);
  if (l.link.kind == LinkModel::Kind::GILBERT_ELLIOTT)
    w.member("p", l.link.p).member("r", l.link.r);
  else
    w.key("p").null().key("r").null();
  w.member("on_off", l.link.onOff()).member("capacity", l.capacity);
  w.key("margin").beginObject().key("quantity");
  if (m.quantity.empty())
    w.null();
  else
    w.value(m.quantity);
  w.member("value", m.value).member("half_line", m.half_line).member("diverges_at", m.band.diverges_at);
  w.member("converges_at", m.band.converges_at).member("undecided_band", m.band.undecided_band);
  w.member("any_positive", m.any_positive);
  w.member("grows_regardless", m.grows_regardless).member("converges_at_observed", m.converges_at_observed);
  w.key("stable_intervals");
  jintervals(w, m.stable);
  w.member("scan_points", m.scan_points).member("margin", m.margin).member("note", m.note).endObject();
  w.member("markov_threshold", l.markov_note).endObject();
}

/// "links": one link object a sensor, each with its origin.
void jlinks(JsonWriter& w, const std::vector<SensorLinkReport>& links, const std::vector<std::string>& origins)
{
  w.br(2).key("links").beginArray();
  for (std::size_t i = 0; i < links.size(); ++i)
    jlink(w.br(4), links[i], i < origins.size() ? origins[i] : "");
  if (!links.empty())
    w.br(2);
  w.endArray();
}

void jset(JsonWriter& w, const RateAnalysis& r)
{
  w.beginObject().member("name", r.name).key("sensors").beginArray();
  for (int s : r.sensors)
    w.value(s);
  w.endArray().member("lower_bound", r.lower_bound).member("closed_form_upper", r.closed_form_upper);
  w.member("mare_diverges_at", r.mare.diverges_at).member("mare_converges_at", r.mare.converges_at);
  w.member("mare_undecided_band", r.mare.undecided_band).member("mare_note", r.mare_note);
  w.member("exact_rate", r.exact_rate).member("exact_method", r.exact_method);
  w.member("unbounded_at_every_rate", unboundedAtEveryRate(r.exact_rate));
  w.member("dead_reckoned", r.dead_reckoned).member("dead_states", r.dead_states);
  w.member("recovery_lower_bound", r.recovery_lower_bound).member("recovery_exact", r.recovery_exact);
  w.member("recovery_note", r.recovery_note).key("recovery_stable_intervals");
  jintervals(w, r.recovery_stable);
  w.key("aoe_theorem5");
  jverdict(w, r.aoe_theorem5);
  w.key("verdict");
  jverdict(w, r.verdict);
  w.key("links_verdict");
  jverdict(w, r.links_verdict);
  w.member("margin_quantity", r.margin_quantity).member("channel_value", r.channel_value);
  w.member("necessary_threshold", r.necessary_threshold).member("sufficient_threshold", r.sufficient_threshold);
  w.member("margin", r.margin).key("stable_intervals");
  jintervals(w, r.stable_intervals);
  w.key("observed");
  if (r.observed.empty())
    w.null();
  else
    jset(w, r.observed.front());
  w.endObject();
}

void jtrace(JsonWriter& w, const TraceEvidence& e)
{
  w.beginObject().member("sensor", e.sensor).member("samples", e.samples);
  if (!e.applicable)
  {
    w.key("verdict").beginObject().member("kind", "not_applicable").member("reason", e.reason).endObject();
    w.endObject();
    return;
  }
  const ExcitationReport& r = e.report;
  w.member("h", r.h).member("lambda_block_min", r.lambda_block).member("lambda", r.lambda).member("norm_A", r.norm_A);
  w.key("a3").beginArray();
  for (const ExcitationA3& a : r.a3)
    w.beginObject()
        .member("p", a.p)
        .member("printed", a.printed)
        .member("proof", a.proof)
        .member("holds", a.holds())
        .endObject();
  w.endArray().key("verdict");
  jverdict(w, r.verdict);
  w.member("caveat", ExcitationReport::caveat()).endObject();
}

}  // namespace

std::string analysisJson(const StabilityReport& rep, const std::vector<std::string>& origins,
                         const std::vector<TraceEvidence>& traces)
{
  JsonWriter w;
  w.beginObject();
  w.br(2).member("model", rep.model_name);
  w.br(2).key("eigenvalues").beginArray();
  for (int i = 0; i < rep.eigenvalues.size(); ++i)
    w.beginObject().member("re", rep.eigenvalues[i].real()).member("im", rep.eigenvalues[i].imag()).endObject();
  w.endArray();
  w.br(2).member("spectral_radius", rep.spectral_radius);
  w.br(2).member("mahler_measure", rep.mahler_measure);
  w.br(2).member("entropy", rep.entropy);
  w.br(2).member("diagonalizable", rep.diagonalizable);
  w.br(2).key("strong_observability");
  jverdict(w, rep.strong_observability);
  w.br(2).member("noise_excites_unstable_modes", rep.noise_excites_unstable_modes);
  w.br(2).member("detectable", rep.detectable);
  w.br(2).member("dead_reckoned", rep.dead_reckoned);
  w.br(2).member("dead_states", rep.dead_states);
  w.br(2).key("channel");
  if (rep.has_channel)
  {
    w.beginObject().member("kind", rep.link.kind == LinkModel::Kind::IID ? "bernoulli" : "gilbert_elliott");
    w.member("arrival_rate", rep.arrival_rate).member("recovery_rate", rep.recovery_rate);
    w.member("on_off", rep.link.onOff()).member("capacity", rep.capacity.total);
    w.member("capacity_lower", rep.capacity.lower).member("capacity_upper", rep.capacity.upper);
    w.member("capacity_note", rep.capacity_note).member("mare_at_rates", rep.mare_at_rates);
    w.member("mare_at_rates_trace", rep.mare_at_rates_trace);
    w.member("mare_at_rates_certificate", rep.mare_at_rates_certificate);
    w.member("uniform", rep.uniform_links).endObject();
  }
  else
    w.null();
  jlinks(w, rep.links, origins);
  w.br(2).member("estimator", rep.estimator);
  w.br(2).member("estimator_note", rep.estimator_note);
  w.br(2).key("rseio");
  jverdict(w, rep.rseio);
  w.br(2).key("all_sensors");
  jset(w, rep.model);
  w.br(2).key("sensors").beginArray();
  for (const RateAnalysis& r : rep.sensors)
    jset(w.br(4), r);
  w.br(2).endArray();
  w.br(2).key("gan_liu").beginArray();
  for (const TraceEvidence& e : traces)
    jtrace(w.br(4), e);
  if (!traces.empty())
    w.br(2);
  w.endArray();
  w.br(0).endObject();
  return w.text() + "\n";
}
std::string verdictJson(const std::string& model_name, const VerdictReport& rep,
                        const std::vector<std::string>& origins)
{
  JsonWriter w;
  w.beginObject();
  w.br(2).member("model", model_name);
  w.br(2).key("verdict");
  jverdict(w, rep.verdict);
  w.br(2).key("links_verdict");
  jverdict(w, rep.links_verdict);
  w.br(2).member("dead_reckoned", rep.dead_reckoned);
  w.br(2).member("dead_states", rep.dead_states);
  jlinks(w, rep.links, origins);
  w.br(0).endObject();
  return w.text() + "\n";
}

std::string designJson(const Model& model, const LinkDesign& d, const std::string& cost)
{
  JsonWriter w;
  w.beginObject();
  w.br(2).member("model", model.name);
  w.br(2).key("design").beginObject().member("cost", cost).member("growth_cap", d.growth_cap);
  w.member("applicable", d.applicable).member("note", d.note);
  if (d.applicable)
  {
    w.member("cost_value", d.cost_value).key("verdict");
    jverdict(w, d.check);
    w.member("vertices", d.vertices);
  }
  w.key("sensors").beginArray();
  for (std::size_t j = 0; j < model.sensors.size(); ++j)
  {
    w.br(4).beginObject().member("name", model.sensors[j].name);
    if (d.applicable)
      w.member("arrival_rate", d.rates[j]).member("alone", d.alone[j]);
    w.endObject();
  }
  if (!model.sensors.empty())
    w.br(2);
  w.endArray().endObject();
  w.br(0).endObject();
  return w.text() + "\n";
}

}  // namespace networked_estimation
