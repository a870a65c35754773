// The verdict for the links a robot has (measured_links.hpp).
#include "networked_estimation/link/measured_links.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "networked_estimation/common/error.hpp"
#include "networked_estimation/io/json_writer.hpp"
#include "networked_estimation/link/link_trace.hpp"

namespace networked_estimation
{
namespace measured_links_detail
{

std::string fmt(double v)
{
  if (std::isnan(v))
    return "n/a";
  std::ostringstream os;
  os.precision(4);
  os << v;
  return os.str();
}

std::string range(double value, double lower, double upper)
{
  return fmt(value) + " [" + fmt(lower) + ", " + fmt(upper) + "]";
}

/// The fitted loss model's parameters with their intervals, in words.
std::string describeFit(const LossFit& f)
{
  if (f.chosen == "bernoulli")
    return "bernoulli, loss " +
           range(1.0 - f.estimate.arrival.value, 1.0 - f.estimate.arrival.upper, 1.0 - f.estimate.arrival.lower);
  if (f.chosen == "gilbert")
    return "gilbert, p " + range(f.estimate.failure.value, f.estimate.failure.lower, f.estimate.failure.upper) +
           ", r " + range(f.estimate.recovery.value, f.estimate.recovery.lower, f.estimate.recovery.upper);
  const GilbertElliottFit& g = f.ge;
  return "gilbert_elliott, p " + range(g.p.value, g.p.lower, g.p.upper) + ", r " +
         range(g.r.value, g.r.lower, g.r.upper) + ", loss_good " +
         range(g.loss_good.value, g.loss_good.lower, g.loss_good.upper) + ", loss_bad " +
         range(g.loss_bad.value, g.loss_bad.lower, g.loss_bad.upper);
}

std::size_t sensorOf(const Model& model, const std::string& name, const std::string& what)
{
  std::string names;
  for (std::size_t i = 0; i < model.sensors.size(); ++i)
  {
    if (model.sensors[i].name == name)
      return i;
    names += (i ? ", " : "") + model.sensors[i].name;
  }
  throw ConfigError(what + ": '" + name + "' is not a sensor of model '" + model.name + "' (its sensors: " + names +
                    ")");
}

void jverdict(JsonWriter& w, const Verdict& v)
{
  w.beginObject().member("kind", toString(v.kind)).member("reason", v.reason).endObject();
}

}  // namespace measured_links_detail

std::vector<MeasuredLink> fitBagLinks(const Model& model, const std::string& bag, const std::string& every_topic,
                                      const std::vector<std::string>& sensor_topics, SensorLinks& links,
                                      const TraceOptions& options)
{
  using namespace measured_links_detail;
  const std::size_t S = model.sensors.size();
  std::vector<std::string> topic_of(S);
  std::vector<std::string> how(S);
  for (const std::string& spec : sensor_topics)
  {
    const std::string::size_type eq = spec.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == spec.size())
      throw ConfigError("--bag-topic '" + spec + "': expected SENSOR=TOPIC");
    const std::string name = spec.substr(0, eq);
    const std::size_t s = sensorOf(model, name, "--bag-topic " + spec);
    if (!topic_of[s].empty())
      throw ConfigError("--bag-topic " + spec + ": sensor '" + name + "' has a topic already (" + topic_of[s] + ")");
    if (links.origin[s].find("(--channel " + name + "=") != std::string::npos)
      throw ConfigError("--bag-topic " + spec + ": sensor '" + name + "' has a --channel of its own already");
    topic_of[s] = spec.substr(eq + 1);
    how[s] = "--bag-topic " + spec;
  }
  if (!every_topic.empty())
  {
    if (links.common)
      throw ConfigError("--topic " + every_topic +
                        " and a plain --channel both give every sensor a link: give one of them, or the others as "
                        "--channel NAME=FILE / --bag-topic SENSOR=TOPIC");
    for (std::size_t s = 0; s < S; ++s)
      if (topic_of[s].empty() && links.origin[s].find("(--channel ") == std::string::npos)
      {
        topic_of[s] = every_topic;
        how[s] = "--topic " + every_topic;
      }
  }
  // One bag reading for every topic, one fit per topic.
  std::vector<std::string> topics;
  for (const std::string& t : topic_of)
    if (!t.empty() && std::find(topics.begin(), topics.end(), t) == topics.end())
      topics.push_back(t);
  if (topics.empty())
    throw ConfigError("--bag " + bag +
                      ": no sensor is given a topic (--topic T for every sensor, --bag-topic "
                      "SENSOR=TOPIC for one)");
  const std::vector<LinkRecord> records = readBagLinks(bag, topics);
  std::vector<LinkFit> fits;
  for (const LinkRecord& r : records)
    fits.push_back(fitLink(analyseLink(r, options)));
  std::vector<MeasuredLink> out;
  for (std::size_t s = 0; s < S; ++s)
  {
    if (topic_of[s].empty())
      continue;
    const std::size_t t =
        static_cast<std::size_t>(std::find(topics.begin(), topics.end(), topic_of[s]) - topics.begin());
    MeasuredLink m;
    m.sensor = model.sensors[s].name;
    m.topic = topic_of[s];
    m.fit = fits[t];
    links.link[s] = m.fit.channel;
    links.origin[s] = m.sensor + ": fitted from " + bag + ", topic " + m.topic + " (" + how[s] +
                      "): " + m.fit.loss.chosen + " by BIC";
    out.push_back(m);
  }
  if (!every_topic.empty())
  {
    const std::size_t t =
        static_cast<std::size_t>(std::find(topics.begin(), topics.end(), every_topic) - topics.begin());
    links.common = fits[t].channel;
  }
  return out;
}

MeasuredVerdict measuredVerdict(const Model& model, const SensorLinks& links, const std::vector<MeasuredLink>& measured)
{
  MeasuredVerdict v;
  auto at = [&](IntervalEnd end)
  {
    std::vector<std::optional<ChannelSettings>> l = links.link;
    for (const MeasuredLink& m : measured)
      for (std::size_t s = 0; s < model.sensors.size(); ++s)
        if (model.sensors[s].name == m.sensor)
          l[s] = settingsOf(fittedLink(m.fit.loss, end), m.fit.channel);
    return verdictOnly(model, l);
  };
  v.point = at(IntervalEnd::POINT);
  v.pessimistic = at(IntervalEnd::PESSIMISTIC);
  v.optimistic = at(IntervalEnd::OPTIMISTIC);
  const Verdict::Kind p = v.point.links_verdict.kind, bad = v.pessimistic.links_verdict.kind,
                      good = v.optimistic.links_verdict.kind;
  v.bounded_at_fit = p == Verdict::Kind::STABLE;
  v.bounded_at_worst_end = bad == Verdict::Kind::STABLE;
  if (p == Verdict::Kind::STABLE && bad == Verdict::Kind::STABLE)
    v.summary = "bounded at the fitted links and at the intervals' worst ends";
  else if (p == Verdict::Kind::STABLE)
    v.summary = "bounded at the fit, not at its worst end: record longer or improve the link";
  else if (good == Verdict::Kind::UNSTABLE)
    v.summary = "unbounded at the fit and even at the intervals' best ends: improve the link";
  else if (p == Verdict::Kind::UNSTABLE)
    v.summary = "unbounded at the fit, not at the intervals' best ends: record longer or improve the link";
  else
    v.summary = toString(p) + " at the fit: " + v.point.links_verdict.reason;
  return v;
}

std::string measuredText(const std::vector<MeasuredLink>& measured, const MeasuredVerdict& v)
{
  using namespace measured_links_detail;
  std::ostringstream os;
  os << "[measured links: fitted from the bag (fit_link's fit, 95 % intervals); the links' verdict at the fits and "
        "at the intervals' ends]\n";
  for (const MeasuredLink& m : measured)
  {
    const LinkStatistics& s = m.fit.stats;
    os << "  " << m.sensor << ": topic " << m.topic << ", " << s.expected << " expected messages at "
       << fmt(1.0 / m.fit.trace.period) << " Hz, loss rate " << fmt(s.loss_rate) << ": " << describeFit(m.fit.loss)
       << "\n";
  }
  os << "  at the fits:             " << describe(v.point.links_verdict) << "\n";
  os << "  at the worst ends:       " << describe(v.pessimistic.links_verdict) << "\n";
  os << "  at the best ends:        " << describe(v.optimistic.links_verdict) << "\n";
  os << "  measured: " << v.summary << "\n";
  return os.str();
}

std::string measuredJson(const std::vector<MeasuredLink>& measured, const MeasuredVerdict& v)
{
  using namespace measured_links_detail;
  JsonWriter w;
  w.beginObject().key("links").beginArray();
  for (const MeasuredLink& m : measured)
  {
    const LossFit& f = m.fit.loss;
    w.br(6).beginObject().member("sensor", m.sensor).member("topic", m.topic).member("model", f.chosen);
    w.member("expected", m.fit.stats.expected).member("loss_rate", m.fit.stats.loss_rate);
    w.member("rate", 1.0 / m.fit.trace.period).member("fit", describeFit(f)).endObject();
  }
  w.br(4).endArray();
  w.br(4).key("at_fit");
  jverdict(w, v.point.links_verdict);
  w.br(4).key("at_worst_end");
  jverdict(w, v.pessimistic.links_verdict);
  w.br(4).key("at_best_end");
  jverdict(w, v.optimistic.links_verdict);
  w.br(4).member("bounded_at_fit", v.bounded_at_fit).member("bounded_at_worst_end", v.bounded_at_worst_end);
  w.br(4).member("summary", v.summary);
  w.br(2).endObject();
  return w.text();
}

}  // namespace networked_estimation
