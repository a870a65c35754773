// Helpers shared by the graph tests (rostest): message collectors, waiting, diagnostics values.
#pragma once

#include <diagnostic_msgs/DiagnosticArray.h>
#include <nodelet/NodeletList.h>
#include <ros/master.h>
#include <ros/network.h>
#include <ros/ros.h>
#include <xmlrpcpp/XmlRpcClient.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace
{

/// Collects messages of one topic.
template <class M>
struct Collector
{
  std::mutex mutex;
  std::vector<M> msgs;
  std::vector<ros::Time> received_at;
  ros::Subscriber sub;
  Collector(ros::NodeHandle& nh, const std::string& topic)
  {
    sub = nh.subscribe<M>(topic, 100000,
                          [this](const boost::shared_ptr<const M>& m)
                          {
                            std::lock_guard<std::mutex> lock(mutex);
                            msgs.push_back(*m);
                            received_at.push_back(ros::Time::now());
                          });
  }
  std::size_t size()
  {
    std::lock_guard<std::mutex> lock(mutex);
    return msgs.size();
  }
  void clear()
  {
    std::lock_guard<std::mutex> lock(mutex);
    msgs.clear();
    received_at.clear();
  }
};

/// Waits (spinning in the background) until pred() or the timeout.
template <class P>
bool waitFor(P pred, double timeout)
{
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(timeout);
  while (ros::WallTime::now() < end)
  {
    if (pred())
      return true;
    ros::WallDuration(0.005).sleep();
  }
  return pred();
}

/// Whether node `publisher` has taken `subscriber` on for `topic` (resolved names): its getBusInfo
/// lists the outbound connection, so that what it publishes from now on reaches the subscriber.
/// Subscriber::getNumPublishers() counts a publisher as soon as the subscribing process asks it to
/// connect, before the publisher has added the connection, and Publisher::getNumSubscribers()
/// counts this process's own subscriptions too (its /clock under sim time): a message published
/// before the connection is added is lost.
inline bool deliversTo(const std::string& publisher, const std::string& topic, const std::string& subscriber)
{
  XmlRpc::XmlRpcValue lookup, response, uri;
  lookup[0] = ros::this_node::getName();
  lookup[1] = publisher;
  std::string host;
  uint32_t port = 0;
  if (!ros::master::execute("lookupNode", lookup, response, uri, false) ||
      uri.getType() != XmlRpc::XmlRpcValue::TypeString ||
      !ros::network::splitURI(static_cast<std::string>(uri), host, port))
    return false;
  XmlRpc::XmlRpcClient client(host.c_str(), static_cast<int>(port), "/");
  XmlRpc::XmlRpcValue ask, info;
  ask[0] = ros::this_node::getName();
  const bool ok = client.execute("getBusInfo", ask, info);
  client.close();
  if (!ok || info.getType() != XmlRpc::XmlRpcValue::TypeArray || info.size() < 3)
    return false;
  XmlRpc::XmlRpcValue& rows = info[2];  // [id, destination, direction, transport, topic, ...]
  for (int i = 0; i < rows.size(); ++i)
    if (rows[i].size() >= 5 && static_cast<std::string>(rows[i][2]) == "o" &&
        static_cast<std::string>(rows[i][4]) == topic && static_cast<std::string>(rows[i][1]) == subscriber)
      return true;
  return false;
}

/// Whether every publisher of `sub`'s topic (at least one) delivers to this process (deliversTo).
inline bool publishersDeliverHere(const ros::Subscriber& sub)
{
  XmlRpc::XmlRpcValue request, response, state;
  request[0] = ros::this_node::getName();
  if (!ros::master::execute("getSystemState", request, response, state, false) ||
      state.getType() != XmlRpc::XmlRpcValue::TypeArray || state.size() < 1)
    return false;
  std::vector<std::string> nodes;
  XmlRpc::XmlRpcValue& publishers = state[0];  // [[topic, [node, ...]], ...]
  for (int i = 0; i < publishers.size(); ++i)
    if (publishers[i].size() == 2 && static_cast<std::string>(publishers[i][0]) == sub.getTopic())
      for (int j = 0; j < publishers[i][1].size(); ++j)
        nodes.push_back(static_cast<std::string>(publishers[i][1][j]));
  for (const std::string& node : nodes)
    if (!deliversTo(node, sub.getTopic(), ros::this_node::getName()))
      return false;
  return !nodes.empty();
}

/// Calls f(k) for k = 1, 2, ... every `period` seconds of wall time on a thread of its own, until
/// destroyed (the destructor stops and joins it).
class PeriodicFeeder
{
public:
  template <class F>
  PeriodicFeeder(double period, F f)
    : thread_(
          [this, period, f]() mutable
          {
            ros::WallTime next = ros::WallTime::now();
            for (long k = 1; !stop_; ++k)
            {
              f(k);
              next += ros::WallDuration(period);
              const ros::WallDuration wait = next - ros::WallTime::now();
              if (wait > ros::WallDuration(0))
                wait.sleep();
            }
          })
  {
  }
  ~PeriodicFeeder()
  {
    stop_ = true;
    thread_.join();
  }
  PeriodicFeeder(const PeriodicFeeder&) = delete;
  PeriodicFeeder& operator=(const PeriodicFeeder&) = delete;

private:
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

/// The nodelets a manager has loaded (its `list` service), or nothing when it does not answer.
inline std::vector<std::string> loadedNodelets(const std::string& manager)
{
  nodelet::NodeletList srv;
  if (!ros::service::waitForService(manager + "/list", ros::Duration(10.0)) ||
      !ros::service::call(manager + "/list", srv))
    return {};
  return srv.response.nodelets;
}

inline bool isLoaded(const std::vector<std::string>& nodelets, const std::string& name)
{
  return std::find(nodelets.begin(), nodelets.end(), name) != nodelets.end();
}

/// Value of key in the latest diagnostics status whose name contains `name`.
/// Also the status's level (-1 before the first) and message.
struct DiagnosticsProbe
{
  std::mutex mutex;
  std::map<std::string, std::string> values;
  int level = -1;
  std::string message;
  ros::Subscriber sub;
  explicit DiagnosticsProbe(ros::NodeHandle& nh, const std::string& name)
  {
    sub =
        nh.subscribe<diagnostic_msgs::DiagnosticArray>("/diagnostics", 100,
                                                       [this, name](const diagnostic_msgs::DiagnosticArray::ConstPtr& a)
                                                       {
                                                         for (const auto& s : a->status)
                                                           if (s.name.find(name) != std::string::npos)
                                                           {
                                                             std::lock_guard<std::mutex> lock(mutex);
                                                             level = s.level;
                                                             message = s.message;
                                                             for (const auto& kv : s.values)
                                                               values[kv.key] = kv.value;
                                                           }
                                                       });
  }
  double get(const std::string& key)
  {
    std::lock_guard<std::mutex> lock(mutex);
    auto it = values.find(key);
    return it == values.end() ? std::nan("") : std::stod(it->second);
  }
  std::string text(const std::string& key)
  {
    std::lock_guard<std::mutex> lock(mutex);
    auto it = values.find(key);
    return it == values.end() ? std::string() : it->second;
  }
  /// Every key-value of the latest status, read at once (get() calls may straddle two statuses).
  std::map<std::string, std::string> snapshot()
  {
    std::lock_guard<std::mutex> lock(mutex);
    return values;
  }
  bool levelIs(int want)
  {
    std::lock_guard<std::mutex> lock(mutex);
    return level == want;
  }
  std::string lastMessage()
  {
    std::lock_guard<std::mutex> lock(mutex);
    return message;
  }
};

}  // namespace
