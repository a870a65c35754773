// Sensor schedules: the model file's `schedule` map, its checks, and what reports say of it
// (schedule.hpp, schedule_config.hpp).
#include "config/schedule_config.hpp"

#include "config/yaml_reader.hpp"

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

/// A list of sensor names -> mask; `f` is e.g. schedule.pattern[1].
std::vector<bool> parseSet(const Field& f, const std::vector<Sensor>& sensors)
{
  if (!f.isList())
    f.fail("expected a list of sensor names (e.g. [gnss, camera]; [] for none), found " + f.found());
  std::vector<std::string> names;
  for (const Sensor& s : sensors)
    names.push_back(s.name);
  std::vector<bool> mask(sensors.size(), false);
  for (const Field& e : f.elements())
  {
    const std::string name = e.string();
    const auto it = std::find(names.begin(), names.end(), name);
    if (it == names.end())
      e.fail("'" + name + "' is not a sensor of the model (sensors: " + joinList(names) + ")");
    const std::size_t s = static_cast<std::size_t>(it - names.begin());
    if (mask[s])
      e.fail("sensor '" + name + "' listed twice");
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

namespace
{

/// The schedule being read, with its map and the model's sensors.
struct ScheduleParse
{
  Schedule sch;
  Field map;
  const std::vector<Sensor>& sensors;
};

/// A non-empty list of sensor sets, each a `noun` ("step", "subset"; `expected` says what the list
/// holds), of which at least one names a sensor (`all_empty` says why otherwise).
std::vector<std::vector<bool>> readSets(const Field& f, const std::vector<Sensor>& sensors, const std::string& noun,
                                        const std::string& expected, const std::string& all_empty)
{
  if (!f.isList() || f.size() == 0)
    f.fail("expected a non-empty list of " + expected + ", found " + f.found());
  std::vector<std::vector<bool>> sets;
  for (const Field& set : f.elements())
    sets.push_back(parseSet(set, sensors));
  if (noneScheduled(sets))
    f.fail(all_empty + ": the estimator would never receive a measurement; name at least one sensor in some " + noun);
  return sets;
}

void readPattern(const Field& p, ScheduleParse& out)
{
  for (const char* other : {"subsets", "probabilities", "transition"})
    if (out.map[other])
      out.map[other].fail(
          "cannot be combined with schedule.pattern (a periodic schedule is a pattern; a random one is "
          "subsets with probabilities or a transition matrix)");
  out.sch.kind = Schedule::Kind::PERIODIC;
  out.sch.pattern = readSets(p, out.sensors, "step", "steps, each a list of sensor names (e.g. [[gnss], [camera]])",
                             "no step schedules a sensor (every step is [])");
}

void readSubsets(const Field& s, ScheduleParse& out)
{
  out.sch.kind = Schedule::Kind::RANDOM;
  out.sch.subsets = readSets(s, out.sensors, "subset", "subsets, each a list of sensor names", "every subset is []");
}

void readProbabilities(const Field& f, ScheduleParse& out)
{
  if (out.map["transition"])
    out.map.fail("give either probabilities (i.i.d.) or transition (Markov), not both");
  const int K = static_cast<int>(out.sch.subsets.size());
  const Eigen::VectorXd p = f.vector(K, std::to_string(K) + " subsets");
  for (int i = 0; i < K; ++i)
    if (p[i] < 0.0 || p[i] > 1.0)
      f.failAt(indexKey(f.key(), static_cast<std::size_t>(i)),
               "expected a probability in [0, 1], found " + formatNumber(p[i]));
  if (std::abs(p.sum() - 1.0) > 1e-9)
    f.fail("the probabilities must sum to 1, found " + formatNumber(p.sum()));
  out.sch.transition = Eigen::VectorXd::Ones(K) * p.transpose();
  out.sch.initial = p;
}

void readTransition(const Field& f, ScheduleParse& out)
{
  const int K = static_cast<int>(out.sch.subsets.size());
  Schedule& sch = out.sch;
  sch.markov = true;
  sch.transition = f.matrix(K, K, std::to_string(K) + " subsets");
  for (int i = 0; i < K; ++i)
  {
    for (int j = 0; j < K; ++j)
      if (sch.transition(i, j) < 0.0 || sch.transition(i, j) > 1.0)
        f.fail("entry (" + std::to_string(i) + "," + std::to_string(j) + "): expected a probability in [0, 1], found " +
               formatNumber(sch.transition(i, j)));
    if (std::abs(sch.transition.row(i).sum() - 1.0) > 1e-9)
      f.fail("row " + std::to_string(i) + " must sum to 1 (rows are the current subset), found " +
             formatNumber(sch.transition.row(i).sum()));
  }
  sch.initial = stationary(sch.transition);
  if (!sch.initial.allFinite())
    f.fail("the chain has no unique stationary distribution");
}

}  // namespace

Schedule parseSchedule(const Field& f, const std::vector<Sensor>& sensors)
{
  using P = ScheduleParse;
  static const std::vector<KeyRule<P>> table = {
      optionalKey<P>("pattern", readPattern),
      optionalKey<P>("subsets", readSubsets,
                     [](const Field& map, P& out)
                     {
                       if (out.sch.kind != Schedule::Kind::PERIODIC)
                         map.required("subsets", " (or give schedule.pattern for a periodic schedule)");
                     }),
      optionalKey<P>("probabilities", readProbabilities,
                     [](const Field& map, P& out)
                     {
                       if (out.sch.kind == Schedule::Kind::RANDOM && !map["transition"])
                         map.fail(
                             "a random schedule needs probabilities (i.i.d.) or transition (Markov chain over "
                             "the subsets)");
                     }),
      optionalKey<P>("transition", readTransition),
  };
  ScheduleParse out{Schedule(), f, sensors};
  readKeys(f, table, out);
  return out.sch;
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
