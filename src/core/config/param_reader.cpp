#include "networked_estimation/config/param_reader.hpp"

#include <limits>
#include <sstream>

#include "config/yaml_reader.hpp"
#include "networked_estimation/common/error.hpp"

namespace networked_estimation
{

ParamReader::ParamReader(YAML::Node params, std::string source)
  : params_(params.IsMap() ? params : YAML::Node(YAML::NodeType::Map)), source_(std::move(source))
{
}

bool ParamReader::has(const std::string& key) const
{
  return static_cast<bool>(params_[key]);
}

namespace
{
std::string show(const YAML::Node& n)
{
  YAML::Emitter e;
  e << YAML::Flow << n;
  return e.c_str();
}
}  // namespace

double ParamReader::number(const std::string& key, double def, double lo, double hi)
{
  used_.insert(key);
  const YAML::Node n = params_[key];
  if (!n)
    return def;
  double v = 0.0;
  try
  {
    v = n.as<double>();
  }
  catch (const YAML::Exception&)
  {
    throw ConfigError(source_ + ": " + key + ": expected a number, found '" + show(n) + "'");
  }
  if (!(v >= lo && v <= hi))
  {
    std::ostringstream os;
    os << source_ << ": " << key << ": expected a number in [" << lo << ", " << hi << "], found " << v;
    throw ConfigError(os.str());
  }
  return v;
}

long ParamReader::integer(const std::string& key, long def, long lo, long hi)
{
  used_.insert(key);
  const YAML::Node n = params_[key];
  if (!n)
    return def;
  long long parsed = 0;
  if (!n.IsScalar() || !detail::integerText(n.Scalar(), parsed) || parsed < std::numeric_limits<long>::min() ||
      parsed > std::numeric_limits<long>::max())
    throw ConfigError(source_ + ": " + key + ": expected an integer, found '" + show(n) + "'");
  const long v = static_cast<long>(parsed);
  if (v < lo || v > hi)
    throw ConfigError(source_ + ": " + key + ": expected an integer in [" + std::to_string(lo) + ", " +
                      std::to_string(hi) + "], found " + std::to_string(v));
  return v;
}

bool ParamReader::flag(const std::string& key, bool def)
{
  used_.insert(key);
  const YAML::Node n = params_[key];
  if (!n)
    return def;
  bool v = false;
  if (!n.IsScalar() || !detail::booleanText(n.Scalar(), v))
    throw ConfigError(source_ + ": " + key + ": expected true or false, found '" + show(n) + "'");
  return v;
}

std::string ParamReader::text(const std::string& key, const std::string& def)
{
  used_.insert(key);
  const YAML::Node n = params_[key];
  if (!n)
    return def;
  if (!n.IsScalar())
    throw ConfigError(source_ + ": " + key + ": expected a string, found '" + show(n) + "'");
  return n.as<std::string>();
}

std::string ParamReader::required(const std::string& key)
{
  if (!has(key))
    throw ConfigError(source_ + ": " + key + ": required parameter is missing");
  const std::string v = text(key, "");
  if (v.empty())
    throw ConfigError(source_ + ": " + key + ": required parameter is empty");
  return v;
}

std::string ParamReader::choice(const std::string& key, const std::string& def, const std::vector<std::string>& choices)
{
  const std::string v = text(key, def);
  for (const std::string& c : choices)
    if (c == v)
      return v;
  std::string list;
  for (const std::string& c : choices)
    list += (list.empty() ? "" : " | ") + c;
  throw ConfigError(source_ + ": " + key + ": expected " + list + ", found '" + v + "'");
}

std::vector<int> ParamReader::indices(const std::string& key, const std::vector<int>& def, int bound)
{
  used_.insert(key);
  const YAML::Node n = params_[key];
  if (!n)
    return def;
  std::vector<int> out;
  if (!n.IsSequence())
    throw ConfigError(source_ + ": " + key + ": expected a list of state indices, found '" + show(n) + "'");
  for (const YAML::Node& e : n)
  {
    int i = -1;
    try
    {
      i = e.as<int>();
    }
    catch (const YAML::Exception&)
    {
      throw ConfigError(source_ + ": " + key + ": expected integer indices, found '" + show(n) + "'");
    }
    if (i < 0 || i >= bound)
      throw ConfigError(source_ + ": " + key + ": index " + std::to_string(i) + " outside the state [0, " +
                        std::to_string(bound) + ")");
    for (int j : out)
      if (j == i)
        throw ConfigError(source_ + ": " + key + ": index " + std::to_string(i) + " repeated");
    out.push_back(i);
  }
  if (out.size() > 3)
    throw ConfigError(source_ + ": " + key + ": at most 3 indices (x, y, z), found " + std::to_string(out.size()));
  return out;
}

YAML::Node ParamReader::take(const std::string& key)
{
  used_.insert(key);
  return params_[key] ? YAML::Node(params_[key]) : YAML::Node();
}

void ParamReader::rejectUnknown() const
{
  std::string unknown;
  for (auto it = params_.begin(); it != params_.end(); ++it)
  {
    const std::string k = it->first.as<std::string>();
    if (!used_.count(k))
      unknown += (unknown.empty() ? "" : ", ") + k;
  }
  if (!unknown.empty())
    throw ConfigError(source_ + ": unknown parameter(s): " + unknown);
}

}  // namespace networked_estimation
