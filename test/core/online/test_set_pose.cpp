// set_pose: the estimate a pose resets to (poseReset) and the online estimator starting over from
// a given estimate (OnlineEstimator::setEstimate).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "networked_estimation/common/error.hpp"
#include "networked_estimation/estimators/estimator.hpp"
#include "networked_estimation/online/online_estimator.hpp"
#include "networked_estimation/online/set_pose.hpp"
#include "test_support.hpp"

namespace ne = networked_estimation;

namespace
{

/// [x, y, yaw, vx, vy, vyaw] at 20 Hz, yaw an angle; position and heading seen by one sensor.
ne::Model planar()
{
  ne::Model m;
  m.name = "planar";
  const double T = 0.05;
  m.A = Eigen::MatrixXd::Identity(6, 6);
  for (int i = 0; i < 3; ++i)
    m.A(i, i + 3) = T;
  m.B = Eigen::MatrixXd::Identity(6, 6);
  m.Q = 0.01 * Eigen::MatrixXd::Identity(6, 6);
  m.C = Eigen::MatrixXd::Zero(3, 6);
  m.C.leftCols(3).setIdentity();
  m.R = 0.1 * Eigen::MatrixXd::Identity(3, 3);
  m.sensors = {{"pose", 0, 3}};
  m.x0 = (Eigen::VectorXd(6) << 0.1, 0.2, 0.3, 0.4, 0.5, 0.6).finished();
  m.P0 = 2.0 * Eigen::MatrixXd::Identity(6, 6);
  m.P0(0, 3) = m.P0(3, 0) = 0.5;   // a position-velocity correlation the reset must cut
  m.P0(3, 4) = m.P0(4, 3) = 0.25;  // a velocity-velocity one it keeps
  m.Bu = Eigen::MatrixXd(6, 0);
  m.angles = {2};
  ne::validateModel(m, "planar");
  return m;
}

ne::StateMap xyYaw()
{
  ne::StateMap s;
  s.x = 0;
  s.y = 1;
  s.yaw = 2;
  return s;
}

ne::PoseWithCovariance pose(double x, double y, double yaw)
{
  ne::PoseWithCovariance p;
  p.pose = {x, y, 7.0, 0.1, 0.2, yaw};  // z, roll and pitch are not mapped: ignored
  p.covariance[0] = 0.04;
  p.covariance[1] = p.covariance[6] = 0.01;  // x-y
  p.covariance[7] = 0.09;
  p.covariance[35] = 0.16;
  p.covariance[5] = p.covariance[30] = -0.02;  // x-yaw
  p.covariance[14] = 99.0;                     // z: not mapped
  return p;
}

std::string errorOf(const ne::Model& m, const ne::StateMap& s, const ne::PoseWithCovariance& p)
{
  Eigen::VectorXd x;
  Eigen::MatrixXd P;
  try
  {
    ne::poseReset(m, s, p, x, P);
  }
  catch (const ne::InputError& e)
  {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(SetPose, MappedEntriesTakeThePoseTheRestStartsOver)
{
  const ne::Model m = planar();
  Eigen::VectorXd x;
  Eigen::MatrixXd P;
  ne::poseReset(m, xyYaw(), pose(3.0, -4.0, 4.0), x, P);
  EXPECT_DOUBLE_EQ(x[0], 3.0);
  EXPECT_DOUBLE_EQ(x[1], -4.0);
  EXPECT_NEAR(x[2], 4.0 - 2.0 * M_PI, 1e-15);  // the heading wrapped into (-pi, pi]
  EXPECT_EQ(x.tail(3), m.x0.tail(3));          // velocities back to x0
  // The pose block: rows and columns 0, 1, 5 of the message's covariance.
  EXPECT_DOUBLE_EQ(P(0, 0), 0.04);
  EXPECT_DOUBLE_EQ(P(1, 1), 0.09);
  EXPECT_DOUBLE_EQ(P(2, 2), 0.16);
  EXPECT_DOUBLE_EQ(P(0, 1), 0.01);
  EXPECT_DOUBLE_EQ(P(0, 2), -0.02);
  EXPECT_DOUBLE_EQ(P(2, 0), -0.02);
  // The rest from P0, uncorrelated with the pose.
  EXPECT_EQ(P.bottomRightCorner(3, 3), m.P0.bottomRightCorner(3, 3));
  EXPECT_EQ(P.topRightCorner(3, 3), Eigen::MatrixXd::Zero(3, 3));
  EXPECT_EQ(P.bottomLeftCorner(3, 3), Eigen::MatrixXd::Zero(3, 3));
  // Only y mapped: x keeps x0 and P0's row, except its correlation with y.
  ne::StateMap onlyY;
  onlyY.y = 1;
  ne::poseReset(m, onlyY, pose(3.0, -4.0, 1.0), x, P);
  EXPECT_DOUBLE_EQ(x[0], 0.1);
  EXPECT_DOUBLE_EQ(x[1], -4.0);
  EXPECT_DOUBLE_EQ(P(0, 3), 0.5);
  EXPECT_DOUBLE_EQ(P(1, 1), 0.09);
}

// With roll and pitch mapped (a built-in motion's default), they take the pose's values, wrapped,
// and their rows of the message's covariance.
TEST(SetPose, RollAndPitchWhenMapped)
{
  ne::Model m = planar();
  ne::StateMap s;
  s.x = 0;
  s.roll = 1;
  s.pitch = 2;
  m.angles = {1, 2};
  ne::PoseWithCovariance p = pose(3.0, -4.0, 0.5);
  p.pose[3] = 0.1;
  p.pose[4] = 3.5;                             // beyond pi: wrapped
  p.covariance[21] = 0.25;                     // roll
  p.covariance[28] = 0.36;                     // pitch
  p.covariance[22] = p.covariance[27] = 0.03;  // roll-pitch
  p.covariance[3] = p.covariance[18] = 0.01;   // x-roll
  Eigen::VectorXd x;
  Eigen::MatrixXd P;
  ne::poseReset(m, s, p, x, P);
  EXPECT_DOUBLE_EQ(x[0], 3.0);
  EXPECT_DOUBLE_EQ(x[1], 0.1);
  EXPECT_NEAR(x[2], 3.5 - 2.0 * M_PI, 1e-15);
  EXPECT_DOUBLE_EQ(P(1, 1), 0.25);
  EXPECT_DOUBLE_EQ(P(2, 2), 0.36);
  EXPECT_DOUBLE_EQ(P(1, 2), 0.03);
  EXPECT_DOUBLE_EQ(P(0, 1), 0.01);
}

TEST(SetPose, BadPosesAreRefusedNamingTheProblem)
{
  const ne::Model m = planar();
  EXPECT_NE(errorOf(m, ne::StateMap{}, pose(1, 2, 3)).find("state_mapping maps none of x, y, z, roll, pitch, yaw"),
            std::string::npos);
  EXPECT_NE(errorOf(m, xyYaw(), pose(std::nan(""), 2, 3)).find("x is not finite"), std::string::npos);
  EXPECT_NE(errorOf(m, xyYaw(), pose(1, 2, INFINITY)).find("yaw is not finite"), std::string::npos);
  ne::PoseWithCovariance p = pose(1, 2, 3);
  p.covariance[35] = std::nan("");
  EXPECT_NE(errorOf(m, xyYaw(), p).find("covariance of yaw and yaw is not finite"), std::string::npos);
  p = pose(1, 2, 3);
  p.covariance[1] = 0.5;  // x-y 0.5 vs y-x 0.01
  EXPECT_NE(errorOf(m, xyYaw(), p).find("not symmetric"), std::string::npos);
  p = pose(1, 2, 3);
  p.covariance[1] = p.covariance[6] = 1.0;  // |corr| > 1
  EXPECT_NE(errorOf(m, xyYaw(), p).find("not positive semidefinite"), std::string::npos);
  p = pose(1, 2, 3);
  p.covariance[14] = std::nan("");  // z is not mapped: its covariance is not read
  EXPECT_EQ(errorOf(m, xyYaw(), p), "");
}

// After setEstimate the next step predicts from (x, P): the same estimate as the estimator built
// with x0 = x, P0 = P, stepped on the same data; reset() goes back to the model's own x0.
TEST(SetPose, OnlineEstimatorStartsOverFromTheGivenEstimate)
{
  const ne::Model m = planar();
  ne::EstimatorSettings st;
  st.algorithm = ne::Algorithm::KFIO;
  ne::OnlineOptions o;
  o.late_policy = ne::LatePolicy::REWIND;
  ne::OnlineEstimator online(m, st, o);
  online.start(1);
  const double y1[3] = {1.0, 1.0, 0.5};
  ASSERT_EQ(online.offerMeasurement({1, 0, y1, 3}).offer, ne::Offer::ACCEPTED);
  online.process();
  online.process();  // step 2: a loss

  Eigen::VectorXd x;
  Eigen::MatrixXd P;
  ne::poseReset(m, xyYaw(), pose(3.0, -4.0, 1.0), x, P);
  online.setEstimate(x, P);
  EXPECT_EQ(online.counters().estimates_set, 1u);
  const double y3[3] = {3.1, -3.9, 1.1};
  ASSERT_EQ(online.offerMeasurement({3, 0, y3, 3}).offer, ne::Offer::ACCEPTED);
  online.process();

  ne::Model from = m;
  from.x0 = x;
  from.P0 = P;
  auto ref = ne::makeEstimator(from, st);
  ne::Sample s;
  s.gamma = true;
  s.y = Eigen::Map<const Eigen::VectorXd>(y3, 3);
  ref->step(s);
  EXPECT_LT((online.estimator().state() - ref->state()).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((online.estimator().covariance() - ref->covariance()).cwiseAbs().maxCoeff(), 1e-12);

  // Data for a step taken before the pose was set is late: the history starts at the pose.
  EXPECT_EQ(online.offerMeasurement({2, 0, y1, 3}).offer, ne::Offer::LATE_DROPPED);

  // reset(): the model's own x0, P0 again (one predicted step from them).
  online.reset();
  online.start(1);
  online.process();
  auto fresh = ne::makeEstimator(m, st);
  ne::Sample loss;
  loss.gamma = false;
  loss.y = Eigen::VectorXd::Constant(3, std::numeric_limits<double>::quiet_NaN());
  fresh->step(loss);
  EXPECT_LT((online.estimator().state() - fresh->state()).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(SetPose, BadEstimatesLeaveTheFilterAsItWas)
{
  const ne::Model m = planar();
  ne::EstimatorSettings st;
  st.algorithm = ne::Algorithm::KFIO;
  ne::OnlineEstimator online(m, st, ne::OnlineOptions{});
  const Eigen::VectorXd before = online.estimator().state();
  const Eigen::MatrixXd I = Eigen::MatrixXd::Identity(6, 6);
  auto refused = [&](const Eigen::VectorXd& x, const Eigen::MatrixXd& P, const std::string& what)
  {
    try
    {
      online.setEstimate(x, P);
    }
    catch (const ne::InputError& e)
    {
      return std::string(e.what()).find(what) != std::string::npos;
    }
    return false;
  };
  EXPECT_TRUE(refused(Eigen::VectorXd::Zero(5), I, "expected a state of 6 entries and a 6 x 6 covariance, found 5"));
  Eigen::VectorXd nan = Eigen::VectorXd::Zero(6);
  nan[4] = std::nan("");
  EXPECT_TRUE(refused(nan, I, "must be finite"));
  Eigen::MatrixXd asym = I;
  asym(0, 1) = 0.3;
  EXPECT_TRUE(refused(Eigen::VectorXd::Zero(6), asym, "not symmetric"));
  EXPECT_TRUE(refused(Eigen::VectorXd::Zero(6), -I, "not positive semidefinite"));
  EXPECT_EQ(online.estimator().state(), before);
  EXPECT_EQ(online.counters().estimates_set, 0u);
  // The symmetry test is relative (1e-9 of the largest entry), as set_pose's: a covariance in large
  // units is symmetric, and a rounding-level asymmetry (P computed as A P A') is not a refusal.
  EXPECT_FALSE(refused(Eigen::VectorXd::Zero(6), 1e10 * I, "not symmetric"));
  Eigen::MatrixXd rounded = I;
  rounded(0, 1) = 1e-13;
  EXPECT_FALSE(refused(Eigen::VectorXd::Zero(6), rounded, "not symmetric"));
  EXPECT_EQ(online.counters().estimates_set, 2u);
}
