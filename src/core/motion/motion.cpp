// The built-in motion models' names, states and angles, and their step for dynamic-size vectors
// (motion.hpp; the equations are omni_motion.hpp's).
#include "networked_estimation/motion/motion.hpp"

#include "networked_estimation/common/error.hpp"
#include "networked_estimation/motion/omni_motion.hpp"

namespace networked_estimation
{

static_assert(motionStates(Motion::OMNI_2D) == omni::s2::N && motionStates(Motion::OMNI_3D) == omni::s3::N,
              "the state counts of motion.hpp and omni_motion.hpp agree");

std::string toString(Motion motion)
{
  switch (motion)
  {
    case Motion::LINEAR:
      return "linear";
    case Motion::OMNI_2D:
      return "omni_2d";
    case Motion::OMNI_3D:
      return "omni_3d";
  }
  return "?";
}

Motion motionFromString(const std::string& name, const std::string& key)
{
  if (name == "omni_2d")
    return Motion::OMNI_2D;
  if (name == "omni_3d")
    return Motion::OMNI_3D;
  throw ConfigError(key + ": expected omni_2d or omni_3d, found '" + name + "'");
}

const std::vector<std::string>& motionStateNames(Motion motion)
{
  static const std::vector<std::string> none;
  static const std::vector<std::string> two = {"x", "y", "yaw", "vx", "vy", "vyaw", "ax", "ay"};
  static const std::vector<std::string> three = {"x",  "y",     "z",      "roll", "pitch", "yaw", "vx", "vy",
                                                 "vz", "vroll", "vpitch", "vyaw", "ax",    "ay",  "az"};
  return motion == Motion::OMNI_2D ? two : motion == Motion::OMNI_3D ? three : none;
}

const std::vector<int>& motionAngles(Motion motion)
{
  static const std::vector<int> none;
  static const std::vector<int> two = {omni::s2::YAW};
  static const std::vector<int> three = {omni::s3::ROLL, omni::s3::PITCH, omni::s3::YAW};
  return motion == Motion::OMNI_2D ? two : motion == Motion::OMNI_3D ? three : none;
}

const std::vector<int>& planarConstrained()
{
  using namespace omni::s3;
  static const std::vector<int> held = {Z, ROLL, PITCH, VZ, VROLL, VPITCH, AZ};
  return held;
}

void propagate(Motion motion, const Eigen::VectorXd& x, double dt, Eigen::VectorXd& x_out, Eigen::MatrixXd* F)
{
  const int n = motionStates(motion);
  x_out.resize(n);
  if (F)
    F->resize(n, n);
  if (motion == Motion::OMNI_2D)
    omni::omni2dStep(x, dt, x_out, F);
  else if (motion == Motion::OMNI_3D)
    omni::omni3dStep(x, dt, x_out, F);
  else
    throw ConfigError("propagate: the linear model has no motion equations (use its A)");
}

}  // namespace networked_estimation
