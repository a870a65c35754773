// Tests of the channel settings and their runtime changes (config/channel_settings.hpp).
#include "config_test_support.hpp"

// =============================================================================================
// Channel settings
// =============================================================================================

TEST(ParseChannelSettings, BernoulliDefaults)
{
  const ne::ChannelSettings s = ne::parseChannelSettings(YAML::Load("model: bernoulli\nloss: 0.2"), "chan.yaml");
  EXPECT_EQ(s.model, ne::LossModelKind::BERNOULLI);
  EXPECT_DOUBLE_EQ(s.loss, 0.2);
  EXPECT_EQ(s.seed, 0u);
  EXPECT_EQ(s.delay, 0.0);
  EXPECT_EQ(s.jitter, 0.0);
  EXPECT_EQ(s.distribution, ne::DelayDistribution::UNIFORM);
  EXPECT_FALSE(s.reorder);
  EXPECT_EQ(s.duplicate, 0.0);
  EXPECT_EQ(s.queue_limit, 1000u);
}

TEST(ParseChannelSettings, GilbertElliottFull)
{
  const ne::ChannelSettings s = ne::parseChannelSettings(
      YAML::Load("model: gilbert_elliott\np: 0.05\nr: 0.4\nloss_bad: 0.9\nloss_good: 0.01\n"
                 "seed: 18446744073709551615\ndelay: 0.02\njitter: 0.005\ndistribution: pareto\n"
                 "reorder: true\nduplicate: 0.1\nqueue_limit: 5\n"),
      "chan.yaml");
  EXPECT_EQ(s.model, ne::LossModelKind::GILBERT_ELLIOTT);
  EXPECT_DOUBLE_EQ(s.p, 0.05);
  EXPECT_DOUBLE_EQ(s.r, 0.4);
  EXPECT_DOUBLE_EQ(s.loss_bad, 0.9);
  EXPECT_DOUBLE_EQ(s.loss_good, 0.01);
  EXPECT_EQ(s.seed, 18446744073709551615ULL);
  EXPECT_DOUBLE_EQ(s.delay, 0.02);
  EXPECT_DOUBLE_EQ(s.jitter, 0.005);
  EXPECT_EQ(s.distribution, ne::DelayDistribution::PARETO);
  EXPECT_TRUE(s.reorder);
  EXPECT_DOUBLE_EQ(s.duplicate, 0.1);
  EXPECT_EQ(s.queue_limit, 5u);
}

TEST(ParseChannelSettings, GilbertElliottDefaults)
{
  const ne::ChannelSettings s = ne::parseChannelSettings(
      YAML::Load("model: gilbert_elliott\np: 0.1\nr: 0.2\nseed: 42\ndistribution: normal"), "c");
  EXPECT_EQ(s.loss_bad, 1.0);
  EXPECT_EQ(s.loss_good, 0.0);
  EXPECT_EQ(s.seed, 42u);
  EXPECT_EQ(s.distribution, ne::DelayDistribution::NORMAL);
}

TEST(ParseChannelSettings, Errors)
{
  expectMessage(channelError("loss: 0.1"), "chan.yaml", "model", "missing required key");
  const std::string unknown = channelError("model: markov");
  expectMessage(unknown, "chan.yaml:1", "model", "unknown loss model 'markov'");
  EXPECT_CONTAINS(unknown, "bernoulli, gilbert_elliott");
  expectMessage(channelError("model: bernoulli"), "chan.yaml", "loss", "missing required key");
  expectMessage(channelError("model: gilbert_elliott\nr: 0.1"), "chan.yaml", "p", "missing required key");
  expectMessage(channelError("model: gilbert_elliott\np: 0.1"), "chan.yaml", "r", "missing required key");
  expectMessage(channelError("model: bernoulli\nloss: 0.1\np: 0.2"), "chan.yaml:3", "p",
                "key 'p' applies only to model gilbert_elliott (model is bernoulli)");
  expectMessage(channelError("model: bernoulli\nloss: 0.1\nloss_bad: 0.2"), "chan.yaml", "loss_bad",
                "key 'loss_bad' applies only to model gilbert_elliott");
  expectMessage(channelError("model: gilbert_elliott\np: 0.1\nr: 0.1\nloss: 0.2"), "chan.yaml", "loss",
                "key 'loss' applies only to model bernoulli (model is gilbert_elliott)");
  expectMessage(channelError("model: bernoulli\nloss: 1.2"), "chan.yaml:2", "loss",
                "expected a probability in [0, 1], found 1.2");
  expectMessage(channelError("model: bernoulli\nloss: .nan"), "chan.yaml", "loss", "expected a finite number");
  expectMessage(channelError("model: gilbert_elliott\np: -0.1\nr: 0.1"), "chan.yaml", "p", "expected a probability");
  expectMessage(channelError("model: gilbert_elliott\np: 0.1\nr: 0.1\nloss_good: 2"), "chan.yaml", "loss_good",
                "expected a probability");
  expectMessage(channelError("model: bernoulli\nloss: 0.1\nseed: -1"), "chan.yaml", "seed",
                "expected a non-negative integer, found -1");
  expectMessage(channelError("model: bernoulli\nloss: 0.1\nseed: 1.5"), "chan.yaml", "seed",
                "expected a non-negative integer, found '1.5'");
  expectMessage(channelError("model: bernoulli\nloss: 0.1\nseed: 18446744073709551616"), "chan.yaml", "seed",
                "integer out of range");
  expectMessage(channelError("model: bernoulli\nloss: 0.1\ndelay: -0.5"), "chan.yaml", "delay",
                "expected a non-negative number of seconds, found -0.5");
  expectMessage(channelError("model: bernoulli\nloss: 0.1\njitter: -1"), "chan.yaml", "jitter",
                "expected a non-negative number of seconds");
  expectMessage(channelError("model: bernoulli\nloss: 0.1\ndistribution: cauchy"), "chan.yaml", "distribution",
                "unknown distribution 'cauchy' (expected one of: uniform, normal, pareto)");
  expectMessage(channelError("model: bernoulli\nloss: 0.1\nreorder: yes"), "chan.yaml", "reorder",
                "expected true or false, found 'yes'");
  expectMessage(channelError("model: bernoulli\nloss: 0.1\nreorder: 1"), "chan.yaml", "reorder",
                "expected true or false");
  expectMessage(channelError("model: bernoulli\nloss: 0.1\nduplicate: 1.5"), "chan.yaml", "duplicate",
                "expected a probability");
  expectMessage(channelError("model: bernoulli\nloss: 0.1\nqueue_limit: 0"), "chan.yaml", "queue_limit",
                "expected an integer >= 1, found 0");
  expectMessage(channelError("model: bernoulli\nloss: 0.1\nqueue_limit: 10.5"), "chan.yaml", "queue_limit",
                "expected an integer >= 1");
  expectMessage(channelError("model: bernoulli\nloss: 0.1\nrate: 5"), "chan.yaml:3", "rate", "unknown key");
  expectMessage(channelError("model: bernoulli\nloss: abc"), "chan.yaml", "loss", "expected a number, found 'abc'");
}

TEST(LoadChannelSettings, FileAndMissingFile)
{
  TempDir dir;
  const std::string path = dir.write("chan.yaml", "model: bernoulli\nloss: 0.25\nseed: 7\n");
  const ne::ChannelSettings s = ne::loadChannelSettings(path);
  EXPECT_DOUBLE_EQ(s.loss, 0.25);
  EXPECT_EQ(s.seed, 7u);
  const std::string missing = (dir.path() / "none.yaml").string();
  EXPECT_EQ(errorOf([&] { ne::loadChannelSettings(missing); }), missing + ": cannot open file");
  const std::string bad = dir.write("bad.yaml", "model: bernoulli\nloss: {0.1\n");
  EXPECT_CONTAINS(errorOf([&] { ne::loadChannelSettings(bad); }), "YAML syntax error");
}

// Runtime changes of a channel: merged onto the current settings and validated as a whole.
TEST(ChannelSettingsMerge, RoundTripAndPartialChanges)
{
  ne::ChannelSettings ge;
  ge.model = ne::LossModelKind::GILBERT_ELLIOTT;
  ge.p = 0.05;
  ge.r = 0.4;
  ge.loss_bad = 0.9;
  ge.seed = 123456789012345ULL;
  ge.delay = 0.01;
  ge.jitter = 0.002;
  ge.distribution = ne::DelayDistribution::PARETO;
  ge.reorder = true;
  ge.queue_limit = 77;
  // round trip through YAML is exact
  const ne::ChannelSettings back = ne::parseChannelSettings(ne::toYaml(ge), "rt");
  EXPECT_EQ(back.model, ge.model);
  EXPECT_EQ(back.p, ge.p);
  EXPECT_EQ(back.r, ge.r);
  EXPECT_EQ(back.loss_bad, ge.loss_bad);
  EXPECT_EQ(back.seed, ge.seed);
  EXPECT_EQ(back.delay, ge.delay);
  EXPECT_EQ(back.jitter, ge.jitter);
  EXPECT_EQ(back.distribution, ge.distribution);
  EXPECT_EQ(back.reorder, ge.reorder);
  EXPECT_EQ(back.queue_limit, ge.queue_limit);
  // a partial change keeps everything else
  const ne::ChannelSettings worse = ne::mergeChannelSettings(ge, YAML::Load("{p: 0.2, delay: 0.05}"), "svc");
  EXPECT_EQ(worse.p, 0.2);
  EXPECT_EQ(worse.delay, 0.05);
  EXPECT_EQ(worse.r, 0.4);
  EXPECT_EQ(worse.queue_limit, 77u);
  // switching model drops the old model's keys
  const ne::ChannelSettings bern = ne::mergeChannelSettings(ge, YAML::Load("{model: bernoulli, loss: 0.3}"), "svc");
  EXPECT_EQ(bern.model, ne::LossModelKind::BERNOULLI);
  EXPECT_EQ(bern.loss, 0.3);
  EXPECT_EQ(bern.delay, 0.01);
}

TEST(ChannelSettingsMerge, InvalidChangesAreRejectedWithTheKey)
{
  ne::ChannelSettings base;
  base.loss = 0.1;
  auto expectError = [&](const std::string& yaml, const std::string& fragment)
  {
    try
    {
      ne::mergeChannelSettings(base, YAML::Load(yaml), "~set_parameters");
      ADD_FAILURE() << "accepted " << yaml;
    }
    catch (const ne::ConfigError& e)
    {
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("~set_parameters"), std::string::npos) << e.what();
    }
  };
  expectError("{loss: 1.5}", "loss");
  expectError("{delay: -1}", "delay");
  expectError("{distribution: cauchy}", "distribution");
  expectError("{bogus: 1}", "bogus");
  expectError("{p: 0.1}", "applies only to model gilbert_elliott");
  expectError("{model: gilbert_elliott}", "needs p and r");
  expectError("[1, 2]", "expected a map");
  EXPECT_EQ(base.loss, 0.1);
}
