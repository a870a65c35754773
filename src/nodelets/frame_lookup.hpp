// The Estimator's tf lookups, an owned part of the nodelet: world_frame and base_link_frame, and a
// tf2 buffer with its listener, made on first use (a configuration with no frames to transform
// listens to no tf).
#pragma once

#include <geometry_msgs/TransformStamped.h>
#include <ros/ros.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <memory>
#include <mutex>
#include <string>

#include "dispatch_thread.hpp"
#include "frame_transforms.hpp"

namespace networked_estimation
{

class FrameLookup
{
public:
  void configure(ros::NodeHandle nh, const std::string& world, const std::string& base)
  {
    nh_ = nh;
    frames_.world = world;
    frames_.base = base;
  }

  /// The frames, with the buffer and its listener made on the first call (any thread).
  const Frames& get()
  {
    std::call_once(made_, [this] { make(); });
    return frames_;
  }

private:
  void make()
  {
    buffer_ = std::make_unique<tf2_ros::Buffer>();
    // tf messages read where they arrive (spin_thread = false, an InlineQueue): no dedicated
    // listener thread waking 100 times a second when no tf flows, and no hand-off to the manager's
    // threads for each (the Estimator's own tf comes back 20 times a second). The callback only
    // stores the transforms under the buffer's lock, under which nothing is published.
    ros::NodeHandle inline_nh(nh_);
    inline_nh.setCallbackQueue(&queue_);
    listener_ = std::make_unique<tf2_ros::TransformListener>(*buffer_, inline_nh, false);
    tf2_ros::Buffer* buffer = buffer_.get();
    frames_.lookup = [buffer](const std::string& target, const std::string& source, const ros::Time& stamp,
                              tf2::Transform& out, std::string& why)
    {
      try
      {
        const geometry_msgs::TransformStamped t = buffer->lookupTransform(target, source, stamp);
        const auto& r = t.transform.rotation;
        const auto& x = t.transform.translation;
        out = tf2::Transform(tf2::Quaternion(r.x, r.y, r.z, r.w), tf2::Vector3(x.x, x.y, x.z));
        return true;
      }
      catch (const tf2::TransformException& e)
      {
        why = "no transform " + target + " <- " + source + " at the message's stamp: " + e.what();
        return false;
      }
    };
  }

  ros::NodeHandle nh_;
  std::once_flag made_;
  Frames frames_;
  InlineQueue queue_;  // before the listener: it outlives the listener's subscriptions
  std::unique_ptr<tf2_ros::Buffer> buffer_;
  std::unique_ptr<tf2_ros::TransformListener> listener_;
};

}  // namespace networked_estimation
