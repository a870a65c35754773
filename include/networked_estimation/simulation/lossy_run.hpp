// One simulated run of a plant behind lossy links: the PlantSimulator, one independent loss stream
// per sensor (each sensor with its own channel settings, or lossless), and optionally a lossy
// actuator link. It is what `simulate` writes to its files and what `montecarlo --experiment custom`
// feeds to the estimators, so that a custom run equals simulate + replay + score for the same seed.
//
// Seeds, from the run's seed S: the plant PlantSimulator(model, S); sensor s's link
// deriveSeed(S ^ settings.seed, 100 + s); the actuator link deriveSeed(S ^ settings.seed, 200);
// a random sensor schedule deriveSeed(S, 300).
//
// With a sensor schedule (model.schedule), a sensor that is not scheduled at a step does not
// transmit: its cells are NaN and scheduled() says so; it is not a loss. Every link still draws its
// loss at every step (time-driven links, schedule.hpp), so the scheduled packets meet the same
// losses as without a schedule.
#pragma once

#include <Eigen/Dense>

#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "networked_estimation/channel/loss_model.hpp"
#include "networked_estimation/config/channel_settings.hpp"
#include "networked_estimation/config/model.hpp"
#include "networked_estimation/estimators/estimator.hpp"
#include "networked_estimation/simulation/schedule_sampler.hpp"
#include "networked_estimation/simulation/simulator.hpp"

namespace networked_estimation
{

struct LossyRunOptions
{
  /// One entry per sensor (empty = every sensor lossless): that sensor's link, or none (lossless).
  std::vector<std::optional<ChannelSettings>> sensor_links;
  /// The controller-to-actuator link (models with control); none = every command arrives.
  std::optional<ChannelSettings> actuator_link;
  ControlSequence control;
  /// What the y cells of a step with no sensor arrived hold: the measurement noise v_k (the
  /// papers' model, y_k = gamma_k C x_k + v_k; default) or nothing (NaN).
  bool noise_on_loss = true;
};

/// The sensor links of a run: one loss stream per sensor (or none: lossless), seeded from the run's
/// seed S as LossyRun does (sensor s: deriveSeed(S ^ settings.seed, 100 + s)), and the rule that
/// turns a true sample into what reaches the estimator. LossyRun holds one; a sweep holds one per
/// grid point to replay one simulated plant behind every point's links.
class SensorLinkSet
{
public:
  /// `links`: one entry per sensor, or empty (every sensor lossless). Throws ConfigError when the
  /// count differs from the model's sensors.
  SensorLinkSet(const Model& model, const std::vector<std::optional<ChannelSettings>>& links, std::uint64_t seed,
                bool noise_on_loss);

  /// Restarts every loss stream for the run seed `seed` (no allocation).
  void reseed(std::uint64_t seed);

  /// Draws every link's loss for one step (whether or not its sensor transmits: time-driven links)
  /// and writes what arrived into `received`: y with the cells of a lost or unscheduled sensor NaN,
  /// gamma = 1 when some sensor arrived (else y = v, or NaN, on the scheduled sensors), u.
  void receive(const SimulatedSample& sample, const std::vector<bool>& scheduled, Sample& received);

private:
  const Model* model_;
  bool noise_on_loss_;
  std::vector<std::unique_ptr<LossModel>> links_;  ///< null = lossless
  std::vector<std::uint64_t> seeds_;               ///< per sensor: its settings' seed
};

class LossyRun
{
public:
  LossyRun(const Model& model, std::uint64_t seed, const LossyRunOptions& options);

  /// Starts over at k = 0 exactly as LossyRun(model, seed, options) with the constructor's options
  /// would, reseeding every stream instead of allocating them anew (Monte Carlo runs).
  void restart(std::uint64_t seed);

  /// Advances to step k = k() + 1. Returns the true sample; received() is what reached the
  /// estimator: a lost sensor's cells are NaN, gamma = 1 when at least one sensor arrived.
  /// Throws DivergenceError when the plant state stops being representable (see PlantSimulator).
  const SimulatedSample& step();

  /// The estimator's view of the last step (gamma, y with NaN cells, u; nu = -1).
  const Sample& received() const { return received_; }
  /// Per sensor, whether it was scheduled to transmit at the last step (all true without a schedule).
  const std::vector<bool>& scheduled() const { return schedule_.current(); }
  long k() const { return sim_.k(); }

private:
  SensorLinkSet links_;
  std::uint64_t actuator_seed_ = 0;  ///< the actuator link settings' seed
  PlantSimulator sim_;
  ScheduleSampler schedule_;
  Sample received_;
};

}  // namespace networked_estimation
