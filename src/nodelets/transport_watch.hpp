// The transport each input actually got (docs/ros_interface.md, "Transport per input"). An input
// with `transport: udp` subscribes with roscpp's TransportHints().unreliable().reliable(): UDPROS
// when the publisher serves it, TCPROS otherwise. roscpp does not say which one a subscription got,
// so the nodelets ask their own process's bus info (the slave API's getBusInfo, the table `rosnode
// info` prints: one row per connection, with its transport) over the process's own XML-RPC server,
// name a fallback to TCPROS once in the log and keep it in the diagnostics.
//
// A fallback has two causes: the publisher cannot serve UDPROS (rospy; roscpp and `rosbag play`
// can), or another subscription of the same topic in the same process (nodelet manager) asked for
// TCPROS first: roscpp keeps one connection per topic, publisher and process, with the transport
// of the subscription that made it.
#pragma once

#include <ros/network.h>
#include <ros/ros.h>
#include <ros/this_node.h>
#include <ros/xmlrpc_manager.h>
#include <xmlrpcpp/XmlRpcClient.h>

#include <functional>
#include <set>
#include <string>
#include <vector>

#include "networked_estimation/online/sensor_inputs.hpp"

namespace networked_estimation
{

/// roscpp's transport hints of an input: UDPROS first with TCPROS as the fallback (udp), or TCPROS
/// alone (tcp); TCP_NODELAY on the TCPROS connection as `tcp_nodelay` says.
inline ros::TransportHints transportHints(const InputTransport& t)
{
  ros::TransportHints h;
  if (t.transport == Transport::UDP)
    h.unreliable();
  h.reliable().tcpNoDelay(t.tcp_nodelay);
  return h;
}

/// One inbound connection of this process: a row of getBusInfo with direction "i".
struct InboundLink
{
  std::string topic;      ///< resolved name
  std::string publisher;  ///< the publisher's XML-RPC URI
  std::string transport;  ///< TCPROS, UDPROS or INTRAPROCESS
};

/// What an input's connections are, as its diagnostic value says it, and the publishers whose
/// connection fell back to TCPROS while udp was asked for.
struct TransportStatus
{
  std::string text;
  std::vector<std::string> fallbacks;
};

/// The status of an input on `topic` asking for `wanted`, from this process's inbound connections.
inline TransportStatus transportStatus(const InputTransport& wanted, const std::string& topic,
                                       const std::vector<InboundLink>& links)
{
  TransportStatus s;
  if (wanted.transport == Transport::TCP)
  {
    s.text = wanted.tcp_nodelay ? "tcp" : "tcp (tcp_nodelay: false)";
    return s;
  }
  std::size_t udp = 0, local = 0;
  for (const InboundLink& l : links)
  {
    if (l.topic != topic)
      continue;
    if (l.transport == "UDPROS")
      ++udp;
    else if (l.transport == "INTRAPROCESS")
      ++local;
    else
      s.fallbacks.push_back(l.publisher);
  }
  auto publishers = [](std::size_t n) { return std::to_string(n) + (n == 1 ? " publisher" : " publishers"); };
  std::string parts;
  if (udp > 0)
    parts = "UDPROS from " + publishers(udp);
  if (local > 0)
    parts += (parts.empty() ? "" : "; ") + std::string("in-process from ") + publishers(local) + " (no network)";
  if (!s.fallbacks.empty())
  {
    std::string who;
    for (const std::string& p : s.fallbacks)
      who += (who.empty() ? "" : ", ") + p;
    parts += (parts.empty() ? "" : "; ") + std::string("TCPROS fallback from ") + who +
             " (the publisher cannot serve UDPROS, e.g. rospy, or another subscription of " + topic +
             " in this process asked for TCPROS first)";
  }
  s.text = "udp: " + (parts.empty() ? std::string("no publisher connected") : parts);
  return s;
}

/// The inbound connections of this process, asked over its own XML-RPC server (getBusInfo);
/// false with `why` when the call failed.
inline bool inboundLinks(std::vector<InboundLink>& out, std::string& why)
{
  out.clear();
  std::string host;
  uint32_t port = 0;
  const std::string& uri = ros::XMLRPCManager::instance()->getServerURI();
  if (!ros::network::splitURI(uri, host, port))
  {
    why = "cannot parse this process's XML-RPC URI '" + uri + "'";
    return false;
  }
  XmlRpc::XmlRpcClient client(host.c_str(), static_cast<int>(port), "/");
  XmlRpc::XmlRpcValue params, result;
  params[0] = ros::this_node::getName();
  const bool ok = client.execute("getBusInfo", params, result);
  client.close();
  if (!ok || client.isFault() || result.getType() != XmlRpc::XmlRpcValue::TypeArray || result.size() < 3 ||
      result[2].getType() != XmlRpc::XmlRpcValue::TypeArray)
  {
    why = "getBusInfo on " + uri + " failed";
    return false;
  }
  XmlRpc::XmlRpcValue& rows = result[2];
  for (int i = 0; i < rows.size(); ++i)
  {
    XmlRpc::XmlRpcValue& r = rows[i];
    if (r.getType() != XmlRpc::XmlRpcValue::TypeArray || r.size() < 5)
      continue;
    bool strings = true;
    for (int j = 1; j < 5; ++j)
      strings = strings && r[j].getType() == XmlRpc::XmlRpcValue::TypeString;
    if (!strings || static_cast<std::string>(r[2]) != "i")
      continue;
    out.push_back({static_cast<std::string>(r[4]), static_cast<std::string>(r[1]), static_cast<std::string>(r[3])});
  }
  return true;
}

/// The inputs of a nodelet and the transport each got. update() runs on the diagnostics' thread
/// (it calls this process's XML-RPC server, which another thread serves).
class TransportWatch
{
public:
  /// `who` names the input in the log and the diagnostics ("sensor 'gps' (/fix)"), `key` is its
  /// diagnostic key ("gps transport").
  void add(const std::string& who, const std::string& key, const std::string& resolved_topic,
           const InputTransport& wanted, const ros::Subscriber& sub)
  {
    inputs_.push_back({who, key, resolved_topic, wanted, sub, 0, {}, {}});
    inputs_.back().status = transportStatus(wanted, resolved_topic, {});
    any_udp_ = any_udp_ || wanted.transport == Transport::UDP;
  }

  /// Asks the bus info when a udp input's number of publishers changed, or every kRecheckSeconds
  /// (a publisher replaced by another); each new fallback goes to `warn` once.
  void update(const std::function<void(const std::string&)>& warn)
  {
    if (!any_udp_)
      return;
    const ros::WallTime now = ros::WallTime::now();
    bool changed = asked_.isZero() || (now - asked_).toSec() >= kRecheckSeconds;
    for (Input& in : inputs_)
      if (in.wanted.transport == Transport::UDP)
      {
        const uint32_t n = in.sub ? in.sub.getNumPublishers() : 0;
        changed = changed || n != in.publishers;
        in.publishers = n;
      }
    if (!changed)
      return;
    std::vector<InboundLink> links;
    std::string why;
    asked_ = now;
    if (!inboundLinks(links, why))
    {
      if (!failed_)
        warn("cannot tell which transport the udp inputs got: " + why);
      failed_ = true;
      return;
    }
    for (Input& in : inputs_)
    {
      if (in.wanted.transport != Transport::UDP)
        continue;
      in.status = transportStatus(in.wanted, in.topic, links);
      for (const std::string& p : in.status.fallbacks)
        if (in.told.insert(p).second)
          warn(in.who + ": transport udp, but the connection from " + p +
               " is TCPROS: the publisher cannot serve UDPROS (rospy cannot; roscpp and rosbag play can), or "
               "another subscription of " +
               in.topic +
               " in this process asked for TCPROS first (roscpp keeps one "
               "connection per topic and process); its lost packets arrive late instead of not at all");
    }
  }

  /// (key, value) per input, in the order added.
  std::vector<std::pair<std::string, std::string>> values() const
  {
    std::vector<std::pair<std::string, std::string>> out;
    for (const Input& in : inputs_)
      out.emplace_back(in.key, in.status.text);
    return out;
  }

  /// The inputs whose udp fell back to TCPROS, for the status summary ("sensor 'gps' (/fix)").
  std::vector<std::string> fallbacks() const
  {
    std::vector<std::string> out;
    for (const Input& in : inputs_)
      if (!in.status.fallbacks.empty())
        out.push_back(in.who);
    return out;
  }

  static constexpr double kRecheckSeconds = 10.0;

private:
  struct Input
  {
    std::string who, key, topic;
    InputTransport wanted;
    ros::Subscriber sub;
    uint32_t publishers;
    TransportStatus status;
    std::set<std::string> told;  ///< the publishers whose fallback was logged
  };
  std::vector<Input> inputs_;
  bool any_udp_ = false, failed_ = false;
  ros::WallTime asked_;
};

}  // namespace networked_estimation
