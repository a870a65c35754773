// Writing a model file that reads back bit for bit (model_writer.hpp).
#include "networked_estimation/config/model_writer.hpp"

#include <cstdio>
#include <string>

#include "config/yaml_reader.hpp"
#include "networked_estimation/common/error.hpp"

namespace networked_estimation
{
using namespace detail;

namespace
{

/// A YAML double-quoted scalar: backslash, quote and control characters escaped.
std::string yamlString(const std::string& text)
{
  std::string out = "\"";
  for (const char c : text)
  {
    if (c == '"' || c == '\\')
    {
      out += '\\';
      out += c;
    }
    else if (static_cast<unsigned char>(c) < 0x20)
    {
      char buf[8];
      std::snprintf(buf, sizeof(buf), "\\x%02x", static_cast<unsigned>(static_cast<unsigned char>(c)));
      out += buf;
    }
    else
    {
      out += c;
    }
  }
  return out + "\"";
}

std::string row(const Eigen::MatrixXd& M, Eigen::Index i)
{
  std::string out = "[";
  for (Eigen::Index j = 0; j < M.cols(); ++j)
  {
    out += (j ? ", " : "") + plainNumber(M(i, j));
  }
  return out + "]";
}

/// A matrix in block style, one row a line, each line starting with `indent`.
void writeMatrix(std::ostream& out, const std::string& indent, const std::string& key, const Eigen::MatrixXd& M)
{
  out << indent << key << ":\n";
  for (Eigen::Index i = 0; i < M.rows(); ++i)
  {
    out << indent << "  - " << row(M, i) << "\n";
  }
}

/// [[a, b], [], [c]]: per entry the names of the sensors it marks.
void writeSubsets(std::ostream& out, const std::string& key, const Model& model,
                  const std::vector<std::vector<bool>>& subsets)
{
  out << "  " << key << ": [";
  for (std::size_t i = 0; i < subsets.size(); ++i)
  {
    out << (i ? ", [" : "[");
    bool first = true;
    for (std::size_t s = 0; s < subsets[i].size(); ++s)
    {
      if (subsets[i][s])
      {
        out << (first ? "" : ", ") << yamlString(model.sensors[s].name);
        first = false;
      }
    }
    out << "]";
  }
  out << "]\n";
}

void writeSchedule(std::ostream& out, const Model& model)
{
  const Schedule& sc = model.schedule;
  if (!sc.active())
  {
    return;
  }
  out << "schedule:\n";
  if (sc.kind == Schedule::Kind::PERIODIC)
  {
    writeSubsets(out, "pattern", model, sc.pattern);
    return;
  }
  writeSubsets(out, "subsets", model, sc.subsets);
  if (sc.markov)
  {
    writeMatrix(out, "  ", "transition", sc.transition);
  }
  else
  {
    out << "  probabilities: " << row(sc.transition, 0) << "\n";  // i.i.d.: every row is the law
  }
}

}  // namespace

void writeModelYaml(std::ostream& out, const Model& model, const std::string& comment)
{
  const std::string source = "model " + yamlString(model.name);
  validateModel(model, source);

  std::string::size_type start = 0;
  while (!comment.empty() && start <= comment.size())
  {
    std::string::size_type end = comment.find('\n', start);
    if (end == std::string::npos)
    {
      end = comment.size();
    }
    const std::string line = comment.substr(start, end - start);
    if (end == comment.size() && line.empty())
    {
      break;  // a trailing newline
    }
    out << (line.empty() ? "#" : "# " + line) << "\n";
    start = end + 1;
  }

  if (!model.name.empty())
  {
    out << "name: " << yamlString(model.name) << "\n";
  }
  if (model.period > 0.0)
  {
    out << "period: " << plainNumber(model.period) << "\n";
  }
  if (!model.states.empty())
  {
    out << "states: [";
    for (std::size_t i = 0; i < model.states.size(); ++i)
    {
      out << (i ? ", " : "") << yamlString(model.states[i]);
    }
    out << "]\n";
  }
  if (!model.angles.empty())
  {
    out << "angles: [";
    for (std::size_t i = 0; i < model.angles.size(); ++i)
    {
      const int a = model.angles[i];
      out << (i ? ", " : "") << (model.states.empty() ? std::to_string(a) : yamlString(model.states[a]));
    }
    out << "]\n";
  }
  if (model.nonlinear())
  {
    // the motion's states and angles are implied; written above, they document the file
    out << "motion: " << toString(model.motion) << "\n";
    if (model.two_d_mode)
    {
      out << "two_d_mode: true\n";
    }
  }
  else
  {
    writeMatrix(out, "", "A", model.A);
  }
  if (!model.B.isIdentity(0.0))
  {
    writeMatrix(out, "", "B", model.B);
  }
  writeMatrix(out, "", "Q", model.Q);
  out << "sensors:\n";
  for (const Sensor& s : model.sensors)
  {
    out << "  - name: " << yamlString(s.name) << "\n";
    writeMatrix(out, "    ", "C", model.C.middleRows(s.offset, s.size));
    writeMatrix(out, "    ", "R", model.R.block(s.offset, s.offset, s.size, s.size));
  }
  out << "x0: " << row(model.x0.transpose(), 0) << "\n";
  writeMatrix(out, "", "P0", model.P0);
  if (model.hasControl())
  {
    out << "control:\n";
    writeMatrix(out, "  ", "Bu", model.Bu);
  }
  if (!model.uncertainty.empty())
  {
    out << "uncertainty:\n";
    for (const Uncertainty& u : model.uncertainty)
    {
      out << "  - range: " << plainNumber(u.range) << "\n";
      writeMatrix(out, "    ", "dA", u.dA);
      writeMatrix(out, "    ", "dB", u.dB);
      writeMatrix(out, "    ", "dC", u.dC);
    }
  }
  writeSchedule(out, model);
}

}  // namespace networked_estimation
