// Constant-velocity and constant-acceleration models (kinematic_model.hpp).
#include "networked_estimation/config/kinematic_model.hpp"

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "config/yaml_reader.hpp"
#include "networked_estimation/common/error.hpp"

namespace networked_estimation
{
using namespace detail;

namespace
{

const char* const kConstantVelocity = "constant_velocity";
const char* const kConstantAcceleration = "constant_acceleration";
const char* const kQuantities[] = {"position", "velocity", "acceleration"};
const char* const kUnits[] = {"m", "m/s", "m/s^2"};
const char* const kHeadingQuantities[] = {"yaw", "yaw_rate", "yaw_acceleration"};
const char* const kHeadingUnits[] = {"rad", "rad/s", "rad/s^2"};

double factorial(int k)
{
  double f = 1.0;
  for (int i = 2; i <= k; ++i)
  {
    f *= i;
  }
  return f;
}

/// One axis, derivatives 0..order-1: A_ij = T^(j-i) / (j-i)!, and with m = order - 1
/// Q_ij = q T^(2m+1-i-j) / ((m-i)! (m-j)! (2m+1-i-j)), the integral of
/// (e^{F s} G)_i (e^{F s} G)_j = s^(m-i) / (m-i)! * s^(m-j) / (m-j)! over [0, T].
void axisBlocks(int order, double T, double q, Eigen::MatrixXd& A, Eigen::MatrixXd& Q)
{
  const int m = order - 1;
  A = Eigen::MatrixXd::Zero(order, order);
  Q = Eigen::MatrixXd::Zero(order, order);
  for (int i = 0; i < order; ++i)
  {
    for (int j = 0; j < order; ++j)
    {
      if (j >= i)
      {
        A(i, j) = std::pow(T, j - i) / factorial(j - i);
      }
      const int power = 2 * m + 1 - i - j;
      Q(i, j) = q * std::pow(T, power) / (factorial(m - i) * factorial(m - j) * power);
    }
  }
}

std::string quoted(const std::string& text)
{
  return "'" + text + "'";
}

std::string motionProblem(const std::string& motion)
{
  return std::string("expected ") + kConstantVelocity + " or " + kConstantAcceleration + ", found " + quoted(motion);
}

/// 2, 3, or 0 for an unknown motion.
int orderOf(const std::string& motion)
{
  return motion == kConstantVelocity ? 2 : motion == kConstantAcceleration ? 3 : 0;
}

/// Index of the quantity among the first `order` ones (position, velocity, acceleration), or -1.
int quantityIndex(const std::string& quantity, int order)
{
  for (int i = 0; i < order; ++i)
  {
    if (quantity == kQuantities[i])
    {
      return i;
    }
  }
  return -1;
}

/// Index of a heading quantity (yaw, yaw_rate, yaw_acceleration) among the first `order`, or -1.
int headingQuantityIndex(const std::string& quantity, int order)
{
  for (int i = 0; i < order; ++i)
  {
    if (quantity == kHeadingQuantities[i])
    {
      return i;
    }
  }
  return -1;
}

std::string headingDensityUnits(int order)
{
  return order == 2 ? "rad^2/s^3" : "rad^2/s^5";
}

}  // namespace

int kinematicOrder(const std::string& motion)
{
  const int order = orderOf(motion);
  if (order == 0)
  {
    throw ConfigError(message("kinematic model", 0, "motion", motionProblem(motion)));
  }
  return order;
}

std::string densityKey(const std::string& motion)
{
  return kinematicOrder(motion) == 2 ? "accel-density" : "jerk-density";
}

std::vector<std::string> kinematicStateNames(int order, int dims, bool heading)
{
  const char* const axes[] = {"x", "y", "z"};
  const char* const prefixes[] = {"", "v", "a"};
  std::vector<std::string> names;
  for (int i = 0; i < order; ++i)
  {
    for (int a = 0; a < dims; ++a)
    {
      names.push_back(std::string(prefixes[i]) + axes[a]);
    }
    if (heading)
    {
      names.push_back(std::string(prefixes[i]) + "yaw");
    }
  }
  return names;
}

Model makeKinematicModel(const KinematicSpec& spec)
{
  const std::string source = "kinematic model " + quoted(spec.name);
  const auto name = [&spec](const std::string& key) { return spec.key_name ? spec.key_name(key) : key; };
  const auto fail = [&source, &name](const std::string& key, const std::string& problem)
  { throw ConfigError(message(source, 0, name(key), problem)); };

  const int order = orderOf(spec.motion);
  if (order == 0)
  {
    fail("motion", motionProblem(spec.motion));
  }
  if (spec.dims < 1 || spec.dims > 3)
  {
    fail("dims", "expected 1, 2 or 3, found " + std::to_string(spec.dims));
  }
  if (!std::isfinite(spec.rate) || !(spec.rate > 0.0))
  {
    fail("rate", "expected a finite number of Hz > 0, found " + plainNumber(spec.rate));
  }
  const std::string q_units = order == 2 ? "m^2/s^3" : "m^2/s^5";
  if (!std::isfinite(spec.density) || !(spec.density > 0.0))
  {
    fail(densityKey(spec.motion),
         "expected a finite spectral density > 0 (" + q_units + "), found " + plainNumber(spec.density));
  }
  const bool heading = spec.heading_density != 0.0;
  if (heading && (!std::isfinite(spec.heading_density) || !(spec.heading_density > 0.0)))
  {
    fail("heading", "expected a finite spectral density > 0 (" + headingDensityUnits(order) + "), found " +
                        plainNumber(spec.heading_density));
  }
  if (heading && spec.dims < 2)
  {
    fail("heading", "a heading needs a robot in 2-D or 3-D, found dims 1");
  }
  const int d = spec.dims;
  const int D = d + (heading ? 1 : 0);  // axes, the heading last
  const int n = order * D;
  const double T = 1.0 / spec.rate;

  Model model;
  model.name = spec.name;
  model.period = T;
  Eigen::MatrixXd A1, Q1, Ah, Qh;
  axisBlocks(order, T, spec.density, A1, Q1);
  if (heading)
  {
    axisBlocks(order, T, spec.heading_density, Ah, Qh);
  }
  model.A = Eigen::MatrixXd::Zero(n, n);
  model.Q = Eigen::MatrixXd::Zero(n, n);
  for (int i = 0; i < order; ++i)
  {
    for (int j = 0; j < order; ++j)
    {
      for (int a = 0; a < D; ++a)
      {
        const bool yaw = a == d;
        model.A(i * D + a, j * D + a) = yaw ? Ah(i, j) : A1(i, j);
        model.Q(i * D + a, j * D + a) = yaw ? Qh(i, j) : Q1(i, j);
      }
    }
  }
  model.B = Eigen::MatrixXd::Identity(n, n);
  model.states = kinematicStateNames(order, d, heading);
  if (heading)
  {
    model.angles = {d};  // the yaw, first of the heading's entries
  }
  // Q's correlation matrix (Q scaled to unit diagonal) does not depend on T or q: Q = q S C S with
  // S = diag(T^(r-1/2-i)). The model checks test definiteness on that scaling (yaml_reader.cpp), so
  // Q passes them at every rate; what is refused is a rate (with q) at which Q's entries leave the
  // normal doubles: q T^(2r-1) underflows (above about 1.9e61 Hz for constant acceleration and 2.5e102
  // Hz for constant velocity with q = 1; subnormal entries have lost their precision) or one
  // overflows (rates below about 1e-62 Hz, 1e-103 Hz for constant velocity).
  // Checked per block: the axes' Q (with the density) and the heading's (with its own density).
  const auto checkBlock = [&](const Eigen::MatrixXd& Qb, const std::string& key, double density)
  {
    const bool normal = Qb.allFinite() && (Qb.array().abs() >= std::numeric_limits<double>::min()).all();
    const std::string q_problem =
        normal ? networked_estimation::checkCovariance(Qb, Definiteness::POSITIVE).describe("Q") : std::string();
    if (!normal || !q_problem.empty())
    {
      const std::string what = normal ? "that is not positive definite: " + q_problem
                                      : "whose entries leave the range of double precision (per axis from q T^" +
                                            std::to_string(2 * order - 1) + " = " + plainNumber(Qb(0, 0)) +
                                            " to q T = " + plainNumber(Qb(order - 1, order - 1)) +
                                            "; normal doubles are 2.2e-308 to 1.8e308 in magnitude)";
      fail("rate", plainNumber(spec.rate) + " Hz with " + key + " " + plainNumber(density) + " gives a " + spec.motion +
                       " Q " + what + "; use a less extreme rate or density");
    }
  };
  checkBlock(Q1, densityKey(spec.motion), spec.density);
  if (heading)
  {
    checkBlock(Qh, "heading", spec.heading_density);
  }

  // Sensors
  if (spec.sensors.empty())
  {
    fail("sensors", "expected at least one sensor, found none");
  }
  int m = 0;
  for (const KinematicSensor& in : spec.sensors)
  {
    m += headingQuantityIndex(in.quantity, 3) >= 0 ? 1 : d;
  }
  model.C = Eigen::MatrixXd::Zero(m, n);
  model.R = Eigen::MatrixXd::Zero(m, m);
  int offset = 0;
  for (std::size_t s = 0; s < spec.sensors.size(); ++s)
  {
    const KinematicSensor& in = spec.sensors[s];
    const std::string key = indexKey("sensors", s);
    if (in.name.empty())
    {
      fail(key + ".name", "expected a non-empty name, found ''");
    }
    for (std::size_t k = 0; k < s; ++k)
    {
      if (spec.sensors[k].name == in.name)
      {
        fail(key + ".name",
             "duplicate sensor name " + quoted(in.name) + " (also " + name(indexKey("sensors", k) + ".name") + ")");
      }
    }
    const int which = quantityIndex(in.quantity, order);
    const int yaw_which = heading ? headingQuantityIndex(in.quantity, order) : -1;
    if (which < 0 && yaw_which < 0)
    {
      std::string expected = order == 2 ? "position or velocity" : "position, velocity or acceleration";
      if (heading)
      {
        expected = order == 2 ? "position, velocity, yaw or yaw_rate"
                              : "position, velocity, acceleration, yaw, yaw_rate or yaw_acceleration";
      }
      std::string note;
      if (order == 2 && (in.quantity == kQuantities[2] || in.quantity == kHeadingQuantities[2]))
      {
        note = " (" + in.quantity + " needs a constant_acceleration model)";
      }
      else if (!heading && headingQuantityIndex(in.quantity, order) >= 0)
      {
        note = " (" + in.quantity + " needs a heading: --heading)";
      }
      fail(key + ".quantity",
           "expected " + expected + " for a " + spec.motion + " model" + note + ", found " + quoted(in.quantity));
    }
    if (!std::isfinite(in.sigma) || !(in.sigma > 0.0))
    {
      fail(key + ".sigma", std::string("expected a finite standard deviation > 0 (") +
                               (which >= 0 ? kUnits[which] : kHeadingUnits[yaw_which]) + "), found " +
                               plainNumber(in.sigma));
    }
    const int rows = which >= 0 ? d : 1;
    for (int a = 0; a < rows; ++a)
    {
      const int column = which >= 0 ? which * D + a : yaw_which * D + d;
      model.C(offset + a, column) = 1.0;
      model.R(offset + a, offset + a) = in.sigma * in.sigma;
    }
    model.sensors.push_back(Sensor{in.name, offset, rows});
    offset += rows;
  }

  // x0, P0
  if (spec.x0.size() == 0)
  {
    model.x0 = Eigen::VectorXd::Zero(n);
  }
  else if (spec.x0.size() != n)
  {
    fail("x0", "expected " + std::to_string(n) + " entries (n = " + std::to_string(n) + ", the state " +
                   joinList(model.states) + "), found " + std::to_string(spec.x0.size()));
  }
  else
  {
    model.x0 = spec.x0;
  }
  const double variances[] = {spec.p0_position, spec.p0_velocity, spec.p0_acceleration};
  const char* const p0_keys[] = {"p0-position", "p0-velocity", "p0-acceleration"};
  const double yaw_variances[] = {spec.p0_yaw, spec.p0_yaw_rate, spec.p0_yaw_acceleration};
  const char* const p0_yaw_keys[] = {"p0-yaw", "p0-yaw-rate", "p0-yaw-acceleration"};
  model.P0 = Eigen::MatrixXd::Zero(n, n);
  for (int i = 0; i < order; ++i)
  {
    if (!std::isfinite(variances[i]) || variances[i] < 0.0)
    {
      fail(p0_keys[i], std::string("expected a finite variance >= 0 (") + kUnits[i] + " squared), found " +
                           plainNumber(variances[i]));
    }
    if (heading && (!std::isfinite(yaw_variances[i]) || yaw_variances[i] < 0.0))
    {
      fail(p0_yaw_keys[i], std::string("expected a finite variance >= 0 (") + kHeadingUnits[i] + " squared), found " +
                               plainNumber(yaw_variances[i]));
    }
    for (int a = 0; a < D; ++a)
    {
      model.P0(i * D + a, i * D + a) = a == d ? yaw_variances[i] : variances[i];
    }
  }
  model.Bu = Eigen::MatrixXd::Zero(n, 0);

  validateModel(model, source);
  return model;
}

std::string kinematicModelComment(const KinematicSpec& spec)
{
  const int order = kinematicOrder(spec.motion);
  const double T = 1.0 / spec.rate;
  std::string units = "m, m/s";
  std::string order_text = "all positions, then all velocities";
  std::string A_text = "[[1, T], [0, 1]]";
  std::string Q_text = "q [[T^3/3, T^2/2], [T^2/2, T]]";
  std::string noise = "acceleration";
  std::string q_units = "m^2/s^3";
  if (order == 3)
  {
    units += ", m/s^2";
    order_text += ", then all accelerations";
    A_text = "[[1, T, T^2/2], [0, 1, T], [0, 0, 1]]";
    Q_text = "q [[T^5/20, T^4/8, T^3/6], [T^4/8, T^3/3, T^2/2], [T^3/6, T^2/2, T]]";
    noise = "jerk";
    q_units = "m^2/s^5";
  }
  const bool heading = spec.heading_density != 0.0;
  if (heading)
  {
    units += order == 3 ? "; rad, rad/s, rad/s^2" : "; rad, rad/s";
    order_text += ", the heading last in each group";
  }
  std::string out = spec.motion + " model in " + std::to_string(spec.dims) + "-D at " + plainNumber(spec.rate) +
                    " Hz (period T = " + plainNumber(T) + " s).\n";
  out +=
      "State [" + joinList(kinematicStateNames(order, spec.dims, heading)) + "] (" + units + "): " + order_text + ".\n";
  out += "Process noise: white " + noise + " of spectral density q = " + plainNumber(spec.density) + " " + q_units +
         " on every axis.\n";
  if (heading)
  {
    out += "Heading: yaw, an angle in (-pi, pi] (angles: [yaw]), moving like an axis with white angular " + noise +
           " of spectral density q = " + plainNumber(spec.heading_density) + " " + headingDensityUnits(order) + ".\n";
  }
  out += "A = e^{F T}, per axis " + A_text + ".\n";
  out += "Q = integral over [0, T] of e^{F s} G q G' e^{F' s} ds, per axis\n";
  out += "    " + Q_text + "; B = identity.\n";
  for (const KinematicSensor& s : spec.sensors)
  {
    const int which = quantityIndex(s.quantity, order);
    const int yaw_which = headingQuantityIndex(s.quantity, order);
    if (yaw_which >= 0 && which < 0)
    {
      out += "Sensor " + s.name + ": the heading's " + s.quantity + ", sigma = " + plainNumber(s.sigma) + " " +
             kHeadingUnits[yaw_which] + " (R = sigma^2).\n";
      continue;
    }
    out += "Sensor " + s.name + ": the " + s.quantity + " of every axis, sigma = " + plainNumber(s.sigma) + " " +
           kUnits[which < 0 ? 0 : which] + " (R = sigma^2 I).\n";
  }
  return out;
}

}  // namespace networked_estimation
