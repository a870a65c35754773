// BenchPassThrough: the bare hop the LossyChannel is compared with (bench_util.hpp has the set).
#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>
#include <ros/ros.h>
#include <topic_tools/shape_shifter.h>

#include "networked_estimation/Measurement.h"

namespace networked_estimation
{

class BenchPassThrough : public nodelet::Nodelet
{
private:
  void onInit() override
  {
    ros::NodeHandle& nh = getNodeHandle();
    getPrivateNodeHandle().param("queue_size", queue_size_, 1000);
    bool typed = false;
    getPrivateNodeHandle().param("typed", typed, false);
    if (typed)  // Measurement in, the same object out: the cheapest nodelet hop there is
    {
      pub_ = nh.advertise<Measurement>("out", static_cast<uint32_t>(queue_size_));
      sub_ = nh.subscribe<Measurement>(
          "in", static_cast<uint32_t>(queue_size_), [this](const Measurement::ConstPtr& m) { pub_.publish(m); },
          ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
    }
    else  // any type (ShapeShifter), as the LossyChannel
      sub_ = nh.subscribe("in", static_cast<uint32_t>(queue_size_), &BenchPassThrough::onMessage, this,
                          ros::TransportHints().tcpNoDelay());
    NODELET_INFO("BenchPassThrough %s -> %s", nh.resolveName("in").c_str(), nh.resolveName("out").c_str());
  }

  // The nodelet's callback queue is single-threaded: no two calls overlap, no lock needed.
  void onMessage(const ros::MessageEvent<topic_tools::ShapeShifter const>& event)
  {
    const topic_tools::ShapeShifter::ConstPtr& msg = event.getConstMessage();
    if (!advertised_)
    {
      const auto& header = event.getConnectionHeader();
      const auto latch = header.find("latching");
      pub_ = msg->advertise(getNodeHandle(), "out", static_cast<uint32_t>(queue_size_),
                            latch != header.end() && latch->second == "1");
      advertised_ = true;
    }
    pub_.publish(msg);
  }

  int queue_size_ = 1000;
  bool advertised_ = false;
  ros::Subscriber sub_;
  ros::Publisher pub_;
};

}  // namespace networked_estimation

PLUGINLIB_EXPORT_CLASS(networked_estimation::BenchPassThrough, nodelet::Nodelet)
