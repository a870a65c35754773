// The Estimator's tf, as robot_localization does it: when the estimate drives base_link itself
// (~child_frame_id = ~base_link_frame), base_link never gets a second parent. Header-only and
// master-free: the decision takes what tf knows about base_link (its parent and who broadcasts it).
#pragma once

#include <tf2/LinearMath/Transform.h>
#include <yaml-cpp/yaml.h>

#include <string>

namespace networked_estimation
{

struct TfPlan
{
  enum class Kind
  {
    DIRECT,       ///< world_frame -> child (the estimate's own frame, or base_link when nobody else parents it)
    MAP_TO_ODOM,  ///< world_frame (map) -> odom_frame, from the estimate and the existing odom -> base_link
    NONE          ///< base_link already has another parent: publish nothing (reason says whose)
  };
  Kind kind = Kind::DIRECT;
  std::string reason;
};

/// `parent`, `broadcaster`: base_link's parent in tf and its broadcaster (empty when none); `self`:
/// this node's name.
inline TfPlan planTf(const std::string& world, const std::string& odom, const std::string& base,
                     const std::string& child, const std::string& parent, const std::string& broadcaster,
                     const std::string& self)
{
  TfPlan plan;
  if (child != base || parent.empty() || broadcaster == self)
    return plan;  // our own frame, or base_link is ours to parent
  if (parent == odom && world != odom)
  {
    plan.kind = TfPlan::Kind::MAP_TO_ODOM;
    return plan;
  }
  plan.kind = TfPlan::Kind::NONE;
  plan.reason = parent + " -> " + base + " is published by " + broadcaster + ": not giving " + base +
                " a second parent (" + world + ")";
  return plan;
}

/// world <- odom from world <- base (the estimate) and odom <- base (the robot's odometry).
inline tf2::Transform mapToOdom(const tf2::Transform& world_base, const tf2::Transform& odom_base)
{
  return world_base * odom_base.inverse();
}

/// base_link's parent and broadcaster from tf2's allFramesAsYAML() (empty when unknown).
inline void parentOf(const std::string& frames_yaml, const std::string& frame, std::string& parent,
                     std::string& broadcaster)
{
  parent.clear();
  broadcaster.clear();
  try
  {
    const YAML::Node all = YAML::Load(frames_yaml);
    const YAML::Node f = all[frame];
    if (f && f["parent"])
      parent = f["parent"].as<std::string>();
    if (f && f["broadcaster"])
      broadcaster = f["broadcaster"].as<std::string>();
  }
  catch (const YAML::Exception&)
  {
  }
}

}  // namespace networked_estimation
