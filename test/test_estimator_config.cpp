// parseEstimatorNodeConfig: the Estimator nodelet's parameters, defaults and every refusal naming
// its key (the nodelet turns the ConfigError into a FATAL message and does not start).
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <unistd.h>

#include "networked_estimation/common/error.hpp"
#include "networked_estimation/online/estimator_node_config.hpp"

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
    scalar_ = write("scalar.yaml", "name: s\nperiod: 0.02\nA: [[0.9]]\nQ: [[1]]\nC: [[1]]\nR: [[1]]\nx0: [0]\nP0: [[1]]\n");
    planar_ = write("planar.yaml",
                    "name: p\nperiod: 0.05\nA: [[1, 0], [0, 1]]\nQ: [[1, 0], [0, 1]]\nx0: [0, 0]\nP0: [[1, 0], [0, 1]]\n"
                    "sensors:\n  - {name: a, C: [[1, 0], [0, 1]], R: [[1, 0], [0, 1]]}\n"
                    "  - {name: b, C: [[1, 1]], R: [[2]]}\n");
    control_ = write("control.yaml",
                     "name: c\nperiod: 0.01\nA: [[1.1]]\nQ: [[1]]\nC: [[1]]\nR: [[1]]\nx0: [0]\nP0: [[1]]\n"
                     "control: {Bu: [[1]]}\n");
    no_period_ = write("no_period.yaml", "name: n\nA: [[0.9]]\nQ: [[1]]\nC: [[1]]\nR: [[1]]\nx0: [0]\nP0: [[1]]\n");
    wide_ = write("wide.yaml",
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

  std::string dir_, scalar_, planar_, control_, no_period_, wide_;
  std::vector<std::string> files_;
};

}  // namespace

TEST_F(EstimatorConfig, Defaults)
{
  const ne::EstimatorNodeConfig c = parse("");
  EXPECT_EQ(c.settings.algorithm, ne::Algorithm::KFIO);
  EXPECT_EQ(c.model.name, "s");
  EXPECT_DOUBLE_EQ(c.period, 0.02);
  EXPECT_DOUBLE_EQ(c.latency_budget, 0.01);
  EXPECT_EQ(c.online.late_policy, ne::LatePolicy::DROP);
  EXPECT_EQ(c.online.history_length, 100u);
  EXPECT_EQ(c.online.max_future_steps, 1000);
  EXPECT_EQ(c.online.max_past_steps, 1000);
  EXPECT_EQ(c.input_type, "measurement");
  EXPECT_EQ(c.frame_id, "map");
  EXPECT_EQ(c.child_frame_id, "kfio_estimate");
  EXPECT_EQ(c.position_indices, std::vector<int>{0});  // n = 1
  EXPECT_TRUE(c.publish_tf);
  EXPECT_TRUE(std::isinf(c.trace_bound));
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
      "stability_window: 400, stability_min_samples: 40, diagnostic_period: 2.0}",
      planar_);
  EXPECT_EQ(c.settings.algorithm, ne::Algorithm::RSEIO);
  EXPECT_DOUBLE_EQ(c.settings.mu, 0.8);
  EXPECT_DOUBLE_EQ(c.period, 0.05);
  EXPECT_DOUBLE_EQ(c.latency_budget, 0.2);
  EXPECT_EQ(c.online.late_policy, ne::LatePolicy::REWIND);
  EXPECT_EQ(c.online.history_length, 20u);
  EXPECT_EQ(c.online.max_future_steps, 50);
  EXPECT_EQ(c.online.max_past_steps, 300);
  EXPECT_EQ(c.input_type, "point");
  EXPECT_EQ(c.frame_id, "odom");
  EXPECT_EQ(c.child_frame_id, "est");
  EXPECT_EQ(c.position_indices, (std::vector<int>{1, 0}));
  EXPECT_FALSE(c.publish_tf);
  EXPECT_DOUBLE_EQ(c.trace_bound, 12.5);
  EXPECT_EQ(c.queue_size, 10u);
  EXPECT_TRUE(c.markov_link);
  EXPECT_EQ(c.stability_window, 400u);
  EXPECT_EQ(c.stability_min_samples, 40u);
  const ne::EstimatorNodeConfig a =
      parse("{algorithm: aoe, control_link: {recovery: 0.3, failure: 0.4}}", control_);
  EXPECT_EQ(a.settings.algorithm, ne::Algorithm::AOE);
  EXPECT_TRUE(a.settings.has_control_link);
  EXPECT_DOUBLE_EQ(a.settings.recovery, 0.3);
}

TEST_F(EstimatorConfig, RefusalsNameTheKey)
{
  auto has = [](const std::string& msg, const std::string& what) {
    return msg.find(what) != std::string::npos;
  };
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
  EXPECT_TRUE(has(error("{latency_budget: -0.1}"), "latency_budget: expected a number in [0, 3600], found -0.1"));
  EXPECT_TRUE(has(error("{latency_budget: soon}"), "latency_budget: expected a number, found 'soon'"));
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
  EXPECT_TRUE(has(error("{trace_bound: -1}"), "trace_bound"));
  EXPECT_TRUE(has(error("{queue_size: 0}"), "queue_size: expected an integer in [1, 1000000], found 0"));
  EXPECT_TRUE(has(error("{link_model: bursty}"), "link_model: expected iid | markov, found 'bursty'"));
  EXPECT_TRUE(has(error("{stability_window: 50, stability_min_samples: 60}"), "stability_min_samples"));
  EXPECT_TRUE(has(error("{frame_id: [a, b]}"), "frame_id: expected a string"));
  // Every message names where the parameters came from.
  EXPECT_TRUE(has(error("{queue_size: 0}"), "/est parameters: "));
}
