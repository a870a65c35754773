// One simulated run behind lossy links (lossy_run.hpp).
#include "networked_estimation/simulation/lossy_run.hpp"

#include <limits>

#include "networked_estimation/common/error.hpp"
#include "networked_estimation/common/random.hpp"

namespace networked_estimation
{
namespace
{

std::unique_ptr<LossModel> actuatorLink(const Model& model, std::uint64_t seed, const LossyRunOptions& o)
{
  if (!o.actuator_link)
    return nullptr;
  if (!model.hasControl())
    throw ConfigError("actuator channel: model '" + model.name + "' has no control input");
  return makeLossModel(*o.actuator_link, deriveSeed(seed ^ o.actuator_link->seed, 200));
}

}  // namespace

SensorLinkSet::SensorLinkSet(const Model& model, const std::vector<std::optional<ChannelSettings>>& links,
                             std::uint64_t seed, bool noise_on_loss)
  : model_(&model), noise_on_loss_(noise_on_loss)
{
  const std::size_t S = model.sensors.size();
  if (!links.empty() && links.size() != S)
    throw ConfigError("sensor links: " + std::to_string(links.size()) + " given for the " + std::to_string(S) +
                      " sensors of model '" + model.name + "'");
  for (std::size_t s = 0; s < S; ++s)
  {
    const bool lossy = !links.empty() && links[s].has_value();
    links_.push_back(lossy ? makeLossModel(*links[s], deriveSeed(seed ^ links[s]->seed, 100 + s)) : nullptr);
    seeds_.push_back(lossy ? links[s]->seed : 0);
  }
}

void SensorLinkSet::reseed(std::uint64_t seed)
{
  for (std::size_t s = 0; s < links_.size(); ++s)
    if (links_[s])
      links_[s]->reseed(deriveSeed(seed ^ seeds_[s], 100 + s));
}

void SensorLinkSet::receive(const SimulatedSample& sample, const std::vector<bool>& on, Sample& received)
{
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<Sensor>& sensors = model_->sensors;
  Eigen::VectorXd& y = received.y;
  y = sample.y;
  bool gamma = false;
  for (std::size_t s = 0; s < links_.size(); ++s)
  {
    const Sensor& sensor = sensors[s];
    // Drawn whether or not the sensor transmits: the link's loss process runs in time.
    const bool lost = links_[s] && links_[s]->nextLost();
    if (lost || !on[s])
      y.segment(sensor.offset, sensor.size).setConstant(nan);
    else
      gamma = true;
  }
  if (!gamma)
  {
    if (noise_on_loss_)
      y = sample.v;
    else
      y.setConstant(nan);
    // A sensor that did not transmit delivers nothing, not even noise.
    for (std::size_t s = 0; s < links_.size(); ++s)
      if (!on[s])
        y.segment(sensors[s].offset, sensors[s].size).setConstant(nan);
  }
  received.gamma = gamma;
  received.u = sample.u;
}

LossyRun::LossyRun(const Model& model, std::uint64_t seed, const LossyRunOptions& options)
  : links_(model, options.sensor_links, seed, options.noise_on_loss),
    actuator_seed_(options.actuator_link ? options.actuator_link->seed : 0),
    sim_(model, seed, options.control, actuatorLink(model, seed, options)),
    schedule_(model.schedule, model.sensors.size(), deriveSeed(seed, 300))
{
  received_.y.resize(model.m());
  received_.nu = -1;
}

void LossyRun::restart(std::uint64_t seed)
{
  sim_.restart(seed, deriveSeed(seed ^ actuator_seed_, 200));
  links_.reseed(seed);
  schedule_.restart(deriveSeed(seed, 300));
}

const SimulatedSample& LossyRun::step()
{
  const SimulatedSample& sample = sim_.step();
  links_.receive(sample, schedule_.next(), received_);
  return sample;
}

}  // namespace networked_estimation
