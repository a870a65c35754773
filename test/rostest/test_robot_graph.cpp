// rostest: a simulated robot on standard ROS message types (estimator_robot_bag.test). The
// PlantSimulator publishes NavSatFix (2 Hz), Imu (10 Hz) and Odometry (50 Hz); estimators read them
// straight (clean), through LossyChannels (lossy), and from a bag replayed through the same links
// (replayed). Private parameters of the test node: model (file), settings (kfio settings file),
// steps (plant steps).
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <nav_msgs/Odometry.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/NavSatFix.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <type_traits>
#include <vector>

#include "graph_test_support.hpp"
#include "sensor_adapters.hpp"
#include "networked_estimation/ChannelEvent.h"
#include "networked_estimation/Estimate.h"
#include "networked_estimation/PlantState.h"
#include "networked_estimation/config/model.hpp"
#include "networked_estimation/io/replay_csv.hpp"

namespace ne = networked_estimation;
using ne::ChannelEvent;
using ne::Estimate;
using ne::PlantState;

namespace
{

constexpr double kPeriod = 0.02;
const std::vector<double> kDatum = {48.137, 11.575, 520.0};

std::map<long, Estimate> byStep(Collector<Estimate>& c)
{
  std::lock_guard<std::mutex> lock(c.mutex);
  std::map<long, Estimate> out;
  for (const Estimate& e : c.msgs)
    EXPECT_TRUE(out.emplace(static_cast<long>(e.step), e).second) << "step " << e.step << " published twice";
  return out;
}

/// "<value> [<lower>, <upper>] (<n> samples)" of the link stability diagnostic: value and n.
bool parseRate(const std::string& text, double& value, long& n)
{
  double lo = 0, hi = 0;
  return std::sscanf(text.c_str(), "%lf [%lf, %lf] (%ld samples)", &value, &lo, &hi, &n) == 4;
}

/// A channel's events from its first delivery on (before it the estimator cannot know the sensor's
/// phase, so those steps are not due there): how many entered and how many were delivered.
struct LinkCount
{
  long sent = 0, delivered = 0;
};
LinkCount countFromFirstDelivery(Collector<ChannelEvent>& c)
{
  std::lock_guard<std::mutex> lock(c.mutex);
  std::map<std::uint64_t, bool> by_seq;
  for (const ChannelEvent& e : c.msgs)
    by_seq[e.seq] = e.outcome == ChannelEvent::DELIVERED;
  LinkCount n;
  bool started = false;
  for (const auto& kv : by_seq)
  {
    started = started || kv.second;
    if (!started)
      continue;
    ++n.sent;
    n.delivered += kv.second ? 1 : 0;
  }
  EXPECT_EQ(by_seq.size(), c.msgs.size()) << "events: a sequence number twice";
  if (!by_seq.empty())
    EXPECT_EQ(by_seq.rbegin()->first + 1, by_seq.size()) << "events: a sequence number missing";
  return n;
}

/// What one estimator was given at step k: y (NaN where a sensor is missing) and, per sensor, R's
/// block from the message (empty: the model's).
struct StepInput
{
  Eigen::VectorXd y;
  std::vector<Eigen::MatrixXd> R;
};

/// The step of a stamp on the estimator's grid (step 1 at t1).
long stepOf(const ros::Time& stamp, const ros::Time& t1)
{
  return std::lround((stamp - t1).toSec() / kPeriod) + 1;
}

template <class M>
void addSensor(std::map<long, StepInput>& in, Collector<M>& c, const ne::Model& model, std::size_t s,
               const ne::SensorInput& input, const ros::Time& t1)
{
  std::lock_guard<std::mutex> lock(c.mutex);
  const ne::Sensor& sn = model.sensors[s];
  for (const M& m : c.msgs)
  {
    const long k = stepOf(m.header.stamp, t1);
    StepInput& si = in[k];
    if (si.y.size() == 0)
    {
      si.y = Eigen::VectorXd::Constant(model.m(), std::nan(""));
      si.R.assign(model.sensors.size(), Eigen::MatrixXd());
    }
    std::vector<double> y(static_cast<std::size_t>(sn.size)), R(static_cast<std::size_t>(sn.size * sn.size));
    std::string why;
    ne::MessageView v;
    Eigen::Vector3d enu;
    if constexpr (!std::is_same<M, sensor_msgs::NavSatFix>::value)
      v = ne::view(m);
    else
    {
      ne::NavSatFixEnu conv(kDatum);
      bool new_datum = false;
      ASSERT_TRUE(conv.convert(m, enu, why, new_datum)) << why;
      v.enu = &enu;
      v.enu_cov = m.position_covariance.data();
      v.enu_cov_type = m.position_covariance_type;
    }
    ASSERT_TRUE(ne::readFields(v, input.fields, y.data(), why)) << why;
    for (int i = 0; i < sn.size; ++i)
      si.y(sn.offset + i) = y[static_cast<std::size_t>(i)];
    if (input.message_covariance)
    {
      ASSERT_EQ(ne::readCovariance(input.type, v, input.fields, R.data(), why), ne::CovarianceRead::OK) << why;
      si.R[s] = Eigen::Map<const Eigen::MatrixXd>(R.data(), sn.size, sn.size);  // symmetric: either order
    }
  }
}

ne::SensorInput inputOf(ne::InputType type, const std::vector<std::string>& fields, bool message_covariance)
{
  ne::SensorInput in;
  in.type = type;
  for (const std::string& f : fields)
    in.fields.push_back(ne::inputFieldFromString(type, f, "test"));
  in.message_covariance = message_covariance;
  return in;
}

}  // namespace

// Clean: an estimate at every one of the plant's steps, every due sample arrives, the link verdict
// OK. Lossy: each sensor's due samples and arrivals in the link diagnostic equal what its channel
// did (events), exactly; the GNSS below its critical rate 1 - 1/1.01^50 makes the verdict ERROR;
// and the estimates equal the offline `replay` tool run on what the estimator received (y, the
// messages' R_k as r columns, '-' where a sensor was not due) to 1e-12. Replayed: the bag through
// the same links gives the same estimates, step by step.
TEST(RobotGraph, SimulatedRobotThroughLossyLinksAndABag)
{
  ros::NodeHandle nh, pnh("~");
  std::string model_file, settings_file;
  int steps = 0;
  ASSERT_TRUE(pnh.getParam("model", model_file) && pnh.getParam("settings", settings_file) &&
              pnh.getParam("steps", steps));
  const ne::Model model = ne::loadModel(model_file);
  const std::vector<std::string> names = {"gps", "imu", "odom"};
  for (std::size_t s = 0; s < names.size(); ++s)
    ASSERT_EQ(model.sensors[s].name, names[s]);
  const long every[3] = {25, 5, 1};

  Collector<Estimate> clean(nh, "clean/estimate"), lossy(nh, "lossy/estimate"), replayed(nh, "replayed/estimate");
  Collector<PlantState> truth(nh, "plant/state");
  Collector<sensor_msgs::NavSatFix> rx_fix(nh, "/lossy/fix");
  Collector<sensor_msgs::Imu> rx_imu(nh, "/lossy/imu");
  Collector<nav_msgs::Odometry> rx_odom(nh, "/lossy/odom");
  Collector<ChannelEvent> ev_gps(nh, "/gps_link/events"), ev_imu(nh, "/imu_link/events"),
      ev_odom(nh, "/odom_link/events");
  DiagnosticsProbe clean_link(nh, "clean/estimator: link stability"), clean_est(nh, "clean/estimator: estimator");
  DiagnosticsProbe lossy_link(nh, "lossy/estimator: link stability"), lossy_est(nh, "lossy/estimator: estimator");

  char dir_template[] = "/tmp/ne_robot_bag_XXXXXX";
  const std::string dir = mkdtemp(dir_template);
  const std::string bag = dir + "/robot.bag";
  // The recorder starts before the plant (start_delay 6 s).
  ASSERT_EQ(std::system(
                ("rosbag record -q -O " + bag + " /fix /imu /odom __name:=bag_recorder > " + dir + "/record.log 2>&1 &")
                    .c_str()),
            0);
  ASSERT_TRUE(waitFor([&] { return truth.size() >= static_cast<std::size_t>(steps + 1); }, 90.0))
      << "plant states: " << truth.size();
  // The clock runs 1 s (sim) past the last step: every step is finalised at its deadline (0.2 s).
  ASSERT_TRUE(waitFor([&] { return clean.size() >= static_cast<std::size_t>(steps); }, 20.0)) << clean.size();
  ros::WallDuration(2.5).sleep();  // the last deliveries and a diagnostics period (1 s)
  ASSERT_EQ(std::system("rosnode kill /bag_recorder > /dev/null 2>&1"), 0);

  // After the plant's last step the clock runs on (clock_tail): the estimators keep predicting, and
  // the sensors due at those steps count as not arrived (nothing tells an estimator that a plant
  // stopped). `tail(s, last, K)`: the due steps of sensor s after step `last` up to K.
  ros::Time plant_end;
  {
    std::lock_guard<std::mutex> lock(truth.mutex);
    plant_end = truth.msgs.back().header.stamp;
  }
  auto tail = [&](std::size_t s, long first_due, long last, long K)
  {
    long n = 0;
    for (long k = last + 1; k <= K; ++k)
      n += (k - first_due) % every[s] == 0 ? 1 : 0;
    return n;
  };

  // Clean: an estimate at every step 1..N (and on through the tail); every sample the plant sent
  // arrived; verdict OK.
  const std::map<long, Estimate> C = byStep(clean);
  ASSERT_EQ(C.begin()->first, 1);
  const long KC = C.rbegin()->first;
  ASSERT_EQ(static_cast<long>(C.size()), KC) << "clean: a step without an estimate";
  ASSERT_GE(KC, steps);
  ASSERT_EQ(C.at(steps).header.stamp, plant_end) << "clean's step N is the plant's last step";
  EXPECT_EQ(clean_est.get("steps"), KC);
  for (std::size_t s = 0; s < names.size(); ++s)
  {
    double value = 0;
    long n = 0;
    const std::string text = clean_link.text(names[s] + " arrival rate");
    ASSERT_TRUE(parseRate(text, value, n)) << text;
    const long sent = (steps - 1) / every[s] + 1;  // due at k = 1, 1 + every, ...
    EXPECT_EQ(n, sent + tail(s, 1, steps, KC)) << names[s] << ": " << text;
    EXPECT_EQ(std::lround(value * static_cast<double>(n)), sent) << names[s] << ": " << text;
  }
  EXPECT_TRUE(clean_link.levelIs(diagnostic_msgs::DiagnosticStatus::OK)) << clean_link.lastMessage();

  // Lossy: the link diagnostic's due samples and arrivals are the channels' events (from each
  // sensor's first delivery, when the estimator learns its phase), plus the tail.
  const std::map<long, Estimate> L = byStep(lossy);
  ASSERT_FALSE(L.empty());
  const long K = L.rbegin()->first;
  ASSERT_EQ(static_cast<long>(L.size()), K) << "lossy: a step without an estimate";
  const ros::Time t1 =
      L.begin()->second.header.stamp - ros::Duration(kPeriod * static_cast<double>(L.begin()->first - 1));
  const long last = stepOf(plant_end, t1);  // the plant's last step in lossy's numbering
  std::map<long, StepInput> in;
  addSensor(in, rx_fix, model, 0, inputOf(ne::InputType::NAVSATFIX, {"east", "north"}, true), t1);
  addSensor(in, rx_imu, model, 1, inputOf(ne::InputType::IMU, {"orientation.yaw"}, false), t1);
  addSensor(in, rx_odom, model, 2, inputOf(ne::InputType::ODOMETRY, {"pose.pose.position.x"}, true), t1);
  // A sensor is due at its own steps from its first sample on (its phase).
  long first[3] = {-1, -1, -1};
  for (const auto& kv : in)
    for (std::size_t s = 0; s < 3; ++s)
      if (first[s] < 0 && std::isfinite(kv.second.y(model.sensors[s].offset)))
        first[s] = kv.first;
  Collector<ChannelEvent>* events[3] = {&ev_gps, &ev_imu, &ev_odom};
  for (std::size_t s = 0; s < names.size(); ++s)
  {
    ASSERT_GE(first[s], 1) << names[s] << " never arrived";
    const LinkCount n = countFromFirstDelivery(*events[s]);
    double value = 0;
    long samples = 0;
    const std::string text = lossy_link.text(names[s] + " arrival rate");
    ASSERT_TRUE(parseRate(text, value, samples)) << text;
    EXPECT_EQ(samples, n.sent + tail(s, first[s], last, K)) << names[s] << ": " << text;
    EXPECT_EQ(std::lround(value * static_cast<double>(samples)), n.delivered) << names[s] << ": " << text;
  }
  // GNSS at about 0.15, below 0.392, and the interval of its estimate below it too: ERROR.
  EXPECT_TRUE(lossy_link.levelIs(diagnostic_msgs::DiagnosticStatus::ERROR)) << lossy_link.lastMessage();
  EXPECT_EQ(lossy_est.get("rejected"), 0.0);
  EXPECT_EQ(lossy_est.get("late dropped"), 0.0);

  // Online = offline: the replay tool on what `lossy` received.
  const std::string csv = dir + "/lossy_in.csv", out = dir + "/lossy_out.csv";
  {
    std::ofstream f(csv);
    ne::writeReplayInputHeader(f, model.m(), model.p(), false, ne::replayRColumns(model));
    for (long k = 1; k <= K; ++k)
    {
      StepInput si;
      auto it = in.find(k);
      if (it != in.end())
        si = it->second;
      else
      {
        si.y = Eigen::VectorXd::Constant(model.m(), std::nan(""));
        si.R.assign(3, Eigen::MatrixXd());
      }
      std::vector<bool> off(static_cast<std::size_t>(model.m()), false), given(3, false);
      Eigen::MatrixXd R = model.R;
      for (std::size_t s = 0; s < 3; ++s)
      {
        const ne::Sensor& sn = model.sensors[s];
        const bool due = first[s] >= 0 && k >= first[s] && (k - first[s]) % every[s] == 0;
        const bool has = std::isfinite(si.y(sn.offset));
        ASSERT_TRUE(due || !has) << names[s] << " arrived at step " << k << ", not one of its steps";
        for (int i = 0; i < sn.size; ++i)
          off[static_cast<std::size_t>(sn.offset + i)] = !due;
        if (has && si.R[s].size() > 0)
        {
          R.block(sn.offset, sn.offset, sn.size, sn.size) = si.R[s];
          given[s] = true;
        }
      }
      std::ostringstream tail;
      ne::writeReplayRowR(tail, model, R, given);
      ne::writeReplayInputRow(f, k, L.at(k).gamma, si.y, Eigen::VectorXd(), false, -1, &off, tail.str());
    }
  }
  const std::string cmd = "rosrun networked_estimation replay --model '" + model_file + "' --settings '" +
                          settings_file + "' --input '" + csv + "' --output '" + out + "'";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  const ne::ReplayOutput offline = ne::readReplayOutput(out);
  ASSERT_EQ(static_cast<long>(offline.rows.size()), K);
  double worst = 0.0;
  long fused_gps_with_own_R = 0;
  for (long k = 1; k <= K; ++k)
  {
    const Estimate& e = L.at(k);
    const ne::ReplayOutputRow& r = offline.rows[static_cast<std::size_t>(k - 1)];
    for (int i = 0; i < model.n(); ++i)
    {
      worst =
          std::max(worst, std::abs(e.state[static_cast<std::size_t>(i)] - r.x(i)) / std::max(1.0, std::abs(r.x(i))));
      for (int j = 0; j < model.n(); ++j)
        worst = std::max(worst, std::abs(e.covariance[static_cast<std::size_t>(i * model.n() + j)] - r.P(i, j)) /
                                    std::max(1.0, std::abs(r.P(i, j))));
    }
    auto it = in.find(k);
    fused_gps_with_own_R += it != in.end() && it->second.R[0].size() > 0 ? 1 : 0;
  }
  EXPECT_LE(worst, 1e-12) << "online vs replay (relative to max(1, |value|))";
  EXPECT_GT(fused_gps_with_own_R, 3);  // the comparison covers fixes with their own covariance

  // The bag through the same links into `replayed`: the same estimates. Its clock runs only as far
  // as the bag: the last steps (its budget, 1 s = 50 steps) may stay unfinalised there.
  ASSERT_TRUE(waitFor([&] { return std::ifstream(bag).good(); }, 20.0)) << "no closed bag at " << bag;
  ASSERT_EQ(std::system(("rosbag play -q --keep-alive --clock --hz=1000 -d 2 " + bag +
                         " /fix:=/replay/fix /imu:=/replay/imu /odom:=/replay/odom __name:=bag_player > " + dir +
                         "/play.log 2>&1 &")
                            .c_str()),
            0);
  const std::size_t want = static_cast<std::size_t>(last - 51);
  const bool all = waitFor([&] { return replayed.size() >= want; }, 60.0);
  std::system("rosnode kill /bag_player > /dev/null 2>&1");
  ASSERT_TRUE(all) << "replayed " << replayed.size() << " of " << want;
  const std::map<long, Estimate> P = byStep(replayed);
  for (long k = 1; k <= static_cast<long>(want); ++k)
  {
    ASSERT_TRUE(P.count(k)) << "replayed: no step " << k;
    ASSERT_EQ(P.at(k).gamma, L.at(k).gamma) << "step " << k;
    ASSERT_EQ(P.at(k).state, L.at(k).state) << "step " << k;
    ASSERT_EQ(P.at(k).covariance, L.at(k).covariance) << "step " << k;
  }
}

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "robot_graph_test");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  const int r = RUN_ALL_TESTS();
  spinner.stop();
  return r;
}
