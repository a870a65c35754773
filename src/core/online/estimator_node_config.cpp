#include "networked_estimation/online/estimator_node_config.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <limits>

#include "networked_estimation/common/error.hpp"
#include "networked_estimation/estimators/estimator.hpp"
#include "networked_estimation/config/param_reader.hpp"

namespace networked_estimation
{

EstimatorNodeConfig parseEstimatorNodeConfig(const YAML::Node& params, const std::string& source)
{
  ParamReader p(params, source);
  EstimatorNodeConfig c;
  c.model_file = p.required("model");
  try
  {
    c.model = loadModel(c.model_file);
  }
  catch (const ConfigError& e)
  {
    throw ConfigError(source + ": model: " + e.what());
  }
  const Model& model = c.model;

  YAML::Node est(YAML::NodeType::Map);
  for (const char* key : {"algorithm", "mu", "control_link", "max_components"})
    if (p.has(key))
      est[key] = p.take(key);
  if (!est["algorithm"])
    est["algorithm"] = "kfio";
  c.settings = parseEstimatorSettings(est, source);
  if (c.settings.algorithm == Algorithm::ACK_KF)
    throw ConfigError(source + ": algorithm: ack_kf needs nu_k (whether each command arrived), which the graph "
                      "does not carry; use it offline with replay");
  try
  {
    makeEstimator(model, c.settings);  // the combination of model and settings (e.g. aoe needs control_link)
  }
  catch (const ConfigError& e)
  {
    throw ConfigError(source + ": " + e.what());
  }

  c.period = p.number("period", model.period, 0.0, 3600.0);
  if (!(c.period > 0.0))
    throw ConfigError(source + ": period: the model '" + c.model_file + "' has no period and none was given");
  c.latency_budget = p.number("latency_budget", 0.5 * c.period, 0.0, 3600.0);

  c.online.late_policy = latePolicyFromString(p.text("late_policy", "drop"), source);
  c.online.history_length = static_cast<std::size_t>(p.integer("history_length", 100, 1, 100000));
  c.online.max_future_steps = p.integer("max_future_steps", 1000, 1, 1000000);
  c.online.max_past_steps =
      p.integer("max_past_steps", std::max<long>(1000, static_cast<long>(c.online.history_length)), 1, 1000000);
  validateOnlineOptions(c.online, source);

  c.input_type = p.choice("input_type", "measurement", {"measurement", "range", "point"});
  for (const Sensor& s : model.sensors)
  {
    if (c.input_type == "range" && s.size != 1)
      throw ConfigError(source + ": input_type: range needs sensors of 1 row; sensor '" + s.name + "' has " +
                        std::to_string(s.size));
    if (c.input_type == "point" && s.size > 3)
      throw ConfigError(source + ": input_type: point gives at most 3 values; sensor '" + s.name + "' has " +
                        std::to_string(s.size));
  }
  c.frame_id = p.text("frame_id", "map");
  c.child_frame_id = p.text("child_frame_id", toString(c.settings.algorithm) + "_estimate");
  c.position_indices =
      p.indices("position_indices", model.n() >= 2 ? std::vector<int>{0, 1} : std::vector<int>{0}, model.n());
  c.publish_tf = p.flag("publish_tf", true);
  const double inf = std::numeric_limits<double>::infinity();
  c.trace_bound = p.number("trace_bound", inf, 0.0, inf);
  c.queue_size = static_cast<std::size_t>(p.integer("queue_size", 1000, 1, 1000000));
  c.markov_link = p.choice("link_model", "iid", {"iid", "markov"}) == "markov";
  const long window = p.integer("stability_window", 1000, 10, 1000000);
  c.stability_window = static_cast<std::size_t>(window);
  c.stability_min_samples = static_cast<std::size_t>(p.integer("stability_min_samples", 100, 1, window));
  p.take("diagnostic_period");  // read by diagnostic_updater
  p.rejectUnknown();
  return c;
}

}  // namespace networked_estimation
