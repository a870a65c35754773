// Sensor schedules: the model file's `schedule` map, its checks, and what reports say of it
// (schedule.hpp, schedule_config.hpp).
#include "config/schedule_config.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <sstream>

namespace networked_estimation
{

int Schedule::period() const
{
  return kind == Kind::PERIODIC ? static_cast<int>(pattern.size()) : 1;
}

int Schedule::maxTransmitting() const
{
  const std::vector<std::vector<bool>>& sets = kind == Kind::PERIODIC ? pattern : subsets;
  int most = 0;
  for (const std::vector<bool>& s : sets)
    most = std::max(most, static_cast<int>(std::count(s.begin(), s.end(), true)));
  return most;
}

double Schedule::transmitFraction(std::size_t sensor) const
{
  if (kind == Kind::PERIODIC)
  {
    double on = 0.0;
    for (const std::vector<bool>& step : pattern)
      on += step[sensor] ? 1.0 : 0.0;
    return on / static_cast<double>(pattern.size());
  }
  if (kind == Kind::RANDOM)
  {
    double on = 0.0;
    for (std::size_t i = 0; i < subsets.size(); ++i)
      on += subsets[i][sensor] ? initial[static_cast<Eigen::Index>(i)] : 0.0;
    return on;
  }
  return 1.0;
}

namespace
{

std::string setText(const std::vector<bool>& set, const std::vector<std::string>& names)
{
  std::string out = "[";
  for (std::size_t s = 0; s < set.size(); ++s)
    if (set[s])
      out += (out.size() > 1 ? ", " : "") + (s < names.size() ? names[s] : std::to_string(s));
  return out + "]";
}

}  // namespace

std::string Schedule::describe(const std::vector<std::string>& names) const
{
  std::ostringstream os;
  if (kind == Kind::NONE)
    return "none (every sensor transmits at every step)";
  if (kind == Kind::PERIODIC)
  {
    os << "periodic, tau = " << pattern.size() << ":";
    for (const std::vector<bool>& step : pattern)
      os << " " << setText(step, names);
    return os.str();
  }
  os << (markov ? "random (Markov chain over " : "random (i.i.d. over ") << subsets.size() << " subsets):";
  for (std::size_t i = 0; i < subsets.size(); ++i)
    os << " " << setText(subsets[i], names) << " " << detail::formatNumber(initial[static_cast<Eigen::Index>(i)], 6);
  return os.str();
}

namespace detail
{
namespace
{

/// A list of sensor names -> mask; `key` is e.g. "schedule.pattern[1]".
std::vector<bool> parseSet(const Reader& in, const YAML::Node& node, const std::string& key,
                           const std::vector<Sensor>& sensors)
{
  if (!node.IsSequence())
    in.fail(node, key, "expected a list of sensor names (e.g. [gnss, camera]; [] for none), found " + describe(node));
  std::vector<std::string> names;
  for (const Sensor& s : sensors)
    names.push_back(s.name);
  std::vector<bool> mask(sensors.size(), false);
  for (std::size_t i = 0; i < node.size(); ++i)
  {
    const std::string name = in.string(node[i], indexKey(key, i));
    const auto it = std::find(names.begin(), names.end(), name);
    if (it == names.end())
      in.fail(node[i], indexKey(key, i),
              "'" + name + "' is not a sensor of the model (sensors: " + joinList(names) + ")");
    const std::size_t s = static_cast<std::size_t>(it - names.begin());
    if (mask[s])
      in.fail(node[i], indexKey(key, i), "sensor '" + name + "' listed twice");
    mask[s] = true;
  }
  return mask;
}

/// Stationary distribution of a row-stochastic matrix (left Perron vector), by power iteration on
/// the lazy chain (aperiodic, same stationary law); NaN entries when it does not settle.
Eigen::VectorXd stationary(const Eigen::MatrixXd& T)
{
  const Eigen::Index K = T.rows();
  // Unique iff the eigenvalue 1 is simple (one closed class of subsets).
  const Eigen::VectorXcd ev = T.eigenvalues();
  int ones = 0;
  for (Eigen::Index i = 0; i < ev.size(); ++i)
    ones += std::abs(ev[i] - std::complex<double>(1.0, 0.0)) < 1e-9 ? 1 : 0;
  if (ones != 1)
    return Eigen::VectorXd::Constant(K, std::nan(""));
  const Eigen::MatrixXd lazy = 0.5 * (T + Eigen::MatrixXd::Identity(K, K));
  Eigen::RowVectorXd pi = Eigen::RowVectorXd::Constant(K, 1.0 / static_cast<double>(K));
  for (int it = 0; it < 100000; ++it)
  {
    const Eigen::RowVectorXd next = pi * lazy;
    const double change = (next - pi).cwiseAbs().sum();
    pi = next;
    if (change < 1e-15)
      return pi.transpose();
  }
  return Eigen::VectorXd::Constant(K, std::nan(""));
}

/// Whether no set names a sensor.
bool noneScheduled(const std::vector<std::vector<bool>>& sets)
{
  for (const std::vector<bool>& set : sets)
    for (bool on : set)
      if (on)
        return false;
  return true;
}

}  // namespace

Schedule parseSchedule(const Reader& in, const YAML::Node& node, const std::vector<Sensor>& sensors)
{
  in.requireMap(node, "schedule");
  in.checkKeys(node, "schedule", {"pattern", "subsets", "probabilities", "transition"});
  Schedule sch;
  if (node["pattern"])
  {
    for (const char* other : {"subsets", "probabilities", "transition"})
      if (node[other])
        in.fail(node[other], std::string("schedule.") + other,
                "cannot be combined with schedule.pattern (a periodic schedule is a pattern; a random one is "
                "subsets with probabilities or a transition matrix)");
    const YAML::Node p = node["pattern"];
    if (!p.IsSequence() || p.size() == 0)
      in.fail(p, "schedule.pattern",
              "expected a non-empty list of steps, each a list of sensor names (e.g. [[gnss], [camera]]), found " +
                  describe(p));
    sch.kind = Schedule::Kind::PERIODIC;
    for (std::size_t t = 0; t < p.size(); ++t)
      sch.pattern.push_back(parseSet(in, p[t], indexKey("schedule.pattern", t), sensors));
    if (noneScheduled(sch.pattern))
      in.fail(p, "schedule.pattern",
              "no step schedules a sensor (every step is []): the estimator would never receive a measurement; "
              "name at least one sensor in some step");
  }
  else
  {
    const YAML::Node s = in.require(node, "schedule", "subsets", " (or give schedule.pattern for a periodic schedule)");
    if (!s.IsSequence() || s.size() == 0)
      in.fail(s, "schedule.subsets",
              "expected a non-empty list of subsets, each a list of sensor names, found " + describe(s));
    sch.kind = Schedule::Kind::RANDOM;
    for (std::size_t i = 0; i < s.size(); ++i)
      sch.subsets.push_back(parseSet(in, s[i], indexKey("schedule.subsets", i), sensors));
    if (noneScheduled(sch.subsets))
      in.fail(s, "schedule.subsets",
              "every subset is []: the estimator would never receive a measurement; name at least one sensor in "
              "some subset");
    const int K = static_cast<int>(s.size());
    const bool probs = static_cast<bool>(node["probabilities"]), trans = static_cast<bool>(node["transition"]);
    if (probs == trans)
      in.fail(node, "schedule",
              probs ? "give either probabilities (i.i.d.) or transition (Markov), not both"
                    : "a random schedule needs probabilities (i.i.d.) or transition (Markov chain over the subsets)");
    if (probs)
    {
      const Eigen::VectorXd p =
          in.vector(node["probabilities"], "schedule.probabilities", K, std::to_string(K) + " subsets");
      for (int i = 0; i < K; ++i)
        if (p[i] < 0.0 || p[i] > 1.0)
          in.fail(node["probabilities"], indexKey("schedule.probabilities", static_cast<std::size_t>(i)),
                  "expected a probability in [0, 1], found " + formatNumber(p[i]));
      if (std::abs(p.sum() - 1.0) > 1e-9)
        in.fail(node["probabilities"], "schedule.probabilities",
                "the probabilities must sum to 1, found " + formatNumber(p.sum()));
      sch.transition = Eigen::VectorXd::Ones(K) * p.transpose();
      sch.initial = p;
    }
    else
    {
      sch.markov = true;
      sch.transition = in.matrix(node["transition"], "schedule.transition", K, K, std::to_string(K) + " subsets");
      for (int i = 0; i < K; ++i)
      {
        for (int j = 0; j < K; ++j)
          if (sch.transition(i, j) < 0.0 || sch.transition(i, j) > 1.0)
            in.fail(node["transition"], "schedule.transition",
                    "entry (" + std::to_string(i) + "," + std::to_string(j) +
                        "): expected a probability in [0, 1], found " + formatNumber(sch.transition(i, j)));
        if (std::abs(sch.transition.row(i).sum() - 1.0) > 1e-9)
          in.fail(node["transition"], "schedule.transition",
                  "row " + std::to_string(i) + " must sum to 1 (rows are the current subset), found " +
                      formatNumber(sch.transition.row(i).sum()));
      }
      sch.initial = stationary(sch.transition);
      if (!sch.initial.allFinite())
        in.fail(node["transition"], "schedule.transition", "the chain has no unique stationary distribution");
    }
  }
  return sch;
}

std::string scheduleProblem(const Schedule& sch, std::size_t S)
{
  if (sch.kind == Schedule::Kind::NONE)
    return "";
  const std::vector<std::vector<bool>>& sets = sch.kind == Schedule::Kind::PERIODIC ? sch.pattern : sch.subsets;
  const std::string key = sch.kind == Schedule::Kind::PERIODIC ? "schedule.pattern" : "schedule.subsets";
  if (sets.empty())
    return key + ": expected at least one entry";
  for (std::size_t i = 0; i < sets.size(); ++i)
    if (sets[i].size() != S)
      return indexKey(key, i) + ": expected a mask over " + std::to_string(S) + " sensors, found " +
             std::to_string(sets[i].size());
  if (sch.kind == Schedule::Kind::RANDOM)
  {
    const Eigen::Index K = static_cast<Eigen::Index>(sets.size());
    if (sch.transition.rows() != K || sch.transition.cols() != K)
      return "schedule.transition: expected " + dims(K, K) + ", found " +
             dims(sch.transition.rows(), sch.transition.cols());
    if (!sch.transition.allFinite() || (sch.transition.array() < 0.0).any() ||
        ((sch.transition.rowwise().sum().array() - 1.0).abs() > 1e-9).any())
      return "schedule.transition: expected a row-stochastic matrix";
    if (sch.initial.size() != K || !sch.initial.allFinite() || std::abs(sch.initial.sum() - 1.0) > 1e-9)
      return "schedule: the initial (stationary) distribution must have " + std::to_string(K) + " entries summing to 1";
  }
  return "";
}

}  // namespace detail
}  // namespace networked_estimation
