// parseEstimatorNodeConfig: the Estimator nodelet's parameters, defaults and every refusal naming
// its key (the nodelet turns the ConfigError into a FATAL message and does not start).
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <string>
#include <unistd.h>

#include "networked_estimation/common/error.hpp"
#include "networked_estimation/config/param_reader.hpp"
#include "networked_estimation/online/estimator_node_config.hpp"
#include "networked_estimation/online/motion_sensors.hpp"

namespace ne = networked_estimation;

namespace
{

/// A model file in a temporary directory, removed with the fixture.
class EstimatorConfig : public ::testing::Test
{
protected:
  void SetUp() override
  {
    char tmpl[] = "/tmp/test_estimator_config.XXXXXX";
    ASSERT_NE(mkdtemp(tmpl), nullptr);
    dir_ = tmpl;
    scalar_ =
        write("scalar.yaml", "name: s\nperiod: 0.02\nA: [[0.9]]\nQ: [[1]]\nC: [[1]]\nR: [[1]]\nx0: [0]\nP0: [[1]]\n");
    planar_ =
        write("planar.yaml",
              "name: p\nperiod: 0.05\nA: [[1, 0], [0, 1]]\nQ: [[1, 0], [0, 1]]\nx0: [0, 0]\nP0: [[1, 0], [0, 1]]\n"
              "sensors:\n  - {name: a, C: [[1, 0], [0, 1]], R: [[1, 0], [0, 1]]}\n"
              "  - {name: b, C: [[1, 1]], R: [[2]]}\n");
    // planar with its second state a yaw (an angle, which a yaw field must feed: docs/formats.md 1.2b)
    planar_yaw_ =
        write("planar_yaw.yaml",
              "name: p\nperiod: 0.05\nA: [[1, 0], [0, 1]]\nQ: [[1, 0], [0, 1]]\nx0: [0, 0]\nP0: [[1, 0], [0, 1]]\n"
              "states: [x, yaw]\nangles: [yaw]\n"
              "sensors:\n  - {name: a, C: [[1, 0], [0, 1]], R: [[1, 0], [0, 1]]}\n"
              "  - {name: b, C: [[1, 0]], R: [[2]]}\n");
    control_ = write("control.yaml",
                     "name: c\nperiod: 0.01\nA: [[1.1]]\nQ: [[1]]\nC: [[1]]\nR: [[1]]\nx0: [0]\nP0: [[1]]\n"
                     "control: {Bu: [[1]]}\n");
    no_period_ = write("no_period.yaml", "name: n\nA: [[0.9]]\nQ: [[1]]\nC: [[1]]\nR: [[1]]\nx0: [0]\nP0: [[1]]\n");
    wide_ =
        write("wide.yaml",
              "name: w\nperiod: 0.01\nA: [[1, 0], [0, 1]]\nQ: [[1, 0], [0, 1]]\nx0: [0, 0]\nP0: [[1, 0], [0, 1]]\n"
              "C: [[1, 0], [0, 1], [1, 1], [1, -1]]\nR: [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]\n");
  }
  void TearDown() override
  {
    for (const std::string& f : files_)
      std::remove(f.c_str());
    rmdir(dir_.c_str());
  }
  std::string write(const std::string& name, const std::string& text)
  {
    const std::string path = dir_ + "/" + name;
    std::ofstream(path) << text;
    files_.push_back(path);
    return path;
  }
  /// Parses `yaml` with `model: <file>` added (unless the map has a model key).
  ne::EstimatorNodeConfig parse(const std::string& yaml, const std::string& model = "")
  {
    YAML::Node n = YAML::Load(yaml.empty() ? "{}" : yaml);
    if (!n["model"])
      n["model"] = model.empty() ? scalar_ : model;
    return ne::parseEstimatorNodeConfig(n, "/est parameters");
  }
  /// The ConfigError message of parsing `yaml` (fails the test when it parses).
  std::string error(const std::string& yaml, const std::string& model = "")
  {
    try
    {
      parse(yaml, model);
    }
    catch (const ne::ConfigError& e)
    {
      return e.what();
    }
    ADD_FAILURE() << "accepted: " << yaml;
    return "";
  }

  std::string dir_, scalar_, planar_, planar_yaw_, control_, no_period_, wide_;
  std::vector<std::string> files_;
};

}  // namespace

TEST_F(EstimatorConfig, Defaults)
{
  const ne::EstimatorNodeConfig c = parse("");
  EXPECT_EQ(c.settings.algorithm, ne::Algorithm::KFIO);
  EXPECT_EQ(c.model.name, "s");
  EXPECT_DOUBLE_EQ(c.period, 0.02);
  // latency_budget: auto, within [half a period, 1 s]; stamps within 10 s ahead of ROS time and
  // 1 s + 100 periods behind it.
  EXPECT_TRUE(c.runtime.adaptive_latency);
  EXPECT_DOUBLE_EQ(c.runtime.latency_budget_min, 0.01);
  EXPECT_DOUBLE_EQ(c.runtime.latency_budget_max, 1.0);
  EXPECT_DOUBLE_EQ(c.timeline.max_ahead, 10.0);
  EXPECT_DOUBLE_EQ(c.timeline.max_behind, 3.0);
  EXPECT_DOUBLE_EQ(c.timeline.period, 0.02);
  EXPECT_EQ(c.runtime.late_policy, "drop");
  EXPECT_EQ(c.online.late_policy, ne::LatePolicy::DROP);
  EXPECT_EQ(c.online.history_length, 100u);
  EXPECT_EQ(c.online.max_future_steps, 1000);
  EXPECT_EQ(c.online.max_past_steps, 1000);
  EXPECT_EQ(c.input_type, "measurement");
  EXPECT_EQ(c.frame_id, "map");
  EXPECT_EQ(c.child_frame_id, "kfio_estimate");
  EXPECT_EQ(c.position_indices, std::vector<int>{0});  // n = 1
  EXPECT_TRUE(c.publish_tf);
  EXPECT_TRUE(std::isinf(c.runtime.trace_bound));
  EXPECT_TRUE(c.live_stability);
  EXPECT_FALSE(c.markov_link);
  EXPECT_EQ(c.stability_window, 1000u);
  EXPECT_EQ(c.stability_min_samples, 100u);
  EXPECT_EQ(parse("", planar_).position_indices, (std::vector<int>{0, 1}));
}

TEST_F(EstimatorConfig, EveryKeyIsRead)
{
  const ne::EstimatorNodeConfig c = parse(
      "{algorithm: rseio, mu: 0.8, period: 0.05, latency_budget: 0.2, late_policy: rewind, history_length: 20, "
      "max_future_steps: 50, max_past_steps: 300, input_type: point, frame_id: odom, child_frame_id: est, "
      "position_indices: [1, 0], publish_tf: false, trace_bound: 12.5, queue_size: 10, link_model: markov, "
      "live_stability: false, "
      "stability_window: 400, stability_min_samples: 40, diagnostic_period: 2.0, latency_budget_min: 0.02, "
      "latency_budget_max: 0.5, max_stamp_ahead: 4, max_stamp_behind: 6}",
      planar_);
  EXPECT_EQ(c.settings.algorithm, ne::Algorithm::RSEIO);
  EXPECT_DOUBLE_EQ(c.settings.mu, 0.8);
  EXPECT_DOUBLE_EQ(c.period, 0.05);
  EXPECT_FALSE(c.runtime.adaptive_latency);
  EXPECT_DOUBLE_EQ(c.runtime.latency_budget, 0.2);
  EXPECT_DOUBLE_EQ(c.runtime.latency_budget_min, 0.02);
  EXPECT_DOUBLE_EQ(c.runtime.latency_budget_max, 0.5);
  EXPECT_DOUBLE_EQ(c.timeline.max_ahead, 4.0);
  EXPECT_DOUBLE_EQ(c.timeline.max_behind, 6.0);
  // Without max_stamp_behind: the fixed budget + history_length periods.
  EXPECT_DOUBLE_EQ(parse("{latency_budget: 0.2, history_length: 20, period: 0.05}", planar_).timeline.max_behind,
                   0.2 + 20 * 0.05);
  EXPECT_TRUE(parse("{latency_budget: auto}").runtime.adaptive_latency);
  EXPECT_EQ(c.online.late_policy, ne::LatePolicy::REWIND);
  EXPECT_EQ(c.online.history_length, 20u);
  EXPECT_EQ(c.online.max_future_steps, 50);
  EXPECT_EQ(c.online.max_past_steps, 300);
  EXPECT_EQ(c.input_type, "point");
  EXPECT_EQ(c.frame_id, "odom");
  EXPECT_EQ(c.child_frame_id, "est");
  EXPECT_EQ(c.position_indices, (std::vector<int>{1, 0}));
  EXPECT_FALSE(c.publish_tf);
  EXPECT_DOUBLE_EQ(c.runtime.trace_bound, 12.5);
  EXPECT_EQ(c.queue_size, 10u);
  EXPECT_TRUE(c.markov_link);
  EXPECT_FALSE(c.live_stability);
  EXPECT_EQ(c.stability_window, 400u);
  EXPECT_EQ(c.stability_min_samples, 40u);
  const ne::EstimatorNodeConfig a = parse("{algorithm: aoe, control_link: {recovery: 0.3, failure: 0.4}}", control_);
  EXPECT_EQ(a.settings.algorithm, ne::Algorithm::AOE);
  EXPECT_TRUE(a.settings.has_control_link);
  EXPECT_DOUBLE_EQ(a.settings.recovery, 0.3);
}

TEST_F(EstimatorConfig, RefusalsNameTheKey)
{
  auto has = [](const std::string& msg, const std::string& what) { return msg.find(what) != std::string::npos; };
  EXPECT_TRUE(has(error("{model: ''}"), "model: required parameter is empty"));
  {
    YAML::Node n = YAML::Load("{algorithm: kfio}");
    try
    {
      ne::parseEstimatorNodeConfig(n, "/est parameters");
      ADD_FAILURE();
    }
    catch (const ne::ConfigError& e)
    {
      EXPECT_TRUE(has(e.what(), "/est parameters: model: required parameter is missing")) << e.what();
    }
  }
  const std::string missing = error("{model: " + dir_ + "/nope.yaml}");
  EXPECT_TRUE(has(missing, "model: ") && has(missing, "nope.yaml")) << missing;
  EXPECT_TRUE(has(error("{latency_budjet: 0.1}"), "unknown parameter(s): latency_budjet"));
  EXPECT_TRUE(has(error("{late_policy: later}"), "late_policy: expected drop or rewind, found 'later'"));
  EXPECT_TRUE(has(error("{algorithm: rseio, mu: 1.5}"), "mu"));
  EXPECT_TRUE(has(error("{algorithm: ukf}"), "algorithm"));
  EXPECT_TRUE(has(error("{algorithm: ack_kf}"), "ack_kf needs nu_k"));
  EXPECT_TRUE(has(error("{algorithm: aoe}", control_), "control_link"));
  EXPECT_TRUE(has(error("", no_period_), "period: the model"));
  // the model's period is held to ~period's range (it is the default of ~period); named, not found
  // out through the budgets it sets (latency_budget_min is half a period)
  for (const char* period : {"1e300", "3601"})
  {
    const std::string slow = write(
        std::string("slow") + period + ".yaml",
        std::string("name: s\nperiod: ") + period + "\nA: [[0.9]]\nQ: [[1]]\nC: [[1]]\nR: [[1]]\nx0: [0]\nP0: [[1]]\n");
    EXPECT_EQ(error("", slow), "/est parameters: period: the model '" + slow + "' has period " +
                                   (period[1] == 'e' ? "1e+300" : "3601") +
                                   " s: expected a number of seconds in (0, 3600], the range of ~period (give "
                                   "~period to override it)");
    EXPECT_DOUBLE_EQ(parse("{period: 0.5}", slow).period, 0.5);  // ~period given: the model's is not used
  }
  EXPECT_TRUE(has(error("{latency_budget: -0.1}"), "latency_budget: expected a number of seconds >= 0, found -0.1"));
  EXPECT_TRUE(
      has(error("{latency_budget: soon}"), "latency_budget: expected auto or a number of seconds, found 'soon'"));
  EXPECT_TRUE(has(error("{latency_budget: .nan}"), "latency_budget: expected a number of seconds >= 0, found nan"));
  EXPECT_TRUE(has(error("{latency_budget: 21}"), "latency_budget: expected below max_future_steps x period = 20 s"));
  EXPECT_TRUE(has(error("{latency_budget: 2, max_stamp_behind: 1}"),
                  "latency_budget: expected at most "
                  "max_stamp_behind = 1 s"));
  EXPECT_TRUE(has(error("{latency_budget_min: 0.5, latency_budget_max: 0.2}"),
                  "latency_budget_min: expected at most latency_budget_max = 0.2 s, found 0.5"));
  EXPECT_TRUE(has(error("{latency_budget_max: 0}"), "latency_budget_max: expected a number of seconds > 0, found 0"));
  EXPECT_TRUE(has(error("{max_stamp_ahead: 0}"), "max_stamp_ahead: expected a number of seconds > 0"));
  EXPECT_TRUE(has(error("{max_stamp_behind: -1}"), "max_stamp_behind: expected a number in [0, 1e+09], found -1"));
  EXPECT_TRUE(has(error("{history_length: 0}"), "history_length"));
  EXPECT_TRUE(has(error("{history_length: 500, max_past_steps: 100}"), "max_past_steps"));
  EXPECT_TRUE(has(error("{max_future_steps: 0}"), "max_future_steps"));
  EXPECT_TRUE(has(error("{input_type: imu}"), "input_type: expected measurement | range | point, found 'imu'"));
  EXPECT_TRUE(has(error("{input_type: range}", planar_), "range needs sensors of 1 row; sensor 'a' has 2"));
  EXPECT_TRUE(has(error("{input_type: point}", wide_), "point gives at most 3 values; sensor 'y' has 4"));
  EXPECT_TRUE(has(error("{position_indices: [0, 2]}", planar_), "position_indices: index 2 outside the state [0, 2)"));
  EXPECT_TRUE(has(error("{position_indices: [1, 1]}", planar_), "index 1 repeated"));
  EXPECT_TRUE(has(error("{position_indices: 3}", planar_), "expected a list of state indices"));
  EXPECT_TRUE(has(error("{publish_tf: maybe}"), "publish_tf: expected true or false, found 'maybe'"));
  EXPECT_TRUE(has(error("{live_stability: 2}"), "live_stability: expected true or false, found '2'"));
  EXPECT_TRUE(has(error("{trace_bound: -1}"), "trace_bound"));
  EXPECT_TRUE(has(error("{queue_size: 0}"), "queue_size: expected an integer in [1, 1000000], found 0"));
  EXPECT_TRUE(has(error("{link_model: bursty}"), "link_model: expected iid | markov, found 'bursty'"));
  EXPECT_TRUE(has(error("{stability_window: 50, stability_min_samples: 60}"), "stability_min_samples"));
  EXPECT_TRUE(has(error("{frame_id: [a, b]}"), "frame_id: expected a string"));
  for (const char* key : {"frame_id", "child_frame_id", "world_frame", "base_link_frame", "odom_frame"})
    EXPECT_TRUE(has(error(std::string("{") + key + ": ''}"), std::string(key) + ": expected a frame name, found an "
                                                                                "empty string"))
        << key;
  // Every message names where the parameters came from.
  EXPECT_TRUE(has(error("{queue_size: 0}"), "/est parameters: "));
}

// The `sensors` block: per sensor a topic, a standard message type, the fields forming its rows and
// a nominal rate; sensors without a block keep measurement/<name>.
TEST_F(EstimatorConfig, SensorsBlock)
{
  const ne::EstimatorNodeConfig c = parse(
      "{sensors: {a: {topic: /odom, type: nav_msgs/Odometry, fields: [pose.pose.position.x, "
      "pose.pose.orientation.yaw], rate: 10}}}",
      planar_yaw_);
  ASSERT_EQ(c.inputs.size(), 2u);
  EXPECT_EQ(c.inputs[0].topic, "/odom");
  EXPECT_EQ(c.inputs[0].type, ne::InputType::ODOMETRY);
  ASSERT_EQ(c.inputs[0].fields.size(), 2u);
  EXPECT_EQ(c.inputs[0].fields[0].quantity, ne::Quantity::POSITION);
  EXPECT_EQ(c.inputs[0].fields[0].axis, 0);
  EXPECT_EQ(c.inputs[0].fields[1].quantity, ne::Quantity::ORIENTATION_RPY);
  EXPECT_EQ(c.inputs[0].fields[1].axis, 2);
  EXPECT_DOUBLE_EQ(c.inputs[0].rate, 10.0);
  EXPECT_EQ(c.inputs[1].topic, "measurement/b");
  EXPECT_EQ(c.inputs[1].type, ne::InputType::MEASUREMENT);
  EXPECT_DOUBLE_EQ(c.inputs[1].rate, 20.0);  // the model's (period 0.05)
  EXPECT_EQ(c.online.rate_ratio, (std::vector<double>{2.0, 1.0}));
  // Every type parses, and its fields are the rostopic echo paths (a few spot checks).
  for (ne::InputType t : ne::inputTypes())
    EXPECT_EQ(ne::inputTypeFromString(ne::toString(t), "k", ne::inputTypes()), t);
  EXPECT_EQ(ne::inputFieldFromString(ne::InputType::IMU, "angular_velocity.z", "k").quantity,
            ne::Quantity::ANGULAR_VELOCITY);
  EXPECT_EQ(ne::inputFieldFromString(ne::InputType::NAVSATFIX, "north", "k").axis, 1);
  EXPECT_EQ(ne::inputFieldFromString(ne::InputType::TWIST, "twist.linear.y", "k").axis, 1);
  EXPECT_EQ(ne::inputFieldFromString(ne::InputType::FLOAT64, "data", "k").quantity, ne::Quantity::SCALAR);
  // input_type still maps every sensor without a block.
  const ne::EstimatorNodeConfig r = parse("{input_type: range}");
  EXPECT_EQ(r.inputs[0].type, ne::InputType::RANGE);
  EXPECT_EQ(r.inputs[0].topic, "measurement");
}

TEST_F(EstimatorConfig, SensorsBlockRefusalsNameTheKey)
{
  auto has = [](const std::string& text, const std::string& part)
  { EXPECT_NE(text.find(part), std::string::npos) << text << "\n  expected: " << part; };
  has(error("{sensors: {c: {}}}", planar_), "sensors.c: 'c' is not a sensor of the model (sensors: a, b)");
  has(error("{sensors: {b: {type: sensor_msgs/Gps, fields: [x]}}}", planar_),
      "sensors.b.type: unknown type 'sensor_msgs/Gps' (types: networked_estimation/Measurement, nav_msgs/Odometry");
  has(error("{sensors: {b: {type: sensor_msgs/NavSatFix, fields: [eest]}}}", planar_),
      "sensors.b.fields[0]: 'eest' is not a field of sensor_msgs/NavSatFix (fields: east, north, up)");
  has(error("{sensors: {b: {type: sensor_msgs/Imu, fields: [angular_velocity.z, angular_velocity.x]}}}", planar_),
      "sensors.b.fields: expected 1 fields (one per row of sensor 'b'), found 2");
  has(error("{sensors: {b: {type: sensor_msgs/Imu}}}", planar_),
      "sensors.b.fields: expected a list of sensor_msgs/Imu");
  has(error("{sensors: {b: {fields: [data]}}}", planar_),
      "sensors.b.fields: networked_estimation/Measurement has no field selection");
  has(error("{sensors: {b: {rate: 0}}}", planar_), "sensors.b.rate: expected > 0 and at most the model's rate 20");
  has(error("{sensors: {b: {rate: 25}}}", planar_), "found 25");
  has(error("{sensors: {b: {topic: ''}}}", planar_), "sensors.b.topic: expected a topic name");
  has(error("{sensors: {b: {colour: red}}}", planar_), "sensors.b: unknown parameter(s): colour");
  has(error("{sensors: {b: {covariance: message}}}", planar_),
      "sensors.b.covariance: message: networked_estimation/Measurement carries no covariance (use covariance: model)");
  has(error("{sensors: {b: {type: geometry_msgs/PoseStamped, fields: [pose.position.x], covariance: message}}}",
            planar_),
      "sensors.b.covariance: message: geometry_msgs/PoseStamped has no covariance of 'pose.position.x'");
  has(error("{sensors: {b: {type: sensor_msgs/Imu, fields: [orientation.z], covariance: message}}}", planar_),
      "has no covariance of 'orientation.z'");
  has(error("{sensors: {b: {type: sensor_msgs/Imu, fields: [angular_velocity.z], covariance: sometimes}}}", planar_),
      "covariance");
  has(error("{sensors: {b: {rejection_threshold: 0}}}", planar_),
      "sensors.b.rejection_threshold: expected a Mahalanobis distance > 0, found 0");
  EXPECT_EQ(parse("{sensors: {b: {rejection_threshold: 3}}}", planar_).online.rejection_threshold,
            (std::vector<double>{std::numeric_limits<double>::infinity(), 3.0}));
  const ne::EstimatorNodeConfig m = parse(
      "{sensors: {a: {type: nav_msgs/Odometry, fields: [pose.pose.position.x, twist.twist.angular.z], covariance: "
      "message}}}",
      planar_);
  EXPECT_TRUE(m.inputs[0].message_covariance);
  EXPECT_FALSE(m.inputs[1].message_covariance);
  EXPECT_EQ(ne::covarianceOf(ne::InputType::ODOMETRY, m.inputs[0].fields[1]).block, ne::CovarianceBlock::TWIST);
  EXPECT_EQ(ne::covarianceOf(ne::InputType::ODOMETRY, m.inputs[0].fields[1]).index, 5);
  EXPECT_EQ(
      ne::covarianceOf(ne::InputType::IMU, ne::inputFieldFromString(ne::InputType::IMU, "orientation.yaw", "k")).block,
      ne::CovarianceBlock::ORIENTATION);
  // robot_localization's per-input options: relative (poses), remove_gravitational_acceleration (Imu)
  const ne::EstimatorNodeConfig rl = parse(
      "{sensors: {a: {type: nav_msgs/Odometry, fields: [pose.pose.position.x, pose.pose.position.y], relative: true}, "
      "b: {type: sensor_msgs/Imu, fields: [linear_acceleration.x], remove_gravitational_acceleration: true}}}",
      planar_);
  EXPECT_TRUE(rl.inputs[0].relative);
  EXPECT_FALSE(rl.inputs[0].remove_gravity);
  EXPECT_TRUE(rl.inputs[1].remove_gravity);
  EXPECT_FALSE(rl.inputs[1].relative);
  has(error("{sensors: {b: {type: sensor_msgs/Imu, fields: [linear_acceleration.x], relative: true}}}", planar_),
      "sensors.b.relative: only for a pose (nav_msgs/Odometry, geometry_msgs/PoseWithCovarianceStamped, "
      "geometry_msgs/PoseStamped), found sensor_msgs/Imu");
  has(error("{sensors: {b: {type: nav_msgs/Odometry, fields: [pose.pose.position.x], "
            "remove_gravitational_acceleration: true}}}",
            planar_),
      "sensors.b.remove_gravitational_acceleration: only for sensor_msgs/Imu, found nav_msgs/Odometry");
  has(error("{sensors: {b: {type: sensor_msgs/Imu, fields: [angular_velocity.z], "
            "remove_gravitational_acceleration: true}}}",
            planar_),
      "sensors.b.remove_gravitational_acceleration: the sensor reads no linear_acceleration field");
  has(error("{sensors: {b: {type: nav_msgs/Odometry, fields: [pose.pose.position.x], relative: sometimes}}}", planar_),
      "relative: expected true or false, found 'sometimes'");
  // differential: the pose's fields read its velocity (no angle check: rates are not angles)
  const ne::EstimatorNodeConfig df = parse(
      "{sensors: {b: {type: nav_msgs/Odometry, fields: [pose.pose.orientation.yaw], differential: true}}}", planar_);
  EXPECT_TRUE(df.inputs[1].differential);
  EXPECT_EQ(df.inputs[1].fields[0].quantity, ne::Quantity::ANGULAR_VELOCITY);
  EXPECT_EQ(df.inputs[1].fields[0].axis, 2);
  has(error("{sensors: {b: {type: sensor_msgs/Imu, fields: [angular_velocity.z], differential: true}}}", planar_),
      "sensors.b.differential: only for a pose");
  has(error("{sensors: {b: {type: nav_msgs/Odometry, fields: [twist.twist.linear.x], differential: true}}}", planar_),
      "sensors.b.fields[0]: twist.twist.linear.x: differential reads positions and roll / pitch / yaw of the pose");
  has(error("{sensors: {b: {type: nav_msgs/Odometry, fields: [pose.pose.position.x], differential: true, "
            "relative: true}}}",
            planar_),
      "sensors.b.relative: not with differential");
  has(error("{sensors: {b: {type: nav_msgs/Odometry, fields: [pose.pose.position.x], differential: true, "
            "covariance: message}}}",
            planar_),
      "sensors.b.covariance: message: not with differential");
  has(error("{sensors: {b: [1, 2]}}", planar_), "sensors.b: expected a map");
  has(error("{sensors: [a, b]}", planar_), "sensors: expected a map from sensor names");
}

// The datum's refusals name the entry that is wrong and what it holds: a NaN or infinite entry as
// YAML writes it (.nan, .inf) and as a ROS parameter arrives (the text nan / inf of a double), one
// out of range, one that is not a number; a list of the wrong length names the list.
TEST_F(EstimatorConfig, Datum)
{
  EXPECT_TRUE(parse("").datum.empty());
  EXPECT_EQ(parse("{datum: [48.1, 11.5, 520]}").datum, (std::vector<double>{48.1, 11.5, 520.0}));
  EXPECT_EQ(parse("{datum: [-90, 180, -10.5]}").datum, (std::vector<double>{-90.0, 180.0, -10.5}));
  EXPECT_EQ(error("{datum: [48.1, 11.5]}"),
            "/est parameters: datum: expected [latitude, longitude, altitude] (degrees, degrees, m), found 2 entries");
  EXPECT_EQ(error("{datum: 48.1}"),
            "/est parameters: datum: expected [latitude, longitude, altitude] (degrees, degrees, m), found '48.1'");
  const std::vector<std::pair<std::string, std::string>> table = {
      {"[48.1, east, 3]", "datum[1] (longitude): expected a number, found 'east'"},
      {"[48.1, [1], 3]", "datum[1] (longitude): expected a number, found a list"},
      {"[95, 11.5, 3]", "datum[0] (latitude): expected a finite number of degrees in [-90, 90], found 95"},
      {"[-90.5, 11.5, 3]", "datum[0] (latitude): expected a finite number of degrees in [-90, 90], found -90.5"},
      {"[48.1, 180.5, 3]", "datum[1] (longitude): expected a finite number of degrees in [-180, 180], found 180.5"},
      {"[.nan, 11.5, 3]", "datum[0] (latitude): expected a finite number of degrees in [-90, 90], found .nan"},
      {"[nan, 11.5, 3]", "datum[0] (latitude): expected a finite number of degrees in [-90, 90], found nan"},
      {"[48.1, NaN, 3]", "datum[1] (longitude): expected a finite number of degrees in [-180, 180], found NaN"},
      {"[48.1, 11.5, nan]", "datum[2] (altitude): expected a finite number of metres, found nan"},
      {"[48.1, 11.5, .inf]", "datum[2] (altitude): expected a finite number of metres, found .inf"},
      {"[48.1, 11.5, -inf]", "datum[2] (altitude): expected a finite number of metres, found -inf"},
  };
  for (const auto& row : table)
    EXPECT_EQ(error("{datum: " + row.first + "}"), "/est parameters: " + row.second) << row.first;
}

TEST_F(EstimatorConfig, OdometryOutputSettings)
{
  const ne::EstimatorNodeConfig d = parse("", planar_);
  EXPECT_EQ(d.world_frame, "map");
  EXPECT_EQ(d.base_link_frame, "base_link");
  EXPECT_EQ(d.state_map.x, 0);  // position_indices [0, 1]
  EXPECT_EQ(d.state_map.y, 1);
  EXPECT_EQ(d.state_map.yaw, -1);
  const ne::EstimatorNodeConfig c =
      parse("{frame_id: odom, base_link_frame: base_footprint, state_mapping: {yaw: 1, vx: 0}}", planar_);
  EXPECT_EQ(c.world_frame, "odom");
  EXPECT_EQ(c.base_link_frame, "base_footprint");
  EXPECT_EQ(c.state_map.x, -1);
  EXPECT_EQ(c.state_map.yaw, 1);
  EXPECT_EQ(c.state_map.vx, 0);
  EXPECT_EQ(parse("{world_frame: map, frame_id: odom}", planar_).world_frame, "map");
  auto has = [](const std::string& text, const std::string& part)
  { EXPECT_NE(text.find(part), std::string::npos) << text << "\n  expected: " << part; };
  has(error("{state_mapping: {x: 0, y: 0}}", planar_), "state_mapping.y: state index 0 is mapped twice");
  has(error("{state_mapping: {x: 2}}", planar_), "state_mapping");
  has(error("{state_mapping: {heading: 0}}", planar_), "unknown parameter(s): heading");
  EXPECT_EQ(parse("{state_mapping: {roll: 0, pitch_rate: 1}}", planar_).state_map.pitch_rate, 1);
  has(error("{state_mapping: [0, 1]}", planar_), "state_mapping: expected a map");
}

TEST_F(EstimatorConfig, CommandInput)
{
  EXPECT_EQ(parse("", control_).command.type, ne::InputType::CONTROL_INPUT);
  EXPECT_EQ(parse("", control_).command.topic, "command");
  const ne::EstimatorNodeConfig c =
      parse("{command: {topic: /cmd_vel, type: geometry_msgs/Twist, fields: [linear.x]}}", control_);
  EXPECT_EQ(c.command.topic, "/cmd_vel");
  EXPECT_EQ(c.command.type, ne::InputType::TWIST_UNSTAMPED);
  ASSERT_EQ(c.command.fields.size(), 1u);
  EXPECT_EQ(c.command.fields[0].quantity, ne::Quantity::LINEAR_VELOCITY);
  const ne::EstimatorNodeConfig a =
      parse("{command: {type: std_msgs/Float64MultiArray, fields: ['data[3]']}}", control_);
  EXPECT_EQ(a.command.fields[0].quantity, ne::Quantity::ELEMENT);
  EXPECT_EQ(a.command.fields[0].axis, 3);
  auto has = [](const std::string& text, const std::string& part)
  { EXPECT_NE(text.find(part), std::string::npos) << text << "\n  expected: " << part; };
  has(error("{command: {type: geometry_msgs/Twist, fields: [linear.x]}}"), "command: model 's' has no control input");
  has(error("{command: {type: sensor_msgs/Imu, fields: [angular_velocity.z]}}", control_),
      "command.type: unknown type 'sensor_msgs/Imu' (types: networked_estimation/ControlInput, geometry_msgs/Twist, "
      "geometry_msgs/TwistStamped, std_msgs/Float64MultiArray)");
  has(error("{command: {type: geometry_msgs/Twist, fields: [linear.x, angular.z]}}", control_),
      "command.fields: expected 1 fields (one per entry of u), found 2");
  has(error("{command: {type: std_msgs/Float64MultiArray, fields: ['data[64]']}}", control_),
      "command.fields[0]: 'data[64]' is not a field of std_msgs/Float64MultiArray (fields: data[i], 0 <= i < 64)");
  has(error("{command: {type: networked_estimation/ControlInput, fields: [u]}}", control_),
      "command.fields: networked_estimation/ControlInput has no field selection");
  has(error("{sensors: {b: {type: networked_estimation/ControlInput}}}", planar_), "sensors.b.type: unknown type");
}

// transport (tcp | udp) and tcp_nodelay per sensor and for the command: tcp with TCP_NODELAY unless
// said otherwise, each block on its own, and every malformed value refused naming its key.
TEST_F(EstimatorConfig, InputTransport)
{
  const ne::EstimatorNodeConfig d = parse("{sensors: {a: {topic: /odom}}}", planar_);
  for (const ne::SensorInput& in : d.inputs)
  {
    EXPECT_EQ(in.transport.transport, ne::Transport::TCP) << in.topic;
    EXPECT_TRUE(in.transport.tcp_nodelay) << in.topic;
  }
  EXPECT_EQ(d.command.transport.transport, ne::Transport::TCP);
  const ne::EstimatorNodeConfig c =
      parse("{sensors: {a: {topic: /odom, transport: udp}, b: {transport: tcp, tcp_nodelay: false}}}", planar_);
  EXPECT_EQ(c.inputs[0].transport.transport, ne::Transport::UDP);
  EXPECT_TRUE(c.inputs[0].transport.tcp_nodelay);  // the TCPROS fallback's
  EXPECT_EQ(c.inputs[1].transport.transport, ne::Transport::TCP);
  EXPECT_FALSE(c.inputs[1].transport.tcp_nodelay);
  EXPECT_EQ(ne::toString(ne::Transport::UDP), "udp");
  EXPECT_EQ(ne::toString(ne::Transport::TCP), "tcp");
  const ne::EstimatorNodeConfig u = parse(
      "{command: {topic: /cmd_vel, type: geometry_msgs/Twist, fields: [linear.x], transport: udp, tcp_nodelay: false}}",
      control_);
  EXPECT_EQ(u.command.transport.transport, ne::Transport::UDP);
  EXPECT_FALSE(u.command.transport.tcp_nodelay);
  EXPECT_EQ(u.inputs[0].transport.transport, ne::Transport::TCP);  // the sensor keeps its own
  auto has = [](const std::string& text, const std::string& part)
  { EXPECT_NE(text.find(part), std::string::npos) << text << "\n  expected: " << part; };
  has(error("{sensors: {b: {transport: sctp}}}", planar_),
      "/est parameters: sensors.b.transport: expected tcp or udp, found 'sctp'");
  has(error("{sensors: {b: {transport: UDP}}}", planar_), "sensors.b.transport: expected tcp or udp, found 'UDP'");
  has(error("{sensors: {b: {transport: [udp]}}}", planar_), "sensors.b.transport: expected tcp or udp, found 'a list'");
  has(error("{sensors: {a: {tcp_nodelay: maybe}}}", planar_),
      "sensors.a.tcp_nodelay: expected true or false, found 'maybe'");
  has(error("{sensors: {a: {tcp_nodelay: {x: 1}}}}", planar_),
      "sensors.a.tcp_nodelay: expected true or false, found 'a map'");
  has(error("{command: {transport: unreliable}}", control_),
      "/est parameters: command.transport: expected tcp or udp, found 'unreliable'");
  has(error("{command: {tcp_nodelay: 2}}", control_), "command.tcp_nodelay: expected true or false, found '2'");
  // The one grammar of booleans: yaml-cpp's own would take no, off and y.
  for (const std::string word : {"no", "off", "y", "yes"})
    has(error("{sensors: {a: {tcp_nodelay: " + word + "}}}", planar_),
        "sensors.a.tcp_nodelay: expected true or false, found '" + word + "'");
  // A misspelt key is still refused, not taken for a transport setting.
  has(error("{sensors: {a: {transprot: udp}}}", planar_), "sensors.a: unknown parameter(s): transprot");
  // A nodelet's own ~transport / ~tcp_nodelay (the LossyChannel's `in`): the same rules, the keys
  // named after its parameters' source.
  auto own = [](const std::string& yaml)
  {
    ne::ParamReader p(YAML::Load(yaml), "/ch parameters");
    return ne::parseInputTransport(p, "/ch parameters: ");
  };
  EXPECT_EQ(own("{model: bernoulli}").transport, ne::Transport::TCP);
  EXPECT_EQ(own("{transport: udp, tcp_nodelay: false}").transport, ne::Transport::UDP);
  EXPECT_FALSE(own("{transport: udp, tcp_nodelay: false}").tcp_nodelay);
  for (const auto& bad :
       {std::make_pair("{transport: rudp}", "/ch parameters: transport: expected tcp or udp, found 'rudp'"),
        std::make_pair("{tcp_nodelay: on_and_off}",
                       "/ch parameters: tcp_nodelay: expected true or false, found 'on_and_off'")})
  {
    try
    {
      own(bad.first);
      ADD_FAILURE() << "accepted: " << bad.first;
    }
    catch (const ne::ConfigError& e)
    {
      EXPECT_EQ(std::string(e.what()), bad.second);
    }
  }
}

// The linear robot file (config/robot/planar_linear.yaml, with its model inline) parses as it
// stands, and its model equals config/models/planar_robot.yaml; an inline model's errors name the key.
TEST_F(EstimatorConfig, LinearRobotFileParses)
{
  const std::string root = NE_SOURCE_DIR;
  YAML::Node n = YAML::LoadFile(root + "/config/robot/planar_linear.yaml");
  const ne::EstimatorNodeConfig c = ne::parseEstimatorNodeConfig(n, "planar_linear");
  const ne::Model file = ne::loadModel(root + "/config/models/planar_robot.yaml");
  EXPECT_EQ(c.model.A, file.A);
  EXPECT_EQ(c.model.Q, file.Q);
  EXPECT_EQ(c.model.C, file.C);
  EXPECT_EQ(c.model.R, file.R);
  YAML::Node bad = YAML::Clone(n);
  bad["model"]["Q"][0][0] = -1.0;
  const std::string why = error(YAML::Dump(bad));
  EXPECT_EQ(why.rfind("/est parameters: model:", 0), 0u) << why;  // then the line in the YAML
  EXPECT_NE(why.find(": Q: not positive definite"), std::string::npos) << why;
  ASSERT_EQ(c.inputs.size(), 3u);
  EXPECT_EQ(c.inputs[2].type, ne::InputType::NAVSATFIX);
  EXPECT_EQ(c.online.rate_ratio, (std::vector<double>{1.0, 2.0, 10.0}));
  EXPECT_EQ(c.state_map.yaw_rate, 5);
  EXPECT_TRUE(c.runtime.adaptive_latency);  // latency_budget: auto
}

// The robot template (config/robot_template.yaml): ekfio on omni_2d, its sensors' rows from their
// fields alone (the wheels' twist, the IMU's heading, rate and accelerations, the fixes' east and
// north), odometry/filtered with every state of the motion, the tf driving base_link.
TEST_F(EstimatorConfig, RobotTemplateParses)
{
  const std::string root = NE_SOURCE_DIR;
  const YAML::Node n = YAML::LoadFile(root + "/config/robot_template.yaml");
  const ne::EstimatorNodeConfig c = ne::parseEstimatorNodeConfig(n, "template");
  EXPECT_EQ(c.settings.algorithm, ne::Algorithm::EKFIO);
  EXPECT_EQ(c.model.motion, ne::Motion::OMNI_2D);
  EXPECT_EQ(c.derived_sensors, (std::vector<std::string>{"wheels", "imu", "gps"}));
  auto measures = [&](std::size_t sensor)
  {
    std::vector<std::string> states;
    const ne::Sensor& s = c.model.sensors[sensor];
    for (int i = 0; i < s.size; ++i)
    {
      Eigen::Index j = 0;
      c.model.C.row(s.offset + i).maxCoeff(&j);
      states.push_back(c.model.states[static_cast<std::size_t>(j)]);
    }
    return states;
  };
  EXPECT_EQ(measures(0), (std::vector<std::string>{"vx", "vy", "vyaw"}));
  EXPECT_EQ(measures(1), (std::vector<std::string>{"yaw", "vyaw", "ax", "ay"}));
  EXPECT_EQ(measures(2), (std::vector<std::string>{"x", "y"}));
  EXPECT_DOUBLE_EQ(c.model.R(0, 0), 0.05 * 0.05);  // the wheels' std, for an all-zero twist covariance
  EXPECT_EQ(c.inputs[2].type, ne::InputType::NAVSATFIX);
  EXPECT_EQ(c.online.rate_ratio, (std::vector<double>{1.0, 1.0, 10.0}));
  EXPECT_EQ(c.state_map.yaw, 2);
  EXPECT_EQ(c.state_map.vx, 3);
  EXPECT_EQ(c.state_map.yaw_rate, 5);
  EXPECT_EQ(c.child_frame_id, c.base_link_frame);
  EXPECT_TRUE(c.runtime.adaptive_latency);
  // GNSS aligned as navsat_transform does, the heading from the IMU input
  EXPECT_TRUE(c.gnss.navsat_transform);
  EXPECT_EQ(c.gnss.heading_sensor, 1);
  EXPECT_TRUE(c.gnss.publish_gps_odometry);
}

// The runtime settings (dynamic_reconfigure) get the load's checks, as a whole: NaN, out of range,
// an unknown late_policy and inconsistent combinations are refused naming the key; nothing is
// clamped (a negative budget is an error, not 0).
TEST(RuntimeSettings, ValidatedAsAWhole)
{
  ne::RuntimeLimits limits;
  limits.period = 0.02;
  limits.max_future_steps = 1000;
  limits.max_stamp_behind = 3.0;
  auto refusal = [&](const ne::RuntimeSettings& s)
  {
    try
    {
      ne::validateRuntimeSettings(s, limits, "reconfigure");
    }
    catch (const ne::ConfigError& e)
    {
      return std::string(e.what());
    }
    return std::string();
  };
  ne::RuntimeSettings ok;
  ok.latency_budget_min = 0.01;
  EXPECT_EQ(refusal(ok), "");
  EXPECT_EQ(ne::describe(ok), "latency_budget auto in [0.01, 1] s, late_policy drop, trace_bound inf");
  ne::RuntimeSettings s = ok;
  s.latency_budget = std::nan("");
  EXPECT_EQ(refusal(s), "reconfigure: latency_budget: expected a number of seconds >= 0, found nan");
  s = ok;
  s.adaptive_latency = false;
  s.latency_budget = -0.5;
  EXPECT_EQ(refusal(s), "reconfigure: latency_budget: expected a number of seconds >= 0, found -0.5");
  s.latency_budget = 3.5;
  EXPECT_EQ(refusal(s),
            "reconfigure: latency_budget: expected at most max_stamp_behind = 3 s (messages it waits for "
            "would be refused as too old), found 3.5");
  s.latency_budget = 0.25;
  EXPECT_EQ(refusal(s), "");
  EXPECT_EQ(ne::describe(s), "latency_budget 0.25 s, late_policy drop, trace_bound inf");
  s = ok;
  s.late_policy = "later";
  EXPECT_EQ(refusal(s), "reconfigure: late_policy: expected drop or rewind, found 'later'");
  s = ok;
  s.trace_bound = std::nan("");
  EXPECT_EQ(refusal(s), "reconfigure: trace_bound: expected a number >= 0 (inf: no bound), found nan");
  s = ok;
  s.latency_budget_min = 0.5;
  s.latency_budget_max = 0.4;
  EXPECT_EQ(refusal(s), "reconfigure: latency_budget_min: expected at most latency_budget_max = 0.4 s, found 0.5");
  s.latency_budget_max = std::numeric_limits<double>::infinity();
  EXPECT_EQ(refusal(s), "reconfigure: latency_budget_max: expected a number of seconds > 0, found inf");
  limits.max_stamp_behind = 100.0;
  s.latency_budget_max = 25.0;
  EXPECT_EQ(refusal(s),
            "reconfigure: latency_budget_max: expected below max_future_steps x period = 20 s (messages "
            "for the steps it waits on would be refused as far future), found 25");
}

// The `sensors` block, table-driven: each malformed value (empty, repeated, out of range, wrong
// type, unknown name, conflicting keys) is refused with the exact message, naming the key as the
// parameter file spells it (sensors.<name>.<key>).
TEST_F(EstimatorConfig, SensorsBlockMalformedValues)
{
  const std::vector<std::pair<std::string, std::string>> table = {
      {"{sensors: {b: {topic: ''}}}", "/est parameters: sensors.b.topic: expected a topic name, found an empty string"},
      {"{sensors: {b: {topic: [a, b]}}}", "/est parameters: sensors.b: topic: expected a string, found '[a, b]'"},
      {"{sensors: {b: {type: ''}}}",
       "/est parameters: sensors.b.type: unknown type '' (types: networked_estimation/Measurement, nav_msgs/Odometry, "
       "geometry_msgs/PoseWithCovarianceStamped, geometry_msgs/PoseStamped, geometry_msgs/PointStamped, "
       "geometry_msgs/TwistWithCovarianceStamped, geometry_msgs/TwistStamped, sensor_msgs/Imu, sensor_msgs/NavSatFix, "
       "sensor_msgs/Range, std_msgs/Float64, geometry_msgs/Twist, std_msgs/Float64MultiArray)"},
      {"{sensors: {b: {type: [x]}}}", "/est parameters: sensors.b: type: expected a string, found '[x]'"},
      {"{sensors: {b: {type: sensor_msgs/Range, fields: []}}}",
       "/est parameters: sensors.b.fields: expected a list of sensor_msgs/Range fields, one per row of sensor 'b'"},
      {"{sensors: {b: {type: sensor_msgs/Range, fields: [range, range]}}}",
       "/est parameters: sensors.b.fields: expected 1 fields (one per row of sensor 'b'), found 2"},
      {"{sensors: {b: {type: sensor_msgs/Range, fields: range}}}",
       "/est parameters: sensors.b.fields: expected a list of sensor_msgs/Range fields, one per row of sensor 'b'"},
      {"{sensors: {b: {rate: fast}}}", "/est parameters: sensors.b: rate: expected a number, found 'fast'"},
      {"{sensors: {b: {rate: -5}}}", "/est parameters: sensors.b: rate: expected a number in [0, 1e+09], found -5"},
      {"{sensors: {b: {rate: .nan}}}", "/est parameters: sensors.b: rate: expected a number in [0, 1e+09], found nan"},
      {"{sensors: {b: {rejection_threshold: many}}}",
       "/est parameters: sensors.b: rejection_threshold: expected a number, found 'many'"},
      {"{sensors: {b: {rejection_threshold: -1}}}",
       "/est parameters: sensors.b: rejection_threshold: expected a number in [0, inf], found -1"},
      {"{sensors: {b: {covariance: ''}}}",
       "/est parameters: sensors.b: covariance: expected model | message, found ''"},
      {"{sensors: {b: {covariance: [model]}}}",
       "/est parameters: sensors.b: covariance: expected a string, found '[model]'"},
      {"{sensors: {'': {}}}", "/est parameters: sensors.: '' is not a sensor of the model (sensors: a, b)"},
      {"{sensors: {c: {topic: /c}}}", "/est parameters: sensors.c: 'c' is not a sensor of the model (sensors: a, b)"},
      {"{sensors: 3}", "/est parameters: sensors: expected a map from sensor names to input settings"},
      {"{sensors: {b: 3}}", "/est parameters: sensors.b: expected a map (keys: topic, type, fields, rate)"},
      {"{sensors: {b: {type: sensor_msgs/Range, fields: [range], covariance: message, rate: 10}}}",
       "/est parameters: sensors.b.covariance: message: sensor_msgs/Range has no covariance of 'range' (use "
       "covariance: model)"},
  };
  for (const auto& row : table)
    EXPECT_EQ(error(row.first, planar_), row.second) << row.first;
}

// A model with a built-in motion: the Estimator takes algorithm ekfio, its steps last its `period`
// (Sample::dt of every step, which the motion is discretised at), and any other algorithm is
// refused at load naming the algorithm and why.
TEST_F(EstimatorConfig, EkfioWithARobotMotion)
{
  const std::string omni = write("omni.yaml",
                                 "name: rover\nperiod: 0.05\nmotion: omni_2d\n"
                                 "Q: [[1,0,0,0,0,0,0,0],[0,1,0,0,0,0,0,0],[0,0,1,0,0,0,0,0],[0,0,0,1,0,0,0,0],"
                                 "[0,0,0,0,1,0,0,0],[0,0,0,0,0,1,0,0],[0,0,0,0,0,0,1,0],[0,0,0,0,0,0,0,1]]\n"
                                 "sensors:\n  - {name: odom, C: [[0,0,0,1,0,0,0,0],[0,0,0,0,0,1,0,0]], "
                                 "R: [[0.01,0],[0,0.01]]}\n");
  const ne::EstimatorNodeConfig c = parse("{algorithm: ekfio}", omni);
  EXPECT_EQ(c.settings.algorithm, ne::Algorithm::EKFIO);
  EXPECT_EQ(c.model.motion, ne::Motion::OMNI_2D);
  EXPECT_EQ(c.online.step_duration, 0.05);
  const ne::EstimatorNodeConfig faster = parse("{algorithm: ekfio, period: 0.02}", omni);
  EXPECT_EQ(faster.online.step_duration, 0.02);
  const std::string kfio = error("{algorithm: kfio}", omni);
  EXPECT_NE(kfio.find("kfio needs a linear model"), std::string::npos) << kfio;
  EXPECT_NE(kfio.find("use ekfio"), std::string::npos) << kfio;
  EXPECT_NE(error("{}", omni).find("kfio needs a linear model"), std::string::npos);  // the default algorithm
  EXPECT_NE(error("{algorithm: rseio, mu: 0.9}", omni).find("rseio needs a linear model"), std::string::npos);
}

// With a built-in motion, a sensor's fields alone give its rows of C (the unit vectors of the states
// they name) and its R (std, or the messages' covariances); the Odometry output maps every state.
TEST_F(EstimatorConfig, MotionSensorsFromFieldsAlone)
{
  const std::string q8 =
      "Q: [[1,0,0,0,0,0,0,0],[0,1,0,0,0,0,0,0],[0,0,1,0,0,0,0,0],[0,0,0,1,0,0,0,0],"
      "[0,0,0,0,1,0,0,0],[0,0,0,0,0,1,0,0],[0,0,0,0,0,0,1,0],[0,0,0,0,0,0,0,1]]\n";
  const std::string bare = write("bare2d.yaml", "name: rover\nperiod: 0.05\nmotion: omni_2d\n" + q8);
  const ne::EstimatorNodeConfig c = parse(
      "{algorithm: ekfio, sensors: {"
      "wheels: {topic: odom, type: nav_msgs/Odometry, fields: [twist.twist.linear.x, twist.twist.angular.z], "
      "std: [0.1, 0.2]},"
      "imu: {topic: imu, type: sensor_msgs/Imu, fields: [orientation.yaw, angular_velocity.z, linear_acceleration.x], "
      "covariance: message},"
      "gps: {topic: fix, type: sensor_msgs/NavSatFix, fields: [east, north], std: [2, 3]},"
      "vo: {topic: vo, type: geometry_msgs/PoseStamped, fields: [pose.position.x, pose.orientation.yaw], "
      "differential: true, std: [0.5, 0.5]}}}",
      bare);
  ASSERT_EQ(c.model.sensors.size(), 4u);
  EXPECT_EQ(c.derived_sensors, (std::vector<std::string>{"wheels", "imu", "gps", "vo"}));
  // states of omni_2d: x 0, y 1, yaw 2, vx 3, vy 4, vyaw 5, ax 6, ay 7
  const std::vector<std::vector<int>> expected = {{3, 5}, {2, 5, 6}, {0, 1}, {3, 5}};
  for (std::size_t s = 0; s < 4; ++s)
  {
    const ne::Sensor& sensor = c.model.sensors[s];
    ASSERT_EQ(sensor.size, static_cast<int>(expected[s].size())) << sensor.name;
    for (int i = 0; i < sensor.size; ++i)
      for (int j = 0; j < 8; ++j)
        EXPECT_EQ(c.model.C(sensor.offset + i, j), j == expected[s][static_cast<std::size_t>(i)] ? 1.0 : 0.0)
            << sensor.name << " row " << i << " state " << j;
  }
  const ne::Sensor& wheels = c.model.sensors[0];
  EXPECT_DOUBLE_EQ(c.model.R(wheels.offset, wheels.offset), 0.01);
  EXPECT_DOUBLE_EQ(c.model.R(wheels.offset + 1, wheels.offset + 1), 0.04);
  EXPECT_DOUBLE_EQ(c.model.R(wheels.offset, wheels.offset + 1), 0.0);
  const ne::Sensor& imu = c.model.sensors[1];  // covariance: message, no std: the floor for all-zero blocks
  EXPECT_DOUBLE_EQ(c.model.R(imu.offset + 2, imu.offset + 2), ne::kMessageCovarianceFloor);
  EXPECT_TRUE(c.inputs[1].message_covariance);
  EXPECT_DOUBLE_EQ(c.model.R(c.model.sensors[2].offset + 1, c.model.sensors[2].offset + 1), 9.0);
  // the yaw field feeds the motion's yaw, an angle: wrapped by the model's rule
  EXPECT_EQ(ne::angularRows(c.model), (std::vector<int>{imu.offset}));
  // odometry/filtered and the tf: every state omni_2d names
  EXPECT_EQ(c.state_map.x, 0);
  EXPECT_EQ(c.state_map.y, 1);
  EXPECT_EQ(c.state_map.z, -1);
  EXPECT_EQ(c.state_map.roll, -1);
  EXPECT_EQ(c.state_map.yaw, 2);
  EXPECT_EQ(c.state_map.vx, 3);
  EXPECT_EQ(c.state_map.vy, 4);
  EXPECT_EQ(c.state_map.yaw_rate, 5);
  EXPECT_EQ(c.position_indices, (std::vector<int>{0, 1}));

  // omni_3d: the full orientation and angular velocity, and z in the tf
  std::string q15 = "Q: [";
  for (int i = 0; i < 15; ++i)
  {
    q15 += i ? ", [" : "[";
    for (int j = 0; j < 15; ++j)
      q15 += std::string(j ? ", " : "") + (i == j ? "1" : "0");
    q15 += "]";
  }
  q15 += "]\n";
  const std::string bare3 = write("bare3d.yaml", "name: drone\nperiod: 0.02\nmotion: omni_3d\n" + q15);
  const ne::EstimatorNodeConfig d = parse(
      "{algorithm: ekfio, sensors: {imu: {type: sensor_msgs/Imu, covariance: message, "
      "fields: [orientation.roll, orientation.pitch, angular_velocity.y, linear_acceleration.z]}}}",
      bare3);
  EXPECT_EQ(d.model.C(0, 3), 1.0);   // roll
  EXPECT_EQ(d.model.C(1, 4), 1.0);   // pitch
  EXPECT_EQ(d.model.C(2, 10), 1.0);  // vpitch
  EXPECT_EQ(d.model.C(3, 14), 1.0);  // az
  EXPECT_EQ(d.state_map.roll, 3);
  EXPECT_EQ(d.state_map.pitch, 4);
  EXPECT_EQ(d.state_map.z, 2);
  EXPECT_EQ(d.state_map.roll_rate, 9);
  EXPECT_EQ(d.state_map.pitch_rate, 10);
  EXPECT_EQ(d.state_map.yaw_rate, 11);
  EXPECT_EQ(d.position_indices, (std::vector<int>{0, 1, 2}));

  // a model that lists a sensor keeps its C and R; the others are derived after it
  const std::string listed =
      write("listed.yaml", "name: rover\nperiod: 0.05\nmotion: omni_2d\n" + q8 +
                               "sensors:\n  - {name: wheels, C: [[0,0,0,1,0,0,0,0]], R: [[0.3]]}\n");
  const ne::EstimatorNodeConfig e = parse(
      "{algorithm: ekfio, sensors: {gps: {type: sensor_msgs/NavSatFix, fields: [east], std: [1]}, "
      "wheels: {type: nav_msgs/Odometry, fields: [twist.twist.linear.x]}}}",
      listed);
  ASSERT_EQ(e.model.sensors.size(), 2u);
  EXPECT_EQ(e.model.sensors[0].name, "wheels");
  EXPECT_DOUBLE_EQ(e.model.R(0, 0), 0.3);
  EXPECT_EQ(e.model.sensors[1].name, "gps");
  EXPECT_EQ(e.derived_sensors, std::vector<std::string>{"gps"});
  // an explicit state_mapping still wins
  EXPECT_EQ(parse("{algorithm: ekfio, state_mapping: {x: 1}, sensors: {gps: {type: sensor_msgs/NavSatFix, "
                  "fields: [east], std: [1]}}}",
                  bare)
                .state_map.yaw,
            -1);
  // an inline model too
  const ne::EstimatorNodeConfig f =
      parse("{algorithm: ekfio, model: {name: r, period: 0.05, motion: omni_2d, " + q8.substr(0, q8.size() - 1) +
            "}, sensors: {w: {type: nav_msgs/Odometry, fields: [twist.twist.linear.y], "
            "std: [0.1]}}}");
  EXPECT_EQ(f.model.C(0, 4), 1.0);
}

TEST_F(EstimatorConfig, MotionSensorsRefusalsNameTheKey)
{
  const std::string q8 =
      "Q: [[1,0,0,0,0,0,0,0],[0,1,0,0,0,0,0,0],[0,0,1,0,0,0,0,0],[0,0,0,1,0,0,0,0],"
      "[0,0,0,0,1,0,0,0],[0,0,0,0,0,1,0,0],[0,0,0,0,0,0,1,0],[0,0,0,0,0,0,0,1]]\n";
  const std::string bare = write("bare2d.yaml", "name: rover\nperiod: 0.05\nmotion: omni_2d\n" + q8);
  auto refused = [&](const std::string& sensors, const std::string& expected)
  {
    const std::string e = error("{algorithm: ekfio, sensors: {" + sensors + "}}", bare);
    EXPECT_NE(e.find(expected), std::string::npos) << "message: " << e << "\nexpected: " << expected;
  };
  refused("w: {type: nav_msgs/Odometry, fields: [pose.pose.position.z], std: [1]}",
          "/est parameters: sensors.w.fields[0]: pose.pose.position.z measures z, which motion omni_2d has not");
  refused("w: {type: nav_msgs/Odometry, fields: [pose.pose.orientation.x], std: [1]}",
          "sensors.w.fields[0]: pose.pose.orientation.x measures no state of motion omni_2d");
  refused("w: {type: sensor_msgs/Range, fields: [range], std: [1]}",
          "sensors.w.fields[0]: range measures no state of motion omni_2d (its states: x, y, yaw, vx, vy, vyaw, ax, "
          "ay); leave the field out");
  refused("w: {type: networked_estimation/Measurement, std: [1]}",
          "sensors.w.type: unknown type 'networked_estimation/Measurement' (types: nav_msgs/Odometry");
  refused("w: {type: nav_msgs/Odometry, fields: [twist.twist.linear.x, twist.twist.linear.x], std: [1, 1]}",
          "sensors.w.fields[1]: twist.twist.linear.x measures vx, which an earlier field of this sensor measures");
  refused("w: {type: nav_msgs/Odometry, fields: [twist.twist.linear.x]}",
          "sensors.w: give std (one standard deviation per field) or covariance: message");
  refused("w: {type: nav_msgs/Odometry, fields: [twist.twist.linear.x], std: [1, 2]}",
          "sensors.w.std: expected a list of 1 standard deviations, one per field");
  refused("w: {type: nav_msgs/Odometry, fields: [twist.twist.linear.x], std: [-1]}",
          "sensors.w.std[0]: expected a finite standard deviation > 0, found '-1'");
  refused("w: {type: nav_msgs/Odometry, fields: [twist.twist.linear.x], std: [.nan]}",
          "sensors.w.std[0]: expected a finite standard deviation > 0");
  refused("w: {fields: [twist.twist.linear.x], std: [1]}", "sensors.w.type: needed: the model lists no sensor 'w'");
  refused("w: {type: nav_msgs/Odometry, std: [1]}", "sensors.w.fields: expected a list of nav_msgs/Odometry fields");
  refused("w: {type: nav_msgs/Odometry, fields: [twist.twist.linear.x], std: [1], stdd: 2}",
          "unknown parameter(s): stdd");
  EXPECT_NE(error("{algorithm: ekfio}", bare)
                .find("/est parameters: sensors: the model (motion omni_2d) lists no "
                      "sensors"),
            std::string::npos);
  // std on a sensor the model lists: its R is the model's
  const std::string listed = write("listed.yaml", "name: rover\nperiod: 0.05\nmotion: omni_2d\n" + q8 +
                                                      "sensors:\n  - {name: w, C: [[0,0,0,1,0,0,0,0]], R: [[0.3]]}\n");
  EXPECT_NE(error("{algorithm: ekfio, sensors: {w: {type: nav_msgs/Odometry, fields: [twist.twist.linear.x], "
                  "std: [1]}}}",
                  listed)
                .find("sensors.w.std: only for a sensor the model does not list"),
            std::string::npos);
  // a linear model has no states to name: std is refused, the sensor must be the model's
  EXPECT_NE(
      error("{sensors: {a: {type: geometry_msgs/PointStamped, fields: [point.x, point.y], std: [1, 1]}}}", planar_)
          .find("sensors.a.std: only for a sensor the model does not list"),
      std::string::npos);
}

// gnss_alignment: enu (the default, world_frame is the ENU frame of the datum) or navsat_transform
// (robot_localization's alignment); the navsat_transform keys only with it, and every refusal names
// its key.
TEST_F(EstimatorConfig, GnssAlignment)
{
  const std::string rover = write("rover.yaml",
                                  "name: rover\nperiod: 0.05\nmotion: omni_2d\n"
                                  "Q: [[1,0,0,0,0,0,0,0],[0,1,0,0,0,0,0,0],[0,0,1,0,0,0,0,0],[0,0,0,1,0,0,0,0],"
                                  "[0,0,0,0,1,0,0,0],[0,0,0,0,0,1,0,0],[0,0,0,0,0,0,1,0],[0,0,0,0,0,0,0,1]]\n"
                                  "sensors:\n"
                                  "  - {name: odom, C: [[0,0,0,1,0,0,0,0],[0,0,0,0,0,1,0,0]], R: [[0.01,0],[0,0.01]]}\n"
                                  "  - {name: imu, C: [[0,0,1,0,0,0,0,0]], R: [[0.01]]}\n"
                                  "  - {name: gps, C: [[1,0,0,0,0,0,0,0],[0,1,0,0,0,0,0,0]], R: [[1,0],[0,1]]}\n");
  const std::string odom = "odom: {type: nav_msgs/Odometry, fields: [twist.twist.linear.x, twist.twist.angular.z]}";
  const std::string imu = "imu: {type: sensor_msgs/Imu, fields: [orientation.yaw]}";
  const std::string gps = "gps: {type: sensor_msgs/NavSatFix, fields: [east, north]}";
  const std::string mapping = "state_mapping: {x: 0, y: 1, yaw: 2}";
  const std::string all = "algorithm: ekfio, " + mapping + ", sensors: {" + odom + ", " + imu + ", " + gps + "}";
  // Default: enu, nothing of navsat_transform.
  const ne::EstimatorNodeConfig enu = parse("{" + all + "}", rover);
  EXPECT_FALSE(enu.gnss.navsat_transform);
  EXPECT_EQ(enu.gnss.heading_sensor, -1);
  EXPECT_FALSE(parse("{" + all + ", gnss_alignment: enu}", rover).gnss.navsat_transform);
  // navsat_transform: the defaults, the first Imu input as the heading.
  const ne::EstimatorNodeConfig d = parse("{" + all + ", gnss_alignment: navsat_transform}", rover);
  EXPECT_TRUE(d.gnss.navsat_transform);
  EXPECT_EQ(d.gnss.magnetic_declination, 0.0);
  EXPECT_EQ(d.gnss.yaw_offset, 0.0);
  EXPECT_FALSE(d.gnss.zero_altitude || d.gnss.use_odometry_yaw || d.gnss.publish_gps_odometry ||
               d.gnss.publish_filtered_gps || d.gnss.broadcast_utm_transform);
  EXPECT_EQ(d.gnss.heading_sensor, 1);
  EXPECT_EQ(d.gnss.roll, -1);  // omni_2d: no roll or pitch state
  // Every key read.
  const ne::EstimatorNodeConfig c =
      parse("{" + all +
                ", gnss_alignment: navsat_transform, magnetic_declination_radians: 0.2, yaw_offset: -1.5, "
                "zero_altitude: true, publish_gps_odometry: true, publish_filtered_gps: true, "
                "broadcast_utm_transform: true, gnss_heading: imu}",
            rover);
  EXPECT_EQ(c.gnss.magnetic_declination, 0.2);
  EXPECT_EQ(c.gnss.yaw_offset, -1.5);
  EXPECT_TRUE(c.gnss.zero_altitude && c.gnss.publish_gps_odometry && c.gnss.publish_filtered_gps &&
              c.gnss.broadcast_utm_transform);
  EXPECT_EQ(c.gnss.heading_sensor, 1);
  const ne::EstimatorNodeConfig o =
      parse("{" + all + ", gnss_alignment: navsat_transform, use_odometry_yaw: true}", rover);
  EXPECT_TRUE(o.gnss.use_odometry_yaw);
  EXPECT_EQ(o.gnss.heading_sensor, -1);
  // Without an Imu input: only with use_odometry_yaw.
  const std::string no_imu = "algorithm: ekfio, " + mapping + ", sensors: {" + odom + ", " + gps +
                             ", imu: {type: geometry_msgs/PoseStamped, fields: [pose.orientation.yaw]}}";
  EXPECT_TRUE(
      parse("{" + no_imu + ", gnss_alignment: navsat_transform, use_odometry_yaw: true}", rover).gnss.use_odometry_yaw);
  const std::string p = "/est parameters: ";
  EXPECT_EQ(error("{" + no_imu + ", gnss_alignment: navsat_transform}", rover),
            p + "gnss_heading: gnss_alignment: navsat_transform needs base_link's earth-referenced heading at the "
                "first fix: from a sensor_msgs/Imu input (none is configured) or, with use_odometry_yaw: true, from "
                "the fused yaw");
  // The keys only with navsat_transform.
  for (const char* key : {"magnetic_declination_radians: 0.1", "yaw_offset: 0.1", "zero_altitude: true",
                          "use_odometry_yaw: true", "publish_gps_odometry: true", "publish_filtered_gps: true",
                          "broadcast_utm_transform: true", "gnss_heading: imu"})
  {
    const std::string name = std::string(key).substr(0, std::string(key).find(':'));
    EXPECT_EQ(error("{" + all + ", " + key + "}", rover),
              p + name +
                  ": only with gnss_alignment: navsat_transform (found gnss_alignment: enu, where world_frame "
                  "is the ENU frame of the datum)");
  }
  EXPECT_EQ(error("{" + all + ", gnss_alignment: utm}", rover).find(p + "gnss_alignment: "), 0u);
  // navsat_transform needs a NavSatFix input and the pose in state_mapping.
  EXPECT_EQ(error("{gnss_alignment: navsat_transform}"),
            p + "gnss_alignment: navsat_transform needs a sensor_msgs/NavSatFix input (a sensors entry with type "
                "sensor_msgs/NavSatFix); found none");
  EXPECT_EQ(error("{algorithm: ekfio, state_mapping: {x: 0, y: 1}, sensors: {" + odom + ", " + imu + ", " + gps +
                      "}, gnss_alignment: navsat_transform}",
                  rover),
            p + "gnss_alignment: navsat_transform needs base_link's world pose from the estimate: state_mapping.yaw "
                "is not mapped");
  // gnss_heading: a sensor of the model, of type Imu, not with use_odometry_yaw; the values' ranges.
  EXPECT_EQ(error("{" + all + ", gnss_alignment: navsat_transform, gnss_heading: odom}", rover),
            p + "gnss_heading: sensor 'odom' is nav_msgs/Odometry, expected sensor_msgs/Imu (its orientation yaw, "
                "earth-referenced)");
  EXPECT_EQ(
      error("{" + all + ", gnss_alignment: navsat_transform, gnss_heading: compass}", rover).find(p + "gnss_heading"),
      0u);
  EXPECT_EQ(error("{" + all + ", gnss_alignment: navsat_transform, gnss_heading: imu, use_odometry_yaw: true}", rover),
            p + "gnss_heading: not with use_odometry_yaw: true (the heading is then the fused yaw)");
  for (const char* bad : {"magnetic_declination_radians: 4", "magnetic_declination_radians: .nan", "yaw_offset: 7",
                          "yaw_offset: east", "zero_altitude: maybe", "publish_gps_odometry: 2"})
  {
    const std::string name = std::string(bad).substr(0, std::string(bad).find(':'));
    EXPECT_EQ(error("{" + all + ", gnss_alignment: navsat_transform, " + bad + "}", rover).find(p + name), 0u) << bad;
  }
}

// ROS parameters read booleans and integers with the same grammar as the configuration files:
// true/false (in three cases) and decimal digits, nothing else (yaml-cpp alone would take yes, on
// and 0x10).
TEST(ParamReader, OneGrammarForBooleansAndIntegers)
{
  auto flag = [](const std::string& value)
  {
    ne::ParamReader p(YAML::Load("k: " + value), "/n parameters");
    return p.flag("k", false);
  };
  EXPECT_TRUE(flag("true"));
  EXPECT_TRUE(flag("True"));
  EXPECT_FALSE(flag("FALSE"));
  for (const std::string bad : {"yes", "on", "y", "1", "[true]"})
  {
    try
    {
      flag(bad);
      ADD_FAILURE() << bad << " taken as a boolean";
    }
    catch (const ne::ConfigError& e)
    {
      EXPECT_NE(std::string(e.what()).find("/n parameters: k: expected true or false"), std::string::npos) << e.what();
    }
  }
  auto integer = [](const std::string& value)
  {
    ne::ParamReader p(YAML::Load("k: " + value), "/n parameters");
    return p.integer("k", 0, -100, 100);
  };
  EXPECT_EQ(integer("42"), 42);
  EXPECT_EQ(integer("-7"), -7);
  EXPECT_EQ(integer("+3"), 3);
  for (const std::string bad : {"0x10", "2.5", "1e2", "ten", "99999999999999999999999"})
  {
    try
    {
      integer(bad);
      ADD_FAILURE() << bad << " taken as an integer";
    }
    catch (const ne::ConfigError& e)
    {
      EXPECT_NE(std::string(e.what()).find("/n parameters: k: expected an integer"), std::string::npos) << e.what();
    }
  }
}
