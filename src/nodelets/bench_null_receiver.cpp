// BenchNullReceiver: what receiving a stream costs in roscpp (bench_util.hpp has the set).
#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>
#include <ros/ros.h>
#include <topic_tools/shape_shifter.h>

#include <atomic>
#include <limits>
#include <vector>

#include "dispatch_thread.hpp"
#include "load_failure.hpp"

namespace networked_estimation
{

/// Receives ~topics and drops the messages (one hand-off each, to its own thread, as the Estimator;
/// with ~inline, none: in roscpp's receive thread).
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
    dispatch_.start([] { return std::numeric_limits<double>::infinity(); });
    ros::NodeHandle nh(getNodeHandle());
    nh.setCallbackQueue(in_receive_thread ? static_cast<ros::CallbackQueueInterface*>(&inline_) : dispatch_.queue());
    for (const std::string& t : topics)
      subs_.push_back(nh.subscribe<topic_tools::ShapeShifter>(
          t, 1000, [this](const topic_tools::ShapeShifter::ConstPtr&) { ++received_; }, ros::VoidConstPtr(),
          ros::TransportHints().tcpNoDelay()));
    NODELET_INFO("BenchNullReceiver on %zu topics%s", topics.size(), in_receive_thread ? " (inline)" : "");
  }

  InlineQueue inline_;
  DispatchThread dispatch_;
  std::vector<ros::Subscriber> subs_;
  std::atomic<std::uint64_t> received_{0};
};

}  // namespace networked_estimation

PLUGINLIB_EXPORT_CLASS(networked_estimation::BenchNullReceiver, nodelet::Nodelet)
