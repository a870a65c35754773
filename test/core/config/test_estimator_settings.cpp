// Tests of the estimator settings (config/estimator_settings.hpp).
#include "config_test_support.hpp"

// =============================================================================================
// Estimator settings
// =============================================================================================

TEST(Algorithm, NamesRoundTrip)
{
  for (const auto a : {ne::Algorithm::KF, ne::Algorithm::KFIO, ne::Algorithm::RSEIO, ne::Algorithm::AOE,
                       ne::Algorithm::OE, ne::Algorithm::ACK_KF})
  {
    EXPECT_EQ(ne::algorithmFromString(ne::toString(a), "x"), a);
  }
  EXPECT_EQ(ne::toString(ne::Algorithm::ACK_KF), "ack_kf");
  EXPECT_EQ(ne::toString(ne::Algorithm::RSEIO), "rseio");
  const std::string msg = errorOf([] { ne::algorithmFromString("ukf", "cli"); });
  EXPECT_EQ(msg,
            "cli: algorithm: unknown algorithm 'ukf' (expected one of: kf, kfio, rseio, aoe, oe, "
            "ack_kf, ekfio)");
}

TEST(ParseEstimatorSettings, FullFile)
{
  const ne::EstimatorSettings s =
      ne::parseEstimatorSettings(YAML::Load("algorithm: rseio\nmu: 0.8\ncontrol_link: {recovery: "
                                            "0.3, failure: 0.4}\nmax_components: 64\n"),
                                 "est.yaml");
  EXPECT_EQ(s.algorithm, ne::Algorithm::RSEIO);
  EXPECT_DOUBLE_EQ(s.mu, 0.8);
  EXPECT_TRUE(s.has_control_link);
  EXPECT_DOUBLE_EQ(s.recovery, 0.3);
  EXPECT_DOUBLE_EQ(s.failure, 0.4);
  EXPECT_EQ(s.max_components, 64u);
}

TEST(ParseEstimatorSettings, Defaults)
{
  const ne::EstimatorSettings s = ne::parseEstimatorSettings(YAML::Load("algorithm: oe"), "est.yaml");
  EXPECT_EQ(s.algorithm, ne::Algorithm::OE);
  EXPECT_EQ(s.mu, 1.0);
  EXPECT_FALSE(s.has_control_link);
  EXPECT_EQ(s.recovery, 0.5);
  EXPECT_EQ(s.failure, 0.5);
  EXPECT_EQ(s.max_components, 4096u);
  // mu is allowed (and ignored) for other algorithms
  EXPECT_EQ(ne::parseEstimatorSettings(YAML::Load("algorithm: kfio\nmu: 0.5"), "e").algorithm, ne::Algorithm::KFIO);
}

TEST(ParseEstimatorSettings, Errors)
{
  expectMessage(estimatorError("mu: 0.5"), "est.yaml", "algorithm", "missing required key");
  const std::string unknown = estimatorError("algorithm: ukf");
  expectMessage(unknown, "est.yaml:1", "algorithm", "unknown algorithm 'ukf'");
  EXPECT_CONTAINS(unknown, "kf, kfio, rseio, aoe, oe, ack_kf");
  expectMessage(estimatorError("algorithm: rseio"), "est.yaml", "mu", "missing required key");
  expectMessage(estimatorError("algorithm: rseio\nmu: 0"), "est.yaml:2", "mu", "expected a number in (0, 1], found 0");
  expectMessage(estimatorError("algorithm: rseio\nmu: 1.5"), "est.yaml", "mu", "expected a number in (0, 1]");
  expectMessage(estimatorError("algorithm: rseio\nmu: abc"), "est.yaml", "mu", "expected a number, found 'abc'");
  expectMessage(estimatorError("algorithm: aoe\ncontrol_link: {recovery: 0.3}"), "est.yaml", "control_link.failure",
                "missing required key");
  expectMessage(estimatorError("algorithm: aoe\ncontrol_link: {failure: 0.3}"), "est.yaml", "control_link.recovery",
                "missing required key");
  expectMessage(estimatorError("algorithm: aoe\ncontrol_link: {recovery: 1.3, failure: 0.1}"), "est.yaml",
                "control_link.recovery", "expected a probability in [0, 1], found 1.3");
  expectMessage(estimatorError("algorithm: aoe\ncontrol_link: {recovery: 0.3, failure: -0.1}"), "est.yaml",
                "control_link.failure", "expected a probability in [0, 1]");
  expectMessage(estimatorError("algorithm: aoe\ncontrol_link: {recovery: 0.3, failure: 0.1, delay: 1}"), "est.yaml",
                "control_link.delay", "unknown key");
  expectMessage(estimatorError("algorithm: aoe\ncontrol_link: 0.3"), "est.yaml", "control_link", "expected a map");
  expectMessage(estimatorError("algorithm: oe\nmax_components: 2.5"), "est.yaml", "max_components",
                "expected an integer >= 1, found '2.5'");
  expectMessage(estimatorError("algorithm: oe\nmax_components: -3"), "est.yaml", "max_components",
                "expected an integer >= 1, found -3");
  expectMessage(estimatorError("algorithm: oe\nmax_components: 0"), "est.yaml", "max_components",
                "expected an integer >= 1, found 0");
  expectMessage(estimatorError("algorithm: oe\nmu2: 0.5"), "est.yaml:2", "mu2", "unknown key");
  EXPECT_CONTAINS(estimatorError("- algorithm: oe"), "expected a map of keys at the top level");
}

TEST(LoadEstimatorSettings, FileAndMissingFile)
{
  TempDir dir;
  const std::string path = dir.write("est.yaml", "algorithm: ack_kf\n");
  EXPECT_EQ(ne::loadEstimatorSettings(path).algorithm, ne::Algorithm::ACK_KF);
  const std::string missing = (dir.path() / "none.yaml").string();
  EXPECT_EQ(errorOf([&] { ne::loadEstimatorSettings(missing); }), missing + ": cannot open file");
  const std::string bad = dir.write("bad.yaml", "algorithm: [kf\n");
  EXPECT_CONTAINS(errorOf([&] { ne::loadEstimatorSettings(bad); }), "YAML syntax error");
}
