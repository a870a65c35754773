#include "networked_estimation/online/set_pose.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "networked_estimation/common/angles.hpp"
#include "networked_estimation/common/covariance.hpp"
#include "networked_estimation/common/error.hpp"

namespace networked_estimation
{

void poseReset(const Model& model, const StateMap& map, const PoseWithCovariance& in, Eigen::VectorXd& x,
               Eigen::MatrixXd& P)
{
  // (state entry, index into the pose's six) of each mapped pose quantity
  std::vector<std::pair<int, int>> entries;
  const std::pair<int, int> candidates[] = {{map.x, 0},    {map.y, 1},     {map.z, 2},
                                            {map.roll, 3}, {map.pitch, 4}, {map.yaw, 5}};
  for (const auto& c : candidates)
    if (c.first >= 0)
      entries.push_back(c);
  if (entries.empty())
    throw InputError("set_pose: state_mapping maps none of x, y, z, roll, pitch, yaw: nothing to set");
  const char* names[] = {"x", "y", "z", "roll", "pitch", "yaw"};
  const std::size_t e = entries.size();
  Eigen::MatrixXd block(e, e);
  for (std::size_t i = 0; i < e; ++i)
  {
    const int a = entries[i].second;
    if (!std::isfinite(in.pose[a]))
      throw InputError(std::string("set_pose: ") + names[a] + " is not finite");
    for (std::size_t j = 0; j < e; ++j)
    {
      const double v = in.covariance[static_cast<std::size_t>(a * 6 + entries[j].second)];
      if (!std::isfinite(v))
        throw InputError(std::string("set_pose: covariance of ") + names[a] + " and " + names[entries[j].second] +
                         " is not finite");
      block(i, j) = v;
    }
  }
  const CovarianceCheck check = checkCovariance(block, Definiteness::SEMIDEFINITE);
  if (check.problem == CovarianceCheck::Problem::NOT_SYMMETRIC)
    throw InputError("set_pose: the covariance of the pose is not symmetric");
  if (!check.ok())
    throw InputError("set_pose: the covariance of the pose is not positive semidefinite (smallest eigenvalue " +
                     std::to_string(check.smallest) + ")");

  x = model.x0;
  P = model.P0;
  for (std::size_t i = 0; i < e; ++i)
  {
    const int s = entries[i].first;
    P.row(s).setZero();
    P.col(s).setZero();
  }
  for (std::size_t i = 0; i < e; ++i)
  {
    const int s = entries[i].first;
    x[s] = entries[i].second >= 3 ? wrapAngle(in.pose[entries[i].second]) : in.pose[entries[i].second];
    for (std::size_t j = 0; j < e; ++j)
      P(s, entries[j].first) = 0.5 * (block(i, j) + block(j, i));
  }
}

}  // namespace networked_estimation
