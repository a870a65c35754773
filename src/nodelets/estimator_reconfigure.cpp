// The Estimator's runtime settings through dynamic_reconfigure (estimator_nodelet.hpp,
// startReconfigure): validated as a whole, refused with the key named.
#include "estimator_nodelet.hpp"

namespace networked_estimation
{

void EstimatorNodelet::startReconfigure(ros::NodeHandle& pnh)
{
  // In ~reconfigure: the server writes its values back as parameters, which must not become
  // parameters of the nodelet's next load.
  reconfigure_ = std::make_unique<dynamic_reconfigure::Server<EstimatorConfig>>(reconfigure_mutex_,
                                                                                ros::NodeHandle(pnh, "reconfigure"));
  const RuntimeSettings& r = stream_->runtime();
  shown_.adaptive_latency = r.adaptive_latency;
  shown_.latency_budget = r.adaptive_latency ? stream_->budget() : r.latency_budget;
  shown_.latency_budget_min = r.latency_budget_min;
  shown_.latency_budget_max = r.latency_budget_max;
  shown_.late_policy = r.late_policy;
  shown_.trace_bound = std::min(r.trace_bound, 1e300);
  reconfigure_->setCallback(
      [this](EstimatorConfig& c, uint32_t)
      {
        if (reconfigure_ready_)
          reconfigure(c);
      });
  reconfigure_ready_ = true;
  reconfigure_->updateConfig(shown_);
}

void EstimatorNodelet::reconfigure(EstimatorConfig& c)
{
  RuntimeSettings r;
  r.adaptive_latency = c.adaptive_latency;
  r.latency_budget = c.latency_budget;
  r.latency_budget_min = c.latency_budget_min;
  r.latency_budget_max = c.latency_budget_max;
  r.late_policy = c.late_policy;
  r.trace_bound = c.trace_bound >= 1e300 ? std::numeric_limits<double>::infinity() : c.trace_bound;
  std::lock_guard<std::mutex> lock(mutex_);
  try
  {
    validateRuntimeSettings(r, limits_, "reconfigure");
  }
  catch (const ConfigError& e)
  {
    NODELET_ERROR("Estimator: change refused: %s; the settings stay %s", e.what(),
                  describe(stream_->runtime()).c_str());
    c = shown_;  // the server shows these back
    return;
  }
  stream_->setRuntime(r);
  trace_bound_ = r.trace_bound;
  shown_ = c;
  NODELET_INFO("Estimator reconfigured: %s", describe(r).c_str());
  dispatch_.wake();  // the deadlines moved
}

}  // namespace networked_estimation
