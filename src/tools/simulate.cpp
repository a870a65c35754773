// simulate: runs the plant of a model file behind lossy sensor links (one per sensor) and an
// optional lossy actuator link, and writes the replay input (DIR/input.csv, what the estimator
// sees) and the truth (DIR/truth.csv: states and actuator deliveries).
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <limits>
#include <string>

#include "cli.hpp"
#include "networked_estimation/common/error.hpp"
#include "networked_estimation/config/channel_settings.hpp"
#include "networked_estimation/config/model.hpp"
#include "networked_estimation/config/sensor_links.hpp"
#include "networked_estimation/io/atomic_file.hpp"
#include "networked_estimation/io/replay_csv.hpp"
#include "networked_estimation/simulation/lossy_run.hpp"

using namespace networked_estimation;

int main(int argc, char** argv)
{
  cli::CommandLine cl(
      "simulate",
      "Simulates the plant of MODEL for N steps, each sensor behind its own lossy link (an independent\n"
      "loss stream per sensor), and writes DIR/input.csv (replay input: gamma = 1 when at least one sensor\n"
      "arrived; a lost sensor's cells are empty) and DIR/truth.csv (k, x1..xn, nu).\n"
      "--channel FILE gives every sensor that link; --channel NAME=FILE gives sensor NAME its own\n"
      "(repeatable); a sensor with neither is lossless. The links of the sensors are printed.",
      {
          {"model", "FILE", "model file (YAML)", true, false},
          {"channel", "[NAME=]FILE", "sensor-to-estimator channel settings (YAML), for every sensor or sensor NAME",
           false, true},
          {"steps", "N", "number of samples k = 1..N", true, false},
          {"seed", "S", "seed of the plant and (mixed with each channel's seed) of the links", true, false},
          {"out", "DIR", "output directory (created if needed)", true, false},
          {"actuator-channel", "FILE", "controller-to-actuator channel settings (default: lossless)", false, false},
          {"control", "SPEC", "command sequence: constant:V, step:K:V, paper or paper:V (default paper)", false, false},
          {"loss-output", "MODE", "y cells of gamma = 0 rows: noise (v_k, the papers' model; default) or empty", false,
           false},
      });
  return cli::runTool(
      cl, argc, argv,
      [&]() -> int
      {
        const Model model = loadModel(cl.get("model"));
        const SensorLinks links = resolveSensorLinks(model, cl.getAll("channel"));
        const long steps = cl.getLong("steps", 0, 1, std::numeric_limits<long>::max());
        const std::uint64_t seed = cl.getUint64("seed", 0);
        const std::string mode = cl.get("loss-output", "noise");
        if (mode != "noise" && mode != "empty")
          throw cli::UsageError("option '--loss-output': expected noise or empty, found '" + mode + "'");

        LossyRunOptions options;
        options.sensor_links = links.link;
        options.noise_on_loss = mode == "noise";
        if (model.hasControl())
        {
          options.control = ControlSequence::parse(cl.get("control", "paper"), "--control");
          if (cl.has("actuator-channel"))
            options.actuator_link = loadChannelSettings(cl.get("actuator-channel"));
        }
        else
        {
          for (const char* opt : {"control", "actuator-channel"})
            if (cl.has(opt))
              throw cli::UsageError(std::string("option '--") + opt + "': model '" + model.name + "' has no control");
        }

        const std::filesystem::path dir(cl.get("out"));
        std::error_code ec;
        std::filesystem::create_directories(dir, ec);
        if (ec || !std::filesystem::is_directory(dir))
          throw InputError(dir.string() + ": cannot create output directory" + (ec ? " (" + ec.message() + ")" : ""));

        AtomicFile input((dir / "input.csv").string());
        AtomicFile truth((dir / "truth.csv").string());
        writeReplayInputHeader(input.stream(), model.m(), model.p(), false);
        writeTruthHeader(truth.stream(), model.n());

        LossyRun run(model, seed, options);
        long arrived = 0, delivered = 0;
        std::vector<bool> off(static_cast<std::size_t>(model.m()), false);  // rows of unscheduled sensors
        for (long k = 1; k <= steps; ++k)
        {
          // The core refuses a state beyond the rounding floor or not finite (simulator.hpp); the
          // AtomicFiles then remove their temporary files: no output is written.
          const SimulatedSample* step = nullptr;
          try
          {
            step = &run.step();
          }
          catch (const DivergenceError& e)
          {
            throw DivergenceError(std::string("simulate: ") + e.what() + "; no output written");
          }
          const SimulatedSample& sample = *step;
          const Sample& received = run.received();
          arrived += received.gamma ? 1 : 0;
          delivered += sample.nu ? 1 : 0;
          if (model.schedule.active())
          {
            const std::vector<bool>& on = run.scheduled();
            for (std::size_t si = 0; si < model.sensors.size(); ++si)
              for (int i = 0; i < model.sensors[si].size; ++i)
                off[static_cast<std::size_t>(model.sensors[si].offset + i)] = !on[si];
          }
          writeReplayInputRow(input.stream(), sample.k, received.gamma, received.y, sample.u, false, -1,
                              model.schedule.active() ? &off : nullptr);
          writeTruthRow(truth.stream(), sample.k, sample.x, sample.nu);
        }
        input.commit();
        truth.commit();

        std::printf("simulate: %s, %ld steps, arrival rate %.4f, actuator delivery rate %.4f -> %s\n",
                    model.name.c_str(), steps, static_cast<double>(arrived) / steps,
                    static_cast<double>(delivered) / steps, dir.string().c_str());
        std::printf("links:\n%s", links.describe().c_str());
        if (model.schedule.active())
        {
          std::vector<std::string> names;
          for (const Sensor& sn : model.sensors)
            names.push_back(sn.name);
          std::printf("schedule: %s (cells of a sensor that was not scheduled hold '-')\n",
                      model.schedule.describe(names).c_str());
        }
        return 0;
      });
}
