// Tests of resolveSensorLinks (config/sensor_links.hpp).
#include "config_test_support.hpp"

// =============================================================================================
// resolveSensorLinks: --channel FILE and --channel NAME=FILE
// =============================================================================================

namespace
{
const char* kTwoSensors = R"(
name: two
A: [[0.9]]
Q: [[1]]
sensors:
  - {name: gps, C: [[1]], R: [[1]]}
  - {name: camera, C: [[1]], R: [[0.5]]}
)";
}  // namespace

TEST(SensorLinks, PlainChannelForEverySensorNamedOneOverridesIt)
{
  TempDir dir;
  const ne::Model m = ne::loadModel(dir.write("two.yaml", kTwoSensors));
  const std::string radio = dir.write("radio.yaml", "{model: bernoulli, loss: 0.3}");
  const std::string wired = dir.write("wired.yaml", "{model: gilbert_elliott, p: 0.01, r: 0.5}");

  ne::SensorLinks none = ne::resolveSensorLinks(m, {});
  ASSERT_EQ(none.link.size(), 2u);
  EXPECT_FALSE(none.any());
  EXPECT_TRUE(none.uniform());
  EXPECT_CONTAINS(none.describe(), "gps: lossless");
  EXPECT_CONTAINS(none.describe(), "camera: lossless");

  ne::SensorLinks all = ne::resolveSensorLinks(m, {radio});
  EXPECT_TRUE(all.uniform());
  ASSERT_TRUE(all.link[0] && all.link[1]);
  EXPECT_EQ(all.link[1]->loss, 0.3);

  // the named one wins, in either order of the options; the other keeps the plain channel
  for (const auto& args :
       {std::vector<std::string>{radio, "camera=" + wired}, std::vector<std::string>{"camera=" + wired, radio}})
  {
    ne::SensorLinks mixed = ne::resolveSensorLinks(m, args);
    ASSERT_TRUE(mixed.link[0] && mixed.link[1]);
    EXPECT_EQ(mixed.link[0]->model, ne::LossModelKind::BERNOULLI);
    EXPECT_EQ(mixed.link[1]->model, ne::LossModelKind::GILBERT_ELLIOTT);
    EXPECT_FALSE(mixed.uniform());
    EXPECT_CONTAINS(mixed.origin[1], "--channel camera=" + wired);
    EXPECT_CONTAINS(mixed.origin[0], "--channel " + radio);
  }

  // only one named: the other sensor is lossless, and says so
  ne::SensorLinks one = ne::resolveSensorLinks(m, {"gps=" + radio});
  EXPECT_TRUE(one.link[0].has_value());
  EXPECT_FALSE(one.link[1].has_value());
  EXPECT_CONTAINS(one.origin[1], "camera: lossless");
}

TEST(SensorLinks, RefusesWhatIsNotASensorTwiceOrUnreadable)
{
  TempDir dir;
  const ne::Model m = ne::loadModel(dir.write("two.yaml", kTwoSensors));
  const std::string radio = dir.write("radio.yaml", "{model: bernoulli, loss: 0.3}");
  const std::string bad = dir.write("bad.yaml", "{model: bernoulli, loss: 1.5}");
  auto error = [&](const std::vector<std::string>& args) { return errorOf([&] { ne::resolveSensorLinks(m, args); }); };
  const std::string lidar = error({"lidar=" + radio});
  EXPECT_CONTAINS(lidar, "'lidar' is not a sensor of model 'two'");
  EXPECT_CONTAINS(lidar, "gps, camera");
  EXPECT_CONTAINS(error({"gps=" + radio, "gps=" + radio}), "sensor 'gps' has a channel already");
  EXPECT_CONTAINS(error({radio, radio}), "more than one channel for every sensor");
  EXPECT_CONTAINS(error({"gps="}), "no file after 'gps='");
  EXPECT_CONTAINS(error({"=" + radio}), "expected FILE or NAME=FILE");
  EXPECT_CONTAINS(error({"camera=" + bad}), bad + ":1: loss: expected a probability in [0, 1], found 1.5");
  EXPECT_CONTAINS(error({"gps=" + dir.path().string() + "/missing.yaml"}), "missing.yaml: cannot open file");
}
