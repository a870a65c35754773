#include "networked_estimation/config/param_reader.hpp"

#include <limits>
#include <sstream>

#include "config/field.hpp"
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
/// Parameter `key` as a checked field: messages "<source>: <key>: <problem>", a value of the wrong
/// kind shown as it is (parameters have no line to point at).
detail::Field field(const YAML::Node& params, const std::string& source, const std::string& key)
{
  return detail::Field(params, source, detail::Field::Origin::PARAMETERS)[key];
}
}  // namespace

double ParamReader::number(const std::string& key, double def, double lo, double hi)
{
  used_.insert(key);
  const detail::Field f = field(params_, source_, key);
  if (!f)
    return def;
  const double v = f.rawNumber();
  if (!(v >= lo && v <= hi))
  {
    std::ostringstream os;
    os << "expected a number in [" << lo << ", " << hi << "], found " << v;
    f.fail(os.str());
  }
  return v;
}

long ParamReader::integer(const std::string& key, long def, long lo, long hi)
{
  used_.insert(key);
  const detail::Field f = field(params_, source_, key);
  if (!f)
    return def;
  long long parsed = 0;
  if (!f.isScalar() || !detail::integerText(f.text(), parsed) || parsed < std::numeric_limits<long>::min() ||
      parsed > std::numeric_limits<long>::max())
    f.fail("expected an integer, found " + f.found());
  const long v = static_cast<long>(parsed);
  if (v < lo || v > hi)
    f.fail("expected an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], found " +
           std::to_string(v));
  return v;
}

bool ParamReader::flag(const std::string& key, bool def)
{
  used_.insert(key);
  const detail::Field f = field(params_, source_, key);
  return f ? f.boolean() : def;
}

std::string ParamReader::text(const std::string& key, const std::string& def)
{
  used_.insert(key);
  const detail::Field f = field(params_, source_, key);
  return f ? f.string() : def;
}

std::string ParamReader::required(const std::string& key)
{
  if (!has(key))
    throw ConfigError(detail::message(source_, 0, key, "required parameter is missing"));
  const std::string v = text(key, "");
  if (v.empty())
    throw ConfigError(detail::message(source_, 0, key, "required parameter is empty"));
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
  throw ConfigError(detail::message(source_, 0, key, "expected " + list + ", found '" + v + "'"));
}

std::vector<int> ParamReader::indices(const std::string& key, const std::vector<int>& def, int bound)
{
  used_.insert(key);
  const detail::Field f = field(params_, source_, key);
  if (!f)
    return def;
  if (!f.isList())
    f.fail("expected a list of state indices, found " + f.found());
  std::vector<int> out;
  for (const detail::Field& e : f.elements())
  {
    long long i = -1;
    if (!e.isScalar() || !detail::integerText(e.text(), i))
      f.fail("expected integer indices, found " + f.found());
    if (i < 0 || i >= bound)
      f.fail("index " + std::to_string(i) + " outside the state [0, " + std::to_string(bound) + ")");
    for (int j : out)
      if (j == i)
        f.fail("index " + std::to_string(i) + " repeated");
    out.push_back(static_cast<int>(i));
  }
  if (out.size() > 3)
    f.fail("at most 3 indices (x, y, z), found " + std::to_string(out.size()));
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
