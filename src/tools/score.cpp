// score: compares replay outputs with the truth written by simulate.
#include <iostream>
#include <limits>
#include <vector>

#include "cli.hpp"
#include "networked_estimation/config/model.hpp"
#include "networked_estimation/io/replay_csv.hpp"
#include "networked_estimation/io/score.hpp"

using namespace networked_estimation;

int main(int argc, char** argv)
{
  cli::CommandLine cl("score",
                      "Prints, for every estimate, the steps scored, the arrival rate (mean gamma), the\n"
                      "time-averaged squared error mean ||x_k - xhat_k||^2, the mean trace of P and their\n"
                      "ratio (about 1 for a consistent filter), over the steps k >= K. With --model, the error of\n"
                      "each of the model's angular states (its key angles) is the shortest turn, wrapped into\n"
                      "(-pi, pi].",
                      {
                          {"truth", "FILE", "truth CSV written by simulate", true, false},
                          {"estimate", "NAME=FILE", "replay output CSV, labelled NAME", true, true},
                          {"from", "K", "score the steps k >= K (default 1)", false, false},
                          {"model", "FILE", "the model simulated: its angles' errors are wrapped", false, false},
                          {"csv", "", "print CSV instead of a table", false, false},
                      });
  return cli::runTool(cl, argc, argv,
                      [&]() -> int
                      {
                        const long from = cl.getLong("from", 1, 1, std::numeric_limits<long>::max());
                        std::vector<std::pair<std::string, std::string>> estimates;
                        for (const std::string& spec : cl.getAll("estimate"))
                        {
                          const std::string::size_type eq = spec.find('=');
                          if (eq == std::string::npos || eq == 0 || eq + 1 == spec.size())
                            throw cli::UsageError("option '--estimate': expected NAME=FILE, found '" + spec + "'");
                          estimates.emplace_back(spec.substr(0, eq), spec.substr(eq + 1));
                        }
                        const Truth truth = readTruth(cl.get("truth"));
                        std::vector<int> angles;
                        if (cl.has("model"))
                        {
                          const Model model = loadModel(cl.get("model"));
                          if (model.n() != truth.n)
                            throw InputError(truth.path + ": has n = " + std::to_string(truth.n) +
                                             " states but the model " + cl.get("model") +
                                             " has n = " + std::to_string(model.n()));
                          angles = model.angles;
                        }
                        std::vector<Score> scores;
                        for (const auto& e : estimates)
                          scores.push_back(scoreEstimate(e.first, truth, readReplayOutput(e.second), from, angles));
                        std::cout << formatScores(scores, from, cl.has("csv"));
                        return 0;
                      });
}
