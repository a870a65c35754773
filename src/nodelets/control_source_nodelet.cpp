// ControlSource nodelet: the known command sequence u_k (constant, step, or Lin et al.'s
// 1 + exp(-k/10)) as ControlInput on `command`, the input of the actuator link.
//
// It follows the plant: on PlantState k (from `plant_state`) it sends the command for step k + 1,
// stamped one period later, so that a lossless link delivers u_{k+1} well before the plant's
// step k + 1 (the plant applies zero when it has not arrived). Estimators that must know the
// commands (aoe, NACK) subscribe to `command` before the link.
#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>
#include <ros/ros.h>

#include "networked_estimation/ControlInput.h"
#include "networked_estimation/PlantState.h"
#include "networked_estimation/common/error.hpp"
#include "networked_estimation/config/model.hpp"
#include "networked_estimation/simulation/simulator.hpp"
#include "load_failure.hpp"
#include "param_yaml.hpp"

namespace networked_estimation
{

class ControlSourceNodelet : public nodelet::Nodelet
{
private:
  void onInit() override
  {
    ros::NodeHandle& nh = getNodeHandle();
    ros::NodeHandle& pnh = getPrivateNodeHandle();
    try
    {
      ParamReader p(privateParameters(pnh), pnh.getNamespace() + " parameters");
      const Model model = loadModel(p.required("model"));
      if (!model.hasControl())
        throw ConfigError(p.source() + ": model: '" + model.name + "' has no control input (no control: Bu)");
      p_ = model.p();
      period_ = p.number("period", model.period, 1e-6, 3600.0);
      sequence_ = ControlSequence::parse(p.text("sequence", "paper"), p.source() + ": sequence");
      p.rejectUnknown();
    }
    catch (const ConfigError& e)
    {
      refuseLoad(getName(), std::string("ControlSource not started: ") + e.what());
    }
    pub_ = nh.advertise<ControlInput>("command", 1000);
    sub_ = nh.subscribe("plant_state", 1000, &ControlSourceNodelet::onState, this, ros::TransportHints().tcpNoDelay());
  }

  void onState(const PlantState::ConstPtr& state)
  {
    const long k = static_cast<long>(state->step) + 1;
    ControlInput::Ptr c = boost::make_shared<ControlInput>();
    c->header.stamp = state->header.stamp + ros::Duration(period_);
    c->step = static_cast<std::uint64_t>(k);
    const Eigen::VectorXd u = sequence_.at(k, p_);
    c->u.assign(u.data(), u.data() + u.size());
    pub_.publish(c);
  }

  int p_ = 1;
  double period_ = 0.0;
  ControlSequence sequence_;
  ros::Publisher pub_;
  ros::Subscriber sub_;
};

}  // namespace networked_estimation

PLUGINLIB_EXPORT_CLASS(networked_estimation::ControlSourceNodelet, nodelet::Nodelet)
