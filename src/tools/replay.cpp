// replay: runs one estimator over a replay input file and writes its estimates (replay output).
#include <iostream>
#include <memory>

#include "cli.hpp"
#include "networked_estimation/estimators/estimator.hpp"
#include "networked_estimation/config/model.hpp"
#include "networked_estimation/io/atomic_file.hpp"
#include "networked_estimation/io/replay_csv.hpp"
#include "networked_estimation/config/estimator_settings.hpp"

using namespace networked_estimation;

int main(int argc, char** argv)
{
  cli::CommandLine cl(
      "replay",
      "Runs the estimator of SETTINGS for MODEL over the replay input IN and writes x_{k|k}, P_{k|k}\n"
      "of every step to OUT (written atomically: no file at all on error). Exit codes: 0 ok,\n"
      "2 bad arguments or files, 3 the estimator diverged.",
      {
          {"model", "FILE", "model file (YAML)", true, false},
          {"settings", "FILE", "estimator settings (YAML) or an algorithm name (kfio, rseio, ...)", true, false},
          {"input", "IN", "replay input CSV (k,gamma,y1..ym[,u1..up][,nu][,r1_1..]: docs/formats.md)", true, false},
          {"output", "OUT", "replay output CSV (k,gamma,x1..xn,P11..Pnn,trace)", true, false},
          {"truth", "FILE", "truth CSV of simulate: nu for ack_kf when the input has no nu column", false, false},
      });
  return cli::runTool(
      cl, argc, argv,
      [&]() -> int
      {
        const Model model = loadModel(cl.get("model"));
        const EstimatorSettings settings = estimatorSettingsArgument(cl.get("settings"));
        const std::string in_path = cl.get("input");
        ReplayInput input = readReplayInput(in_path, model);
        std::unique_ptr<Estimator> estimator = makeEstimator(model, settings);
        const bool ack = settings.algorithm == Algorithm::ACK_KF;

        // ack_kf is told nu_k: from the input's nu column, else from the truth file.
        if (ack && model.hasControl() && !input.has_nu)
        {
          if (!cl.has("truth"))
            throw cli::UsageError("ack_kf needs nu (a 'nu' column in the input or --truth)");
          const Truth truth = readTruth(cl.get("truth"));
          if (truth.rows.size() != input.rows.size())
            throw InputError(truth.path + ": has " + std::to_string(truth.rows.size()) + " steps but " + in_path +
                             " has " + std::to_string(input.rows.size()) +
                             " (use the truth simulated with this input)");
          for (std::size_t i = 0; i < input.rows.size(); ++i)
            input.rows[i].nu = truth.rows[i].nu;
        }

        AtomicFile out(cl.get("output"));
        writeReplayOutputHeader(out.stream(), model.n());
        Sample sample;
        for (const ReplayRow& row : input.rows)
        {
          sample.gamma = row.gamma;
          sample.y = row.y;
          sample.u = row.u;
          sample.nu = ack ? row.nu : -1;  // only ack_kf may read nu
          sample.R = row.R;               // empty: the model's R
          try
          {
            estimator->step(sample);
          }
          catch (const InputError& e)
          {
            throw InputError(in_path + ":" + std::to_string(row.line) + ": " + e.what());
          }
          catch (const DivergenceError& e)
          {
            throw DivergenceError(toString(settings.algorithm) + " diverged at step k = " + std::to_string(row.k) +
                                  " (" + in_path + ":" + std::to_string(row.line) + "): " + e.what() +
                                  "; no output written");
          }
          writeReplayOutputRow(out.stream(), row.k, row.gamma, estimator->state(), estimator->covariance());
        }
        out.commit();
        return 0;
      });
}
