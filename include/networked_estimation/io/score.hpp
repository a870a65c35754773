// Scoring an estimate (replay output) against the simulated truth: the score tool.
#pragma once

#include <string>
#include <vector>

#include "networked_estimation/io/replay_csv.hpp"

namespace networked_estimation
{

struct Score
{
  std::string name;
  long steps = 0;             ///< number of scored steps (k >= from)
  double arrival_rate = 0.0;  ///< mean gamma over the scored steps
  double mse = 0.0;           ///< sum_k ||x_k - xhat_k||^2 / steps (angles' differences wrapped)
  double mean_trace = 0.0;    ///< mean trace(P_k) over the same steps
  double ratio = 0.0;         ///< mse / mean_trace (about 1 for a consistent filter)
};

/// Scores an estimate against the truth over the steps k >= from. The estimate must have the
/// truth's state dimension and the same k sequence. The errors of the states `angles` (ascending,
/// the model's angles) are wrapped into (-pi, pi]. Throws InputError otherwise (or when no step
/// is left to score, or an angle is not a state of the truth).
Score scoreEstimate(const std::string& name, const Truth& truth, const ReplayOutput& estimate, long from = 1,
                    const std::vector<int>& angles = {});

/// A readable table (one row per score) or, with csv, the header
/// `name,steps,arrival_rate,mse,mean_trace,ratio` and one row per score.
std::string formatScores(const std::vector<Score>& scores, long from, bool csv);

}  // namespace networked_estimation
