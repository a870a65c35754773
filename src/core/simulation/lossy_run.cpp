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

LossyRun::LossyRun(const Model& model, std::uint64_t seed, const LossyRunOptions& options)
  : model_(model),
    noise_on_loss_(options.noise_on_loss),
    sim_(model, seed, options.control, actuatorLink(model, seed, options)),
    schedule_(model.schedule, model.sensors.size(), deriveSeed(seed, 300))
{
  const std::size_t S = model.sensors.size();
  if (!options.sensor_links.empty() && options.sensor_links.size() != S)
    throw ConfigError("sensor links: " + std::to_string(options.sensor_links.size()) + " given for the " +
                      std::to_string(S) + " sensors of model '" + model.name + "'");
  for (std::size_t s = 0; s < S; ++s)
  {
    const bool lossy = !options.sensor_links.empty() && options.sensor_links[s].has_value();
    links_.push_back(lossy ? makeLossModel(*options.sensor_links[s],
                                           deriveSeed(seed ^ options.sensor_links[s]->seed, 100 + s))
                           : nullptr);
    link_seeds_.push_back(lossy ? options.sensor_links[s]->seed : 0);
  }
  if (options.actuator_link)
    actuator_seed_ = options.actuator_link->seed;
  received_.y.resize(model.m());
  received_.nu = -1;
}

void LossyRun::restart(std::uint64_t seed)
{
  sim_.restart(seed, deriveSeed(seed ^ actuator_seed_, 200));
  for (std::size_t s = 0; s < links_.size(); ++s)
    if (links_[s])
      links_[s]->reseed(deriveSeed(seed ^ link_seeds_[s], 100 + s));
  schedule_.restart(deriveSeed(seed, 300));
}

const SimulatedSample& LossyRun::step()
{
  const SimulatedSample& sample = sim_.step();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  Eigen::VectorXd& y = received_.y;
  y = sample.y;
  const std::vector<bool>& on = schedule_.next();
  bool gamma = false;
  for (std::size_t s = 0; s < links_.size(); ++s)
  {
    const Sensor& sensor = model_.sensors[s];
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
        y.segment(model_.sensors[s].offset, model_.sensors[s].size).setConstant(nan);
  }
  received_.gamma = gamma;
  received_.u = sample.u;
  return sample;
}

}  // namespace networked_estimation
