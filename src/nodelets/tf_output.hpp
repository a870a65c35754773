// The Estimator's tf, as robot_localization does it: when the estimate drives base_link itself
// (~child_frame_id = ~base_link_frame), base_link never gets a second parent. Header-only and
// master-free: the decision takes what /tf says about base_link (its parent and who broadcasts it,
// from other publishers than the Estimator itself).
#pragma once

#include <geometry_msgs/TransformStamped.h>
#include <tf2/LinearMath/Transform.h>

#include <cmath>
#include <deque>
#include <limits>
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

/// Which transforms on /tf are the Estimator's own. A transform it receives back cannot be told by
/// its publisher's name (a nodelet's own messages come back without one: "unknown_publisher", as
/// would another nodelet's in the same manager), so it remembers what it sent: the last kKept
/// transforms (frames, stamp and value). One on /tf that is not among them is another publisher's.
class OwnTransforms
{
public:
  static constexpr std::size_t kKept = 200;

  void sent(const geometry_msgs::TransformStamped& t)
  {
    sent_.push_back(t);
    if (sent_.size() > kKept)
      sent_.pop_front();
  }
  bool ours(const geometry_msgs::TransformStamped& t) const
  {
    for (auto it = sent_.rbegin(); it != sent_.rend(); ++it)
      if (it->header.stamp == t.header.stamp && it->header.frame_id == t.header.frame_id &&
          it->child_frame_id == t.child_frame_id && same(it->transform, t.transform))
        return true;
    return false;
  }

private:
  static bool same(const geometry_msgs::Transform& a, const geometry_msgs::Transform& b)
  {
    const double d[7] = {a.translation.x - b.translation.x, a.translation.y - b.translation.y,
                         a.translation.z - b.translation.z, a.rotation.x - b.rotation.x,
                         a.rotation.y - b.rotation.y,       a.rotation.z - b.rotation.z,
                         a.rotation.w - b.rotation.w};
    for (double x : d)
      if (!(std::fabs(x) <= 1e-9))
        return false;
    return true;
  }
  std::deque<geometry_msgs::TransformStamped> sent_;
};

/// base_link's parent as other publishers give it on /tf (and /tf_static): the latest one seen,
/// who sent it, and when (wall time, s). It counts for kFresh seconds (a static one for good), so
/// that a robot's odometry that pauses briefly does not get a second parent next to it.
struct ForeignParent
{
  static constexpr double kFresh = 10.0;
  std::string parent, publisher;
  double seen = -std::numeric_limits<double>::infinity();

  /// A transform on /tf (or /tf_static, `static_tf`) from `publisher`, received at wall time
  /// `now`: remembered when it is base_link's (`base`) and not ours.
  void saw(const geometry_msgs::TransformStamped& t, const std::string& base, const OwnTransforms& own,
           const std::string& from, double now, bool static_tf)
  {
    if (t.child_frame_id != base || own.ours(t))
      return;
    parent = t.header.frame_id;
    publisher = from == "unknown_publisher" ? "another publisher in this process" : from;
    seen = static_tf ? std::numeric_limits<double>::infinity() : now;
  }
  /// The parent in force at wall time `now` (empty: none).
  std::string at(double now) const { return now - seen <= kFresh ? parent : std::string(); }
};

}  // namespace networked_estimation
