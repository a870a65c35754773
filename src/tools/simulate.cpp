// simulate: runs the plant of a model file and a lossy sensor link, and writes the replay input
// (DIR/input.csv, what the estimator sees) and the truth (DIR/truth.csv: states and actuator
// deliveries).
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <limits>
#include <memory>
#include <vector>

#include "cli.hpp"
#include "networked_estimation/common/error.hpp"
#include "networked_estimation/channel/loss_model.hpp"
#include "networked_estimation/config/model.hpp"
#include "networked_estimation/common/random.hpp"
#include "networked_estimation/io/atomic_file.hpp"
#include "networked_estimation/io/replay_csv.hpp"
#include "networked_estimation/config/channel_settings.hpp"
#include "networked_estimation/simulation/simulator.hpp"

using namespace networked_estimation;

int main(int argc, char** argv)
{
  cli::CommandLine cl(
      "simulate",
      "Simulates the plant of MODEL for N steps with the sensor link of CHANNEL (one independent loss\n"
      "stream per sensor) and writes DIR/input.csv (replay input: gamma = 1 when at least one sensor\n"
      "arrived; a lost sensor's cells are empty) and DIR/truth.csv (k, x1..xn, nu).",
      {
          {"model", "FILE", "model file (YAML)", true, false},
          {"channel", "FILE", "sensor-to-estimator channel settings (YAML)", true, false},
          {"steps", "N", "number of samples k = 1..N", true, false},
          {"seed", "S", "seed of the plant and (mixed with the channel's seed) of the links", true, false},
          {"out", "DIR", "output directory (created if needed)", true, false},
          {"actuator-channel", "FILE", "controller-to-actuator channel settings (default: lossless)", false, false},
          {"control", "SPEC", "command sequence: constant:V, step:K:V, paper or paper:V (default paper)", false,
           false},
          {"loss-output", "MODE", "y cells of gamma = 0 rows: noise (v_k, the papers' model; default) or empty",
           false, false},
      });
  return cli::runTool(cl, argc, argv, [&]() -> int {
    const Model model = loadModel(cl.get("model"));
    const ChannelSettings channel = loadChannelSettings(cl.get("channel"));
    const long steps = cl.getLong("steps", 0, 1, std::numeric_limits<long>::max());
    const std::uint64_t seed = cl.getUint64("seed", 0);
    const std::string mode = cl.get("loss-output", "noise");
    if (mode != "noise" && mode != "empty")
      throw cli::UsageError("option '--loss-output': expected noise or empty, found '" + mode + "'");
    const bool noise = mode == "noise";

    ControlSequence control;
    std::unique_ptr<LossModel> actuator;
    if (model.hasControl())
    {
      control = ControlSequence::parse(cl.get("control", "paper"), "--control");
      if (cl.has("actuator-channel"))
      {
        const ChannelSettings act = loadChannelSettings(cl.get("actuator-channel"));
        actuator = makeLossModel(act, deriveSeed(seed ^ act.seed, 200));
      }
    }
    else
    {
      for (const char* opt : {"control", "actuator-channel"})
        if (cl.has(opt))
          throw cli::UsageError(std::string("option '--") + opt + "': model '" + model.name + "' has no control");
    }

    // One independent loss stream per sensor.
    std::vector<std::unique_ptr<LossModel>> links;
    for (std::size_t s = 0; s < model.sensors.size(); ++s)
      links.push_back(makeLossModel(channel, deriveSeed(seed ^ channel.seed, 100 + s)));

    const std::filesystem::path dir(cl.get("out"));
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec || !std::filesystem::is_directory(dir))
      throw InputError(dir.string() + ": cannot create output directory" + (ec ? " (" + ec.message() + ")" : ""));

    AtomicFile input((dir / "input.csv").string());
    AtomicFile truth((dir / "truth.csv").string());
    writeReplayInputHeader(input.stream(), model.m(), model.p(), false);
    writeTruthHeader(truth.stream(), model.n());

    PlantSimulator sim(model, seed, control, std::move(actuator));
    const double nan = std::numeric_limits<double>::quiet_NaN();
    Eigen::VectorXd y(model.m());
    long arrived = 0, delivered = 0;
    for (long k = 1; k <= steps; ++k)
    {
      const SimulatedSample& sample = sim.step();
      if (!sample.x.allFinite() || !sample.y.allFinite())
        throw DivergenceError("simulate: the plant state of model '" + model.name + "' is no longer finite at step k = " +
                              std::to_string(k) + " (an unstable plant overflows: simulate fewer steps); no output written");
      bool gamma = false;
      y = sample.y;
      for (std::size_t s = 0; s < model.sensors.size(); ++s)
      {
        const Sensor& sensor = model.sensors[s];
        if (links[s]->nextLost())
          y.segment(sensor.offset, sensor.size).setConstant(nan);
        else
          gamma = true;
      }
      if (!gamma)
      {
        if (noise)
          y = sample.v;  // the papers' model delivers y_k = gamma_k C x_k + v_k
        else
          y.setConstant(nan);
      }
      arrived += gamma ? 1 : 0;
      delivered += sample.nu ? 1 : 0;
      writeReplayInputRow(input.stream(), sample.k, gamma, y, sample.u);
      writeTruthRow(truth.stream(), sample.k, sample.x, sample.nu);
    }
    input.commit();
    truth.commit();

    std::printf("simulate: %s, %ld steps, arrival rate %.4f, actuator delivery rate %.4f -> %s\n",
                model.name.c_str(), steps, static_cast<double>(arrived) / steps,
                static_cast<double>(delivered) / steps, dir.string().c_str());
    return 0;
  });
}
