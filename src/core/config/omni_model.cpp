// The model of a robot with a built-in motion (omni_model.hpp).
#include "networked_estimation/config/omni_model.hpp"

#include <cmath>
#include <string>
#include <vector>

#include "config/motion_config.hpp"
#include "config/yaml_reader.hpp"
#include "networked_estimation/common/error.hpp"
#include "networked_estimation/motion/motion.hpp"

namespace networked_estimation
{
using namespace detail;

namespace
{

std::string list(const std::vector<double>& v)
{
  std::string out;
  for (std::size_t i = 0; i < v.size(); ++i)
  {
    out += (i ? ", " : "") + plainNumber(v[i]);
  }
  return out;
}

}  // namespace

Model makeOmniModel(const OmniSpec& spec)
{
  const std::string source = "omni model '" + spec.name + "'";
  const auto name = [&spec](const std::string& key) { return spec.key_name ? spec.key_name(key) : key; };
  const auto fail = [&source, &name](const std::string& key, const std::string& problem)
  { throw ConfigError(message(source, 0, name(key), problem)); };
  Motion motion = Motion::LINEAR;
  try
  {
    motion = motionFromString(spec.motion, "motion");
  }
  catch (const ConfigError& e)
  {
    throw ConfigError(source + ": " + e.what());
  }
  const int n = motionStates(motion);
  const std::vector<std::string>& names = motionStateNames(motion);
  if (!std::isfinite(spec.rate) || !(spec.rate > 0.0))
  {
    fail("rate", "expected a finite number of Hz > 0, found " + plainNumber(spec.rate));
  }
  if (spec.two_d_mode && motion != Motion::OMNI_3D)
  {
    fail("two-d-mode", "only for omni_3d (omni_2d is planar already)");
  }

  Model model;
  model.name = spec.name;
  model.period = 1.0 / spec.rate;
  model.motion = motion;
  model.two_d_mode = spec.two_d_mode;
  model.states = names;
  model.angles = motionAngles(motion);
  model.A.resize(0, 0);
  model.B = Eigen::MatrixXd::Identity(n, n);
  model.Bu = Eigen::MatrixXd::Zero(n, 0);

  // Q: the diagonal per second
  const std::size_t nq = spec.process_noise.size();
  if (nq != 1 && nq != static_cast<std::size_t>(n))
  {
    fail("process-noise", "expected 1 or " + std::to_string(n) + " variances per second (one per state of " +
                              spec.motion + ": " + joinList(names) + "), found " + std::to_string(nq));
  }
  model.Q = Eigen::MatrixXd::Zero(n, n);
  for (int i = 0; i < n; ++i)
  {
    const double q = spec.process_noise[nq == 1 ? 0 : static_cast<std::size_t>(i)];
    if (!std::isfinite(q) || !(q > 0.0))
    {
      fail("process-noise", "expected finite variances per second > 0, found " + list(spec.process_noise));
    }
    model.Q(i, i) = q;
  }

  // the period: one step of it must be a finite step of the motion (before the sensors, so that a
  // rate too low is named as such)
  const std::string period_problem = motionPeriodProblem(model);
  if (!period_problem.empty())
  {
    fail("rate", "its period 1 / rate: " + period_problem);
  }

  // sensors
  if (spec.sensors.empty())
  {
    fail("sensors", "expected at least one sensor, found none");
  }
  int m = 0;
  for (const OmniSensor& s : spec.sensors)
  {
    m += static_cast<int>(s.states.size());
  }
  model.C = Eigen::MatrixXd::Zero(m, n);
  model.R = Eigen::MatrixXd::Zero(m, m);
  int offset = 0;
  for (std::size_t k = 0; k < spec.sensors.size(); ++k)
  {
    const OmniSensor& s = spec.sensors[k];
    const std::string key = indexKey("sensors", k);
    if (s.name.empty())
    {
      fail(key + ".name", "expected a non-empty name, found ''");
    }
    for (std::size_t j = 0; j < k; ++j)
    {
      if (spec.sensors[j].name == s.name)
      {
        fail(key + ".name",
             "duplicate sensor name '" + s.name + "' (also " + name(indexKey("sensors", j) + ".name") + ")");
      }
    }
    if (s.states.empty())
    {
      fail(key + ".states", "expected at least one state, found none");
    }
    if (s.sigmas.size() != 1 && s.sigmas.size() != s.states.size())
    {
      fail(key + ".sigma", "expected 1 or " + std::to_string(s.states.size()) +
                               " standard deviations (one per state measured), found " +
                               std::to_string(s.sigmas.size()));
    }
    for (std::size_t r = 0; r < s.states.size(); ++r)
    {
      int column = -1;
      for (int i = 0; i < n; ++i)
      {
        if (names[static_cast<std::size_t>(i)] == s.states[r])
        {
          column = i;
        }
      }
      if (column < 0 && s.states[r].empty())
      {
        std::string given;
        for (std::size_t j = 0; j < s.states.size(); ++j)
          given += (j ? "," : "") + s.states[j];
        fail(key + ".states", "expected names of states of " + spec.motion + " (" + joinList(names) +
                                  ") separated by commas, found " +
                                  (s.states.size() == 1 ? std::string("none") : "an empty name in '" + given + "'"));
      }
      if (column < 0)
      {
        fail(key + ".states", "'" + s.states[r] + "' is not a state of " + spec.motion + " (" + joinList(names) + ")");
      }
      for (std::size_t j = 0; j < r; ++j)
      {
        if (s.states[j] == s.states[r])
        {
          fail(key + ".states", "'" + s.states[r] + "' is measured twice");
        }
      }
      const double sigma = s.sigmas[s.sigmas.size() == 1 ? 0 : r];
      if (!std::isfinite(sigma) || !(sigma > 0.0))
      {
        fail(key + ".sigma", "expected finite standard deviations > 0, found " + list(s.sigmas));
      }
      model.C(offset + static_cast<int>(r), column) = 1.0;
      model.R(offset + static_cast<int>(r), offset + static_cast<int>(r)) = sigma * sigma;
    }
    model.sensors.push_back(Sensor{s.name, offset, static_cast<int>(s.states.size())});
    offset += static_cast<int>(s.states.size());
  }

  // x0, P0
  model.x0 = Eigen::VectorXd::Zero(n);
  if (!spec.x0.empty())
  {
    if (spec.x0.size() != static_cast<std::size_t>(n))
    {
      fail("x0", "expected " + std::to_string(n) + " entries (n = " + std::to_string(n) + ", the state " +
                     joinList(names) + "), found " + std::to_string(spec.x0.size()));
    }
    for (int i = 0; i < n; ++i)
    {
      model.x0[i] = spec.x0[static_cast<std::size_t>(i)];
    }
  }
  const std::size_t np = spec.p0.size();
  if (np > 1 && np != static_cast<std::size_t>(n))
  {
    fail("p0", "expected 1 or " + std::to_string(n) + " variances, found " + std::to_string(np));
  }
  model.P0 = Eigen::MatrixXd::Identity(n, n);
  for (int i = 0; np > 0 && i < n; ++i)
  {
    const double p = spec.p0[np == 1 ? 0 : static_cast<std::size_t>(i)];
    if (!std::isfinite(p) || p < 0.0)
    {
      fail("p0", "expected finite variances >= 0, found " + list(spec.p0));
    }
    model.P0(i, i) = p;
  }

  validateModel(model, source);
  return model;
}

std::string omniModelComment(const OmniSpec& spec)
{
  const Motion motion = motionFromString(spec.motion, "motion");
  std::string out = spec.motion + " robot at " + plainNumber(spec.rate) + " Hz (period " +
                    plainNumber(1.0 / spec.rate) + " s)" + (spec.two_d_mode ? ", two_d_mode" : "") + ".\n";
  out += "State [" + joinList(motionStateNames(motion)) + "]:\n";
  out += "  position and roll/pitch/yaw in the world frame; velocities, body rates and accelerations in\n";
  out += "  the robot's frame (docs/algorithms.md 7). No A: the motion equations predict.\n";
  out += "Process noise Q dt per step, Q = diag(" + list(spec.process_noise) + ") per second.\n";
  for (const OmniSensor& s : spec.sensors)
  {
    out += "Sensor " + s.name + ": " + joinList(s.states) + ", sigma " + list(s.sigmas) + ".\n";
  }
  return out;
}

}  // namespace networked_estimation
