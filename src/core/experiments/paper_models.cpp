// The papers' example models (paper_models.hpp): Zhou's and Lin et al.'s from the model files in
// config/models compiled into the core (embedded_models.hpp), Yang et al.'s written here.
#include "experiments/paper_models.hpp"

#include <map>
#include <mutex>
#include <stdexcept>
#include <yaml-cpp/yaml.h>

#include "experiments/embedded_models.hpp"
#include "networked_estimation/common/error.hpp"

namespace networked_estimation
{
namespace mc
{

namespace
{

/// The parsed model of the embedded file config/models/<name>.yaml, parsed once.
const Model& embeddedModel(const std::string& name)
{
  static std::mutex mutex;
  static std::map<std::string, Model> parsed;
  std::lock_guard<std::mutex> lock(mutex);
  const auto found = parsed.find(name);
  if (found != parsed.end())
    return found->second;
  for (const EmbeddedModel& e : embeddedModels())
    if (name == e.name)
    {
      const std::string source = std::string(e.path) + " (built in)";
      YAML::Node root;
      try
      {
        root = YAML::Load(e.text);
      }
      catch (const YAML::Exception& ex)
      {
        throw ConfigError(source + ":" + std::to_string(ex.mark.line + 1) + ": " + ex.msg);
      }
      return parsed.emplace(name, parseModel(root, source)).first->second;
    }
  throw std::logic_error("no built-in model file config/models/" + name + ".yaml (cmake/embedded_models.cmake)");
}

}  // namespace

Model builtInModel(const std::string& name)
{
  return embeddedModel(name);
}

Model zhouExampleModel(double delta)
{
  Model m = embeddedModel("zhou_example");
  if (m.uncertainty.size() != 1)
    throw std::logic_error("config/models/zhou_example.yaml: expected one uncertain parameter, found " +
                           std::to_string(m.uncertainty.size()));
  m.uncertainty[0].range = delta;
  validateModel(m, "zhou_example");
  return m;
}

Model aoeExampleModel(double rhoA)
{
  Model m = embeddedModel("aoe_example");
  m.A(0, 0) = rhoA;
  validateModel(m, "aoe_example");
  return m;
}

const std::vector<double>& yangRates()
{
  static const std::vector<double> rates = {0.2443, 0.4572, 0.7435, 0.6174, 0.1747, 0.6024, 0.8031, 0.3663};
  return rates;
}

Model yangExampleModel()
{
  Model m;
  m.name = "yang_example1";
  m.period = 1.0;
  m.A.resize(2, 2);
  m.A << -0.82, 0.53, 0.34, 0.78;
  m.B = Eigen::MatrixXd::Identity(2, 2);
  m.Q.resize(2, 2);
  m.Q << 0.53, 0.21, 0.21, 0.50;
  const std::vector<std::vector<double>> H = {
      {-0.69, 0.67},
      {1.18, -0.36, 0.70, -0.38},
      {-1.58, 1.43},
      {-1.71, -2.12},
      {-0.65, 0.49, -2.01, 0.46},
      {1.79, 2.2, 0.59, 0.31},
      {1.28, 2.07, -1.00, -0.92},
      {0.18, 0.21, 2.04, 0.91},
  };
  int rows = 0;
  for (const auto& h : H)
    rows += static_cast<int>(h.size()) / 2;
  m.C.resize(rows, 2);
  int off = 0;
  for (std::size_t i = 0; i < H.size(); ++i)
  {
    const int p = static_cast<int>(H[i].size()) / 2;
    for (int r = 0; r < p; ++r)
    {
      m.C(off + r, 0) = H[i][2 * r];
      m.C(off + r, 1) = H[i][2 * r + 1];
    }
    m.sensors.push_back({"s" + std::to_string(i + 1), off, p});
    off += p;
  }
  m.R = Eigen::MatrixXd::Identity(rows, rows);
  m.x0 = Eigen::Vector2d::Zero();
  m.P0 = Eigen::MatrixXd::Identity(2, 2);
  m.Bu.resize(2, 0);
  validateModel(m, "yang_example1");
  return m;
}

}  // namespace mc

}  // namespace networked_estimation
