// Scoring estimates against the simulated truth (the score tool).
#include "networked_estimation/io/score.hpp"

#include <algorithm>
#include <cstdio>
#include <limits>
#include <sstream>

#include "networked_estimation/common/angles.hpp"
#include "networked_estimation/common/error.hpp"

namespace networked_estimation
{

Score scoreEstimate(const std::string& name, const Truth& truth, const ReplayOutput& estimate, long from,
                    const std::vector<int>& angles)
{
  for (const int a : angles)
    if (a < 0 || a >= truth.n)
      throw InputError(truth.path + ": the angular state " + std::to_string(a) + " is not among its n = " +
                       std::to_string(truth.n) + " states (score it with the model it was simulated with)");
  if (estimate.n != truth.n)
    throw InputError(estimate.path + ": estimate '" + name + "' has n = " + std::to_string(estimate.n) +
                     " states but the truth " + truth.path + " has n = " + std::to_string(truth.n));
  if (estimate.rows.size() != truth.rows.size())
    throw InputError(estimate.path + ": estimate '" + name + "' has " + std::to_string(estimate.rows.size()) +
                     " steps but the truth " + truth.path + " has " + std::to_string(truth.rows.size()) +
                     " (replay the input simulated with this truth)");
  Score score;
  score.name = name;
  double sq = 0.0, tr = 0.0, arrived = 0.0;
  for (std::size_t i = 0; i < estimate.rows.size(); ++i)
  {
    const ReplayOutputRow& e = estimate.rows[i];
    const TruthRow& t = truth.rows[i];
    if (e.k != t.k)
      throw InputError(estimate.path + ": estimate '" + name + "' step k = " + std::to_string(e.k) +
                       " does not match the truth's k = " + std::to_string(t.k));
    if (e.k < from)
      continue;
    ++score.steps;
    sq += squaredError(t.x, e.x, angles);  // an angle's error is the shortest turn
    tr += e.trace;
    arrived += e.gamma ? 1.0 : 0.0;
  }
  if (score.steps == 0)
    throw InputError(estimate.path + ": estimate '" + name + "': no step with k >= " + std::to_string(from) +
                     " to score (" + std::to_string(estimate.rows.size()) + " steps)");
  const double T = static_cast<double>(score.steps);
  score.arrival_rate = arrived / T;
  score.mse = sq / T;
  score.mean_trace = tr / T;
  score.ratio = score.mean_trace > 0.0 ? score.mse / score.mean_trace : std::numeric_limits<double>::infinity();
  return score;
}

std::string formatScores(const std::vector<Score>& scores, long from, bool csv)
{
  std::ostringstream os;
  if (csv)
  {
    os << "name,steps,arrival_rate,mse,mean_trace,ratio\n";
    for (const Score& s : scores)
      os << s.name << ',' << s.steps << ',' << formatDouble(s.arrival_rate) << ',' << formatDouble(s.mse) << ','
         << formatDouble(s.mean_trace) << ',' << formatDouble(s.ratio) << '\n';
    return os.str();
  }
  const auto fmt = [](const char* format, double v)
  {
    char buf[64];
    std::snprintf(buf, sizeof buf, format, v);
    return std::string(buf);
  };
  const std::vector<std::string> heads = {"estimate", "steps", "arrival", "mse", "mean trace(P)", "mse/trace"};
  std::vector<std::vector<std::string>> table;
  for (const Score& s : scores)
    table.push_back({s.name, std::to_string(s.steps), fmt("%.4f", s.arrival_rate), fmt("%.6g", s.mse),
                     fmt("%.6g", s.mean_trace), fmt("%.4f", s.ratio)});
  std::vector<std::size_t> width(heads.size());
  for (std::size_t c = 0; c < heads.size(); ++c)
  {
    width[c] = heads[c].size();
    for (const auto& row : table)
      width[c] = std::max(width[c], row[c].size());
  }
  const auto emit = [&](const std::vector<std::string>& row)
  {
    for (std::size_t c = 0; c < row.size(); ++c)
    {
      if (c > 0)
        os << "  ";
      const std::string pad(width[c] - row[c].size(), ' ');
      if (c == 0)
        os << row[c] << pad;  // names left-aligned, numbers right-aligned
      else
        os << pad << row[c];
    }
    os << '\n';
  };
  os << "scored steps k >= " << from << "; mse = mean ||x_k - xhat_k||^2; mse/trace is about 1 for a consistent "
     << "filter\n";
  emit(heads);
  for (const auto& row : table)
    emit(row);
  return os.str();
}

}  // namespace networked_estimation
