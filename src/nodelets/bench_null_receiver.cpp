// BenchNullReceiver: what receiving a stream costs in roscpp (bench_util.hpp has the set).
#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <topic_tools/shape_shifter.h>

#include <algorithm>
#include <atomic>
#include <limits>
#include <memory>
#include <vector>

#include "dispatch_thread.hpp"
#include "input_message_types.hpp"
#include "load_failure.hpp"

namespace networked_estimation
{

/// Receives ~topics and drops the messages (one hand-off each, to its own thread, as the Estimator;
/// with ~inline, none: in roscpp's receive thread). With ~relay (one of ~topics, nav_msgs/Odometry),
/// that topic's messages are published again on `odometry/filtered` from the same thread: an
/// estimator's traffic (one output per step) with no estimation, the floor of a node that
/// receives a robot's inputs and publishes its outputs through roscpp. With ~decode, every other
/// topic's messages are also deserialized into their class (one of the Estimator's input types,
/// by the topic's type): what any node that reads their values pays on top of receiving them.
class BenchNullReceiver : public nodelet::Nodelet
{
public:
  ~BenchNullReceiver() override
  {
    dispatch_.stop();
    for (ros::Subscriber& s : subs_)
      s.shutdown();
  }

private:
  void onInit() override
  {
    std::vector<std::string> topics;
    getPrivateNodeHandle().getParam("topics", topics);
    if (topics.empty())
      refuseLoad(getName(), "BenchNullReceiver not started: ~topics: expected a list of topics, found none");
    bool in_receive_thread = false;
    getPrivateNodeHandle().param("inline", in_receive_thread, false);
    std::string relay;
    getPrivateNodeHandle().param("relay", relay, std::string());
    bool decode = false;
    getPrivateNodeHandle().param("decode", decode, false);
    if (!relay.empty() && std::find(topics.begin(), topics.end(), relay) == topics.end())
      refuseLoad(getName(), "BenchNullReceiver not started: ~relay: expected one of ~topics, found '" + relay + "'");
    if (!relay.empty() && in_receive_thread)
      refuseLoad(getName(),
                 "BenchNullReceiver not started: ~relay and ~inline: roscpp's receive thread must not "
                 "publish (dispatch_thread.hpp)");
    dispatch_.start([] { return std::numeric_limits<double>::infinity(); });
    ros::NodeHandle nh(getNodeHandle());
    nh.setCallbackQueue(in_receive_thread ? static_cast<ros::CallbackQueueInterface*>(&inline_) : dispatch_.queue());
    if (!relay.empty())
      relay_pub_ = getNodeHandle().advertise<nav_msgs::Odometry>("odometry/filtered", 100);
    for (const std::string& t : topics)
    {
      if (t == relay)
        subs_.push_back(nh.subscribe<nav_msgs::Odometry>(
            t, 1000,
            [this](const nav_msgs::Odometry::ConstPtr& m)
            {
              ++received_;
              relay_pub_.publish(m);
            },
            ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay()));
      else
        subs_.push_back(nh.subscribe<topic_tools::ShapeShifter>(
            t, 1000,
            [this, decode, type = std::make_shared<int>(-1)](const topic_tools::ShapeShifter::ConstPtr& m)
            {
              ++received_;
              if (decode)
                deserialize(*m, *type);
            },
            ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay()));
    }
    NODELET_INFO("BenchNullReceiver on %zu topics%s%s%s", topics.size(), in_receive_thread ? " (inline)" : "",
                 decode ? " (decoding)" : "",
                 relay.empty() ? "" : ("; " + relay + " relayed to " + nh.resolveName("odometry/filtered")).c_str());
  }

  /// Deserializes `m` into its class; `type` caches the topic's input type (-1: not known yet,
  /// -2: not an input type, left as bytes).
  static void deserialize(const topic_tools::ShapeShifter& m, int& type)
  {
    if (type == -1)
    {
      type = -2;
      for (const InputType t : sensorInputTypes())
        if (withInputMessage(t, [&](auto tag)
                             { return ros::message_traits::datatype<MessageOf<decltype(tag)>>() == m.getDataType(); }))
          type = static_cast<int>(t);
    }
    if (type >= 0)
      withInputMessage(static_cast<InputType>(type),
                       [&](auto tag)
                       {
                         const auto msg = m.instantiate<MessageOf<decltype(tag)>>();
                         return msg != nullptr;
                       });
  }

  InlineQueue inline_;
  DispatchThread dispatch_;
  std::vector<ros::Subscriber> subs_;
  ros::Publisher relay_pub_;
  std::atomic<std::uint64_t> received_{0};
};

}  // namespace networked_estimation

PLUGINLIB_EXPORT_CLASS(networked_estimation::BenchNullReceiver, nodelet::Nodelet)
