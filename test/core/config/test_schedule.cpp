// Sensor schedules (schedule.hpp): the model file's `schedule` map and its errors, the sampler's
// transmit pattern, LossyRun (a sensor that is not scheduled is never a loss, the links' losses are
// unchanged by a schedule), and the replay CSV's '-' cells.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <sstream>
#include <string>

#include "networked_estimation/common/error.hpp"
#include "networked_estimation/config/model.hpp"
#include "networked_estimation/config/rate_schedule.hpp"
#include "networked_estimation/stability/stability.hpp"
#include "networked_estimation/io/replay_csv.hpp"
#include "networked_estimation/simulation/lossy_run.hpp"
#include "networked_estimation/simulation/schedule_sampler.hpp"

using namespace networked_estimation;

namespace
{

const std::string kBase = R"(
name: sched
period: 0.1
A: [[0.9, 0], [0, 0.5]]
Q: [[1, 0], [0, 1]]
sensors:
  - {name: gnss, C: [[1, 0]], R: [[1]]}
  - {name: camera, C: [[0, 1], [1, 1]], R: [[1, 0], [0, 1]]}
  - {name: wheel, C: [[1, 1]], R: [[1]]}
)";

Model withSchedule(const std::string& schedule)
{
  return parseModel(YAML::Load(kBase + "schedule:\n" + schedule), "m.yaml");
}

std::string errorOf(const std::string& schedule)
{
  try
  {
    withSchedule(schedule);
  }
  catch (const ConfigError& e)
  {
    return e.what();
  }
  ADD_FAILURE() << "no ConfigError for\n" << schedule;
  return "";
}

#define EXPECT_CONTAINS(text, part) EXPECT_NE(std::string(text).find(part), std::string::npos) << "message: " << (text)

ChannelSettings bernoulli(double loss)
{
  ChannelSettings c;
  c.model = LossModelKind::BERNOULLI;
  c.loss = loss;
  return c;
}

}  // namespace

TEST(Schedule, ParsePeriodic)
{
  const Model m = withSchedule("  pattern: [[gnss], [camera, wheel], []]\n");
  ASSERT_EQ(m.schedule.kind, Schedule::Kind::PERIODIC);
  EXPECT_EQ(m.schedule.period(), 3);
  EXPECT_EQ(m.schedule.maxTransmitting(), 2);
  EXPECT_EQ(m.schedule.pattern[0], (std::vector<bool>{true, false, false}));
  EXPECT_EQ(m.schedule.pattern[1], (std::vector<bool>{false, true, true}));
  EXPECT_EQ(m.schedule.pattern[2], (std::vector<bool>{false, false, false}));
  EXPECT_DOUBLE_EQ(m.schedule.transmitFraction(0), 1.0 / 3.0);
  EXPECT_EQ(m.schedule.describe({"gnss", "camera", "wheel"}), "periodic, tau = 3: [gnss] [camera, wheel] []");
  // No schedule: everything always.
  const Model none = parseModel(YAML::Load(kBase), "m.yaml");
  EXPECT_FALSE(none.schedule.active());
  EXPECT_EQ(none.schedule.transmitFraction(1), 1.0);
}

TEST(Schedule, ParseRandom)
{
  const Model iid = withSchedule("  subsets: [[gnss], [camera], [gnss, wheel]]\n  probabilities: [0.5, 0.3, 0.2]\n");
  ASSERT_EQ(iid.schedule.kind, Schedule::Kind::RANDOM);
  EXPECT_FALSE(iid.schedule.markov);
  EXPECT_NEAR(iid.schedule.transmitFraction(0), 0.7, 1e-15);
  EXPECT_NEAR(iid.schedule.transition(2, 1), 0.3, 1e-15);
  const Model mk = withSchedule("  subsets: [[gnss], [camera]]\n  transition: [[0.9, 0.1], [0.3, 0.7]]\n");
  EXPECT_TRUE(mk.schedule.markov);
  // Stationary law of the chain: (0.75, 0.25).
  EXPECT_NEAR(mk.schedule.initial[0], 0.75, 1e-12);
  EXPECT_NEAR(mk.schedule.transmitFraction(1), 0.25, 1e-12);
}

TEST(Schedule, Errors)
{
  EXPECT_CONTAINS(errorOf("  pattern: [[gnss], [lidar]]\n"), "schedule.pattern[1][0]: 'lidar' is not a sensor");
  EXPECT_CONTAINS(errorOf("  pattern: [[gnss], [lidar]]\n"), "gnss, camera, wheel");
  EXPECT_CONTAINS(errorOf("  pattern: [[gnss, gnss]]\n"), "schedule.pattern[0][1]: sensor 'gnss' listed twice");
  EXPECT_CONTAINS(errorOf("  pattern: []\n"), "schedule.pattern: expected a non-empty list");
  EXPECT_CONTAINS(errorOf("  pattern: [gnss]\n"), "schedule.pattern[0]: expected a list of sensor names");
  // a schedule under which nothing is ever received
  EXPECT_CONTAINS(errorOf("  pattern: [[], []]\n"), "schedule.pattern: no step schedules a sensor (every step is [])");
  EXPECT_CONTAINS(errorOf("  subsets: [[], []]\n  probabilities: [0.5, 0.5]\n"),
                  "schedule.subsets: every subset is []");
  EXPECT_CONTAINS(errorOf("  pattern: [[gnss]]\n  probabilities: [1]\n"), "cannot be combined with schedule.pattern");
  EXPECT_CONTAINS(errorOf("  subsets: [[gnss], [camera]]\n"), "needs probabilities (i.i.d.) or transition");
  EXPECT_CONTAINS(errorOf("  subsets: [[gnss], [camera]]\n  probabilities: [0.5, 0.6]\n"), "must sum to 1, found 1.1");
  EXPECT_CONTAINS(errorOf("  subsets: [[gnss], [camera]]\n  probabilities: [0.5]\n"), "schedule.probabilities");
  EXPECT_CONTAINS(errorOf("  subsets: [[gnss], [camera]]\n  probabilities: [1.5, -0.5]\n"),
                  "schedule.probabilities[0]: expected a probability in [0, 1], found 1.5");
  EXPECT_CONTAINS(errorOf("  subsets: [[gnss], [camera]]\n  transition: [[0.5, 0.4], [0, 1]]\n"),
                  "row 0 must sum to 1");
  EXPECT_CONTAINS(errorOf("  subsets: [[gnss], [camera]]\n  transition: [[1, 0], [0, 1]]\n"),
                  "no unique stationary distribution");
  EXPECT_CONTAINS(errorOf("  subsets: [[gnss]]\n  probabilities: [1]\n  transition: [[1]]\n"), "not both");
  EXPECT_CONTAINS(errorOf("  period: 2\n"), "schedule.period");
  EXPECT_CONTAINS(errorOf("  {}\n"), "schedule");
  // validateModel on a hand-built model: a mask of the wrong size.
  Model m = withSchedule("  pattern: [[gnss]]\n");
  m.schedule.pattern[0].pop_back();
  try
  {
    validateModel(m, "built");
    ADD_FAILURE() << "no error";
  }
  catch (const ConfigError& e)
  {
    EXPECT_CONTAINS(e.what(), "schedule.pattern[0]: expected a mask over 3 sensors, found 2");
  }
}

TEST(Schedule, SamplerPeriodicPatternExact)
{
  const Model m = withSchedule("  pattern: [[gnss], [camera, wheel], []]\n");
  ScheduleSampler s(m.schedule, 3, 1);
  for (long k = 1; k <= 30; ++k)
  {
    const std::vector<bool>& on = s.next();
    EXPECT_EQ(on, m.schedule.pattern[static_cast<std::size_t>((k - 1) % 3)]) << k;
    EXPECT_EQ(s.state(), (k - 1) % 3);
  }
}

// Random schedules: the frequency of each subset within 4.5 standard errors of its probability
// (binomial, 40000 steps: sd = sqrt(p (1 - p) / 40000) <= 0.0025), and for the Markov chain the
// transition frequencies out of each subset likewise (counts >= 9000 per row).
TEST(Schedule, SamplerRandomFrequencies)
{
  const Model iid = withSchedule("  subsets: [[gnss], [camera], [gnss, wheel]]\n  probabilities: [0.5, 0.3, 0.2]\n");
  ScheduleSampler s(iid.schedule, 3, 7);
  const long N = 40000;
  std::vector<long> count(3, 0);
  for (long k = 0; k < N; ++k)
  {
    s.next();
    EXPECT_EQ(s.current(), iid.schedule.subsets[static_cast<std::size_t>(s.state())]);
    ++count[static_cast<std::size_t>(s.state())];
  }
  const double p[3] = {0.5, 0.3, 0.2};
  for (int i = 0; i < 3; ++i)
    EXPECT_NEAR(count[i] / static_cast<double>(N), p[i], 4.5 * std::sqrt(p[i] * (1 - p[i]) / N)) << i;

  const Model mk = withSchedule("  subsets: [[gnss], [camera]]\n  transition: [[0.9, 0.1], [0.3, 0.7]]\n");
  ScheduleSampler sm(mk.schedule, 3, 9);
  long from[2] = {0, 0}, stay[2] = {0, 0};
  int prev = -1;
  for (long k = 0; k < N; ++k)
  {
    sm.next();
    if (prev >= 0)
    {
      ++from[prev];
      stay[prev] += sm.state() == prev;
    }
    prev = sm.state();
  }
  const double ps[2] = {0.9, 0.7};
  for (int i = 0; i < 2; ++i)
  {
    ASSERT_GT(from[i], 9000);
    EXPECT_NEAR(stay[i] / static_cast<double>(from[i]), ps[i], 4.5 * std::sqrt(ps[i] * (1 - ps[i]) / from[i])) << i;
  }
}

// LossyRun: a sensor that is not scheduled never arrives and is never counted as lost; the
// scheduled sensors meet exactly the losses of the same seed without a schedule (time-driven links).
TEST(Schedule, LossyRunHonoursSchedule)
{
  const Model plain = parseModel(YAML::Load(kBase), "m.yaml");
  const Model sched = withSchedule("  pattern: [[gnss], [camera, wheel]]\n");
  LossyRunOptions o;
  o.sensor_links = {bernoulli(0.3), bernoulli(0.3), std::nullopt};
  o.noise_on_loss = false;
  LossyRun a(plain, 5, o), b(sched, 5, o);
  long scheduled_lost = 0;
  for (long k = 1; k <= 400; ++k)
  {
    const SimulatedSample& sa = a.step();
    const SimulatedSample& sb = b.step();
    ASSERT_EQ(sa.y, sb.y);  // the same plant
    const std::vector<bool>& on = b.scheduled();
    EXPECT_EQ(on, sched.schedule.pattern[static_cast<std::size_t>((k - 1) % 2)]);
    EXPECT_EQ(a.scheduled(), (std::vector<bool>{true, true, true}));
    bool any = false;
    for (std::size_t s = 0; s < 3; ++s)
    {
      const Sensor& sn = sched.sensors[s];
      const bool got_a = a.received().y.segment(sn.offset, sn.size).allFinite();
      const bool got_b = b.received().y.segment(sn.offset, sn.size).allFinite();
      if (!on[s])
        EXPECT_FALSE(got_b) << k << " " << s;
      else
      {
        EXPECT_EQ(got_b, got_a) << k << " " << s;
        scheduled_lost += !got_b;
      }
      any = any || got_b;
    }
    EXPECT_EQ(b.received().gamma, any);
  }
  EXPECT_GT(scheduled_lost, 40);  // the links did lose packets (about 0.3 x 400 x 1.5 sensors)
}

TEST(Schedule, ReplayCsvDashCells)
{
  const Model m = withSchedule("  pattern: [[gnss], [camera, wheel]]\n");
  std::ostringstream os;
  writeReplayInputHeader(os, m.m(), 0, false);
  const double nan = std::nan("");
  Eigen::VectorXd y(4);
  y << 1.5, nan, nan, nan;
  std::vector<bool> off = {false, true, true, true};
  writeReplayInputRow(os, 1, true, y, Eigen::VectorXd(), false, -1, &off);
  y << nan, 2.0, 3.0, nan;  // camera arrived; wheel scheduled but lost
  off = {true, false, false, false};
  writeReplayInputRow(os, 2, true, y, Eigen::VectorXd(), false, -1, &off);
  EXPECT_EQ(os.str(), "k,gamma,y1,y2,y3,y4\n1,1,1.5,-,-,-\n2,1,-,2,3,\n");
  std::istringstream in(os.str());
  const ReplayInput r = parseReplayInput(in, "in.csv", m);
  ASSERT_EQ(r.rows.size(), 2u);
  EXPECT_EQ(r.rows[0].scheduled, (std::vector<bool>{true, false, false}));
  EXPECT_EQ(r.rows[1].scheduled, (std::vector<bool>{false, true, true}));
  EXPECT_TRUE(std::isnan(r.rows[1].y[3]));
  EXPECT_EQ(r.rows[1].y[1], 2.0);
  // A sensor partly '-' is an error naming the cell.
  std::istringstream bad("k,gamma,y1,y2,y3,y4\n1,1,1,-,2,3\n");
  try
  {
    parseReplayInput(bad, "bad.csv", m);
    ADD_FAILURE() << "no error";
  }
  catch (const InputError& e)
  {
    EXPECT_CONTAINS(e.what(), "bad.csv:2: y2: sensor 'camera' is partly '-'");
  }
  // Without '-' cells no schedule information is kept.
  std::istringstream plain("k,gamma,y1,y2,y3,y4\n1,1,1,2,3,4\n");
  EXPECT_TRUE(parseReplayInput(plain, "p.csv", m).rows[0].scheduled.empty());
}

// Sensor rates as a schedule (rate_schedule.hpp): the pattern, and the verdict it gives. A 2-D
// model, x1 a random walk seen by "odom" (every step) and "imu" (every 5th), x2 = 1.01 x2 + w seen
// only by "gps" (every 25th): between two chances to arrive x2 grows by 1.01^25, so the i.i.d.
// critical arrival rate of gps is 1 - 1/1.01^50 (a scalar block, Sinopoli's closed form), not the
// 1 - 1/1.01^2 that an every-step analysis would give.
TEST(RateSchedule, PatternAndTheVerdictItGives)
{
  Model m;
  m.name = "rates";
  m.period = 0.02;
  m.A = Eigen::Matrix2d(Eigen::Vector2d(1.0, 1.01).asDiagonal());
  m.B = m.Q = Eigen::MatrixXd::Identity(2, 2);
  m.C.resize(3, 2);
  m.C << 1, 0, 1, 0, 0, 1;
  m.R = Eigen::MatrixXd::Identity(3, 3);
  m.x0 = Eigen::VectorXd::Zero(2);
  m.P0 = Eigen::MatrixXd::Identity(2, 2);
  m.sensors = {{"odom", 0, 1}, {"imu", 1, 1}, {"gps", 2, 1}};
  m.Bu.resize(2, 0);
  validateModel(m, "rates");

  std::string note;
  EXPECT_FALSE(withSensorRates(m, {1, 1, 1}, &note).schedule.active());
  const Model r = withSensorRates(m, {1, 5, 25}, &note);
  EXPECT_TRUE(note.empty()) << note;
  ASSERT_EQ(r.schedule.kind, Schedule::Kind::PERIODIC);
  ASSERT_EQ(r.schedule.period(), 25);
  for (int t = 0; t < 25; ++t)
  {
    EXPECT_TRUE(r.schedule.pattern[t][0]);
    EXPECT_EQ(r.schedule.pattern[t][1], t % 5 == 0) << t;
    EXPECT_EQ(r.schedule.pattern[t][2], t == 0) << t;
  }
  validateModel(r, "rates with schedule");

  const std::vector<LinkModel> links = {LinkModel::iid(1.0), LinkModel::iid(1.0), LinkModel::iid(0.5)};
  AnalysisOptions opt;
  opt.per_sensor = false;
  const std::vector<SensorMargin> every_step = sensorMargins(m, links, opt);
  const std::vector<SensorMargin> own_rates = sensorMargins(r, links, opt);
  // Both by bisection on Theorem 14 to its exact_tolerance (1e-7): 1e-6 leaves room for it.
  EXPECT_NEAR(every_step[2].band.converges_at, 1.0 - 1.0 / std::pow(1.01, 2), 1e-6);
  EXPECT_NEAR(own_rates[2].band.converges_at, 1.0 - 1.0 / std::pow(1.01, 50), 1e-6);

  // What cannot be a periodic schedule is refused with the reason.
  const Model same = withSensorRates(m, {1, 2.5, 25}, &note);
  EXPECT_FALSE(same.schedule.active());
  EXPECT_NE(note.find("sensor 'imu' is sampled every 2.5"), std::string::npos) << note;
  withSensorRates(m, {1, 9973, 9967}, &note);
  EXPECT_NE(note.find("repeat only after more than 10000 steps"), std::string::npos) << note;
}
