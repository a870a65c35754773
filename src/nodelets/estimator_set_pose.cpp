// The Estimator's set_pose topic and service (robot_localization's): a pose, with its covariance,
// the filter starts over from (online/set_pose.hpp).
#include <tf2/LinearMath/Matrix3x3.h>

#include "estimator_nodelet.hpp"
#include "frame_transforms.hpp"
#include "networked_estimation/online/set_pose.hpp"

namespace networked_estimation
{

void EstimatorNodelet::startSetPose(ros::NodeHandle& nh)
{
  set_pose_sub_ = nh.subscribe<geometry_msgs::PoseWithCovarianceStamped>(
      "set_pose", 10,
      [this](const geometry_msgs::PoseWithCovarianceStamped::ConstPtr& m)
      {
        std::string why;
        if (!setPose(*m, why))
          NODELET_WARN("Estimator: set_pose refused: %s", why.c_str());
      });
  set_pose_srv_ = nh.advertiseService<SetPose::Request, SetPose::Response>(
      "set_pose",
      [this](SetPose::Request& req, SetPose::Response& res)
      {
        res.success = setPose(req.pose, res.message);
        if (!res.success)
          NODELET_WARN("Estimator: set_pose refused: %s", res.message.c_str());
        return true;
      });
}

bool EstimatorNodelet::setPose(const geometry_msgs::PoseWithCovarianceStamped& in, std::string& why)
{
  geometry_msgs::PoseWithCovarianceStamped m = in;
  const double n2 =
      m.pose.pose.orientation.x * m.pose.pose.orientation.x + m.pose.pose.orientation.y * m.pose.pose.orientation.y +
      m.pose.pose.orientation.z * m.pose.pose.orientation.z + m.pose.pose.orientation.w * m.pose.pose.orientation.w;
  if (!(n2 > 0.0) || !std::isfinite(n2))
  {
    why = "the orientation is not a rotation (a zero or non-finite quaternion)";
    ++set_pose_refused_;
    return false;
  }
  // Into the world frame (the latest transform: a pose set by hand has no meaningful past).
  m.header.stamp = ros::Time(0);
  if (!m.header.frame_id.empty() && m.header.frame_id != config_.world_frame &&
      !poseToWorld(frames_.get(), m.header.frame_id, m.header.stamp, m.pose.pose, why, m.pose.covariance.data()))
  {
    ++set_pose_refused_;
    return false;
  }
  PoseWithCovariance p;
  p.pose[0] = m.pose.pose.position.x;
  p.pose[1] = m.pose.pose.position.y;
  p.pose[2] = m.pose.pose.position.z;
  tf2::Matrix3x3(toTf(m.pose.pose.orientation).normalized()).getRPY(p.pose[3], p.pose[4], p.pose[5]);
  std::copy(m.pose.covariance.begin(), m.pose.covariance.end(), p.covariance.begin());
  try
  {
    std::lock_guard<std::mutex> lock(mutex_);
    Eigen::VectorXd x;
    Eigen::MatrixXd P;
    poseReset(stream_->online().model(), config_.state_map, p, x, P);
    stream_->setEstimate(x, P);
  }
  catch (const std::exception& e)
  {
    why = e.what();
    ++set_pose_refused_;
    return false;
  }
  NODELET_INFO("Estimator: pose set to x %.3f, y %.3f, z %.3f, yaw %.3f (in %s)", p.pose[0], p.pose[1], p.pose[2],
               p.pose[5], config_.world_frame.c_str());
  why = "pose set";
  return true;
}

}  // namespace networked_estimation
