#include "param_yaml.hpp"

#include <sstream>

namespace networked_estimation
{

YAML::Node toYaml(const XmlRpc::XmlRpcValue& value)
{
  XmlRpc::XmlRpcValue v = value;  // the accessors are non-const
  switch (v.getType())
  {
    case XmlRpc::XmlRpcValue::TypeBoolean:
      return YAML::Node(static_cast<bool>(v));
    case XmlRpc::XmlRpcValue::TypeInt:
      return YAML::Node(static_cast<int>(v));
    case XmlRpc::XmlRpcValue::TypeDouble:
    {
      // keep every digit: YAML::Node(double) may round
      std::ostringstream os;
      os.precision(17);
      os << static_cast<double>(v);
      return YAML::Node(os.str());
    }
    case XmlRpc::XmlRpcValue::TypeString:
      return YAML::Node(static_cast<std::string>(v));
    case XmlRpc::XmlRpcValue::TypeArray:
    {
      YAML::Node seq(YAML::NodeType::Sequence);
      for (int i = 0; i < v.size(); ++i)
        seq.push_back(toYaml(v[i]));
      return seq;
    }
    case XmlRpc::XmlRpcValue::TypeStruct:
    {
      YAML::Node map(YAML::NodeType::Map);
      for (auto it = v.begin(); it != v.end(); ++it)
        map[it->first] = toYaml(it->second);
      return map;
    }
    default:
      return YAML::Node(v.toXml());
  }
}

YAML::Node privateParameters(const ros::NodeHandle& pnh, const std::set<std::string>& ignore)
{
  XmlRpc::XmlRpcValue all;
  YAML::Node out(YAML::NodeType::Map);
  if (!pnh.getParam(pnh.getNamespace(), all) || all.getType() != XmlRpc::XmlRpcValue::TypeStruct)
    return out;
  for (auto it = all.begin(); it != all.end(); ++it)
    if (!ignore.count(it->first))
      out[it->first] = toYaml(it->second);
  return out;
}

}  // namespace networked_estimation
