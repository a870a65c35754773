// LossyChannel nodelet: forwards any message type from `in` to `out` through the core LossyChannel
// engine (loss, delay, jitter, reordering, duplication, queue limit), publishes the ground truth of
// every message on ~events and its health on /diagnostics.
//
// Zero-copy: the message object received is the one published (ShapeShifter keeps the serialized
// bytes; nothing is re-serialised by the channel). Deliveries due immediately are published from
// the subscriber callback; later ones from a delivery thread that sleeps until the next due time
// (in ROS time, so delays hold under /use_sim_time).
#include <diagnostic_updater/diagnostic_updater.h>
#include <dynamic_reconfigure/server.h>
#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>
#include <ros/ros.h>
#include <topic_tools/shape_shifter.h>

#include <atomic>
#include <condition_variable>
#include <limits>
#include <mutex>
#include <sstream>
#include <thread>
#include <unordered_map>

#include "networked_estimation/channel/channel.hpp"
#include "networked_estimation/common/error.hpp"
#include "networked_estimation/stability/link_monitor.hpp"
#include "networked_estimation/ChannelEvent.h"
#include "networked_estimation/ControlInput.h"
#include "networked_estimation/LossyChannelConfig.h"
#include "networked_estimation/Estimate.h"
#include "networked_estimation/Measurement.h"
#include "networked_estimation/PlantState.h"
#include <geometry_msgs/PointStamped.h>
#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <geometry_msgs/Twist.h>
#include <geometry_msgs/TwistStamped.h>
#include <geometry_msgs/TwistWithCovarianceStamped.h>
#include <nav_msgs/Odometry.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/NavSatFix.h>
#include <sensor_msgs/Range.h>
#include <std_msgs/Float64.h>
#include <std_msgs/Float64MultiArray.h>
#include "networked_estimation/SetParameters.h"
#include "load_failure.hpp"
#include "param_yaml.hpp"
#include "worker.hpp"

namespace networked_estimation
{

namespace
{

/// header.stamp of a serialized message whose type starts with a std_msgs/Header
/// (uint32 seq, then time stamp); zero otherwise.
ros::Time inputStamp(const topic_tools::ShapeShifter& msg, bool has_header)
{
  if (!has_header || msg.size() < 12)
    return ros::Time();
  std::vector<uint8_t> buf(msg.size());
  ros::serialization::OStream out(buf.data(), static_cast<uint32_t>(buf.size()));
  msg.write(out);
  uint32_t sec, nsec;
  std::memcpy(&sec, buf.data() + 4, 4);
  std::memcpy(&nsec, buf.data() + 8, 4);
  return ros::Time(sec, nsec);
}

/// Whether the first field of a message definition (after comments and blank lines) is a Header.
bool startsWithHeader(const std::string& definition)
{
  std::istringstream in(definition);
  std::string line;
  while (std::getline(in, line))
  {
    const auto first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#')
      continue;
    return line.compare(first, 14, "Header header ") == 0 || line.compare(first, 13, "Header header") == 0 ||
           line.compare(first, 22, "std_msgs/Header header") == 0;
  }
  return false;
}

/// `out` advertised before the first message for the types named by ~type (so that subscribers
/// connect before the stream starts). Returns false for a type not in this list.
bool advertiseKnown(ros::NodeHandle& nh, const std::string& type, uint32_t queue, ros::Publisher& pub)
{
  if (type == "networked_estimation/Measurement")
    pub = nh.advertise<Measurement>("out", queue);
  else if (type == "networked_estimation/ControlInput")
    pub = nh.advertise<ControlInput>("out", queue);
  else if (type == "networked_estimation/PlantState")
    pub = nh.advertise<PlantState>("out", queue);
  else if (type == "networked_estimation/Estimate")
    pub = nh.advertise<Estimate>("out", queue);
  else if (type == "sensor_msgs/Range")
    pub = nh.advertise<sensor_msgs::Range>("out", queue);
  else if (type == "sensor_msgs/Imu")
    pub = nh.advertise<sensor_msgs::Imu>("out", queue);
  else if (type == "geometry_msgs/PointStamped")
    pub = nh.advertise<geometry_msgs::PointStamped>("out", queue);
  else if (type == "geometry_msgs/PoseStamped")
    pub = nh.advertise<geometry_msgs::PoseStamped>("out", queue);
  else if (type == "geometry_msgs/PoseWithCovarianceStamped")
    pub = nh.advertise<geometry_msgs::PoseWithCovarianceStamped>("out", queue);
  else if (type == "geometry_msgs/TwistStamped")
    pub = nh.advertise<geometry_msgs::TwistStamped>("out", queue);
  else if (type == "geometry_msgs/TwistWithCovarianceStamped")
    pub = nh.advertise<geometry_msgs::TwistWithCovarianceStamped>("out", queue);
  else if (type == "geometry_msgs/Twist")
    pub = nh.advertise<geometry_msgs::Twist>("out", queue);
  else if (type == "nav_msgs/Odometry")
    pub = nh.advertise<nav_msgs::Odometry>("out", queue);
  else if (type == "sensor_msgs/NavSatFix")
    pub = nh.advertise<sensor_msgs::NavSatFix>("out", queue);
  else if (type == "std_msgs/Float64")
    pub = nh.advertise<std_msgs::Float64>("out", queue);
  else if (type == "std_msgs/Float64MultiArray")
    pub = nh.advertise<std_msgs::Float64MultiArray>("out", queue);
  else
    return false;
  return true;
}

const char* kKnownTypes =
    "networked_estimation/{Measurement, ControlInput, PlantState, Estimate}, nav_msgs/Odometry, "
    "sensor_msgs/{Range, Imu, NavSatFix}, geometry_msgs/{PointStamped, PoseStamped, PoseWithCovarianceStamped, "
    "TwistStamped, TwistWithCovarianceStamped, Twist}, std_msgs/{Float64, Float64MultiArray}";

}  // namespace

class LossyChannelNodelet : public nodelet::Nodelet
{
public:
  ~LossyChannelNodelet() override { stopWorker(mutex_, stop_, wake_, thread_); }

private:
  void onInit() override
  {
    ros::NodeHandle& nh = getNodeHandle();
    ros::NodeHandle& pnh = getPrivateNodeHandle();
    const std::string source = pnh.getNamespace() + " parameters";
    try
    {
      settings_ = parseChannelSettings(privateParameters(pnh, {"diagnostic_period", "queue_size", "type", "reconfigure"}), source);
      pnh.param("type", type_, std::string());
      if (!type_.empty() && std::string(kKnownTypes).find(type_.substr(type_.find('/') + 1)) == std::string::npos)
        throw ConfigError(source + ": type: expected one of " + std::string(kKnownTypes) +
                          " (or no type: `out` is then advertised with the type of the first message), found '" +
                          type_ + "'");
    }
    catch (const ConfigError& e)
    {
      refuseLoad(getName(), std::string("LossyChannel not started, nothing will be forwarded: ") + e.what());
    }
    pnh.param("queue_size", queue_size_, 1000);
    channel_ = std::make_unique<LossyChannel>(settings_);
    if (!type_.empty())
    {
      if (!advertiseKnown(nh, type_, static_cast<uint32_t>(queue_size_), out_pub_))
      {
        refuseLoad(getName(), "LossyChannel not started: " + source + ": type: expected one of " +
                                  std::string(kKnownTypes) + ", found '" + type_ + "'");
      }
      advertised_ = true;
      has_header_ = true;  // every listed type starts with a Header
    }
    t0_ = ros::Time::now();
    events_pub_ = pnh.advertise<ChannelEvent>("events", 1000);
    set_srv_ = pnh.advertiseService("set_parameters", &LossyChannelNodelet::setParameters, this);
    startReconfigure(pnh);
    diagnostics_ = std::make_unique<diagnostic_updater::Updater>(nh, pnh, getName());
    diagnostics_->setHardwareID("lossy_channel");
    diagnostics_->add("channel", this, &LossyChannelNodelet::diagnose);
    diag_timer_ = nh.createWallTimer(ros::WallDuration(0.5), [this](const ros::WallTimerEvent&) { diagnostics_->update(); });
    thread_ = std::thread(&LossyChannelNodelet::deliveryLoop, this);
    sub_ = nh.subscribe("in", static_cast<uint32_t>(queue_size_),
                                                   &LossyChannelNodelet::onMessage, this,
                                                   ros::TransportHints().tcpNoDelay());
    NODELET_INFO("LossyChannel %s -> %s: %s", nh.resolveName("in").c_str(), nh.resolveName("out").c_str(),
                 describe().c_str());
  }

  double now() const { return (ros::Time::now() - t0_).toSec(); }

  std::string describe() const
  {
    YAML::Emitter e;
    e << YAML::Flow << toYaml(settings_);
    return e.c_str();
  }

  void onMessage(const ros::MessageEvent<topic_tools::ShapeShifter const>& event)
  {
    const topic_tools::ShapeShifter::ConstPtr& msg = event.getConstMessage();
    const double t = now();
    if (!type_.empty() && msg->getDataType() != type_)
    {
      ++wrong_type_;
      NODELET_WARN_THROTTLE(1.0, "LossyChannel: dropped a %s message: `out` carries %s (~type); %lu so far",
                            msg->getDataType().c_str(), type_.c_str(), static_cast<unsigned long>(wrong_type_.load()));
      return;
    }
    std::unique_lock<std::mutex> lock(mutex_);
    if (!advertised_)
    {
      ros::NodeHandle& nh = getNodeHandle();
      const auto& header = event.getConnectionHeader();
      const auto latch = header.find("latching");
      out_pub_ = msg->advertise(nh, "out", static_cast<uint32_t>(queue_size_),
                                latch != header.end() && latch->second == "1");
      has_header_ = startsWithHeader(msg->getMessageDefinition());
      advertised_ = true;
    }
    const std::uint64_t seq = next_seq_++;
    const ChannelRecord rec = channel_->offer(seq, t);
    monitor_.add(rec.outcome == ChannelOutcome::DELIVERED);
    if (rec.outcome == ChannelOutcome::DELIVERED)
      in_flight_[seq] = {msg, rec.duplicated ? 2 : 1};
    publishDue(t);
    const bool wake = channel_->nextDue() < std::numeric_limits<double>::infinity();
    lock.unlock();
    if (events_pub_.getNumSubscribers() > 0)  // the event (and its stamp copy) only when wanted
      events_pub_.publish(toMessage(rec, msg));
    if (wake)
      wake_.notify_one();
  }

  ChannelEvent toMessage(const ChannelRecord& e, const topic_tools::ShapeShifter::ConstPtr& msg)
  {
    ChannelEvent m;
    m.header.stamp = t0_ + ros::Duration(e.arrival);
    m.seq = e.seq;
    m.input_stamp = inputStamp(*msg, has_header_);
    m.outcome = static_cast<uint8_t>(e.outcome);
    m.duplicated = e.duplicated;
    m.state = static_cast<uint8_t>(e.state);
    m.delay = e.delay;
  m.sampled_delay = e.sampled_delay;
    return m;
  }

  /// Publishes every delivery due at t (mutex held: deliveries leave in the engine's order).
  void publishDue(double t)
  {
    channel_->popDue(t, due_);
    for (const Delivery& d : due_)
    {
      auto it = in_flight_.find(d.seq);
      if (it == in_flight_.end())
        continue;
      out_pub_.publish(it->second.msg);
      if (--it->second.remaining == 0)
        in_flight_.erase(it);
    }
  }

  void deliveryLoop()
  {
    std::unique_lock<std::mutex> lock(mutex_);
    while (!stop_)
    {
      const double due = channel_->nextDue();
      if (due == std::numeric_limits<double>::infinity())
      {
        wake_.wait(lock);
        continue;
      }
      const double wait = due - now();
      if (wait > 0.0)
      {
        // Wall-clock wait; under sim time the clock may run at another rate, so re-check often.
        const double cap = ros::Time::isSimTime() ? 0.0005 : wait;
        wake_.wait_for(lock, std::chrono::duration<double>(std::min(wait, cap)));
        continue;
      }
      publishDue(now());
    }
  }

  /// The settings as the dynamic_reconfigure config (the other model's keys at their defaults).
  static LossyChannelConfig toConfig(const ChannelSettings& s)
  {
    LossyChannelConfig c = LossyChannelConfig::__getDefault__();
    const YAML::Node y = toYaml(s);
    c.model = y["model"].as<std::string>();
    for (auto& kv : {std::make_pair("loss", &c.loss), std::make_pair("p", &c.p), std::make_pair("r", &c.r),
                     std::make_pair("loss_bad", &c.loss_bad), std::make_pair("loss_good", &c.loss_good)})
      if (y[kv.first])
        *kv.second = y[kv.first].as<double>();
    c.delay = s.delay;
    c.jitter = s.jitter;
    c.distribution = y["distribution"] ? y["distribution"].as<std::string>() : c.distribution;
    c.reorder = s.reorder;
    c.duplicate = s.duplicate;
    c.queue_limit = static_cast<int>(s.queue_limit);
    return c;
  }

  /// The config's keys that apply to its model, as a YAML map for mergeChannelSettings.
  static YAML::Node toChanges(const LossyChannelConfig& c)
  {
    YAML::Node y(YAML::NodeType::Map);
    y["model"] = c.model;
    if (c.model == "bernoulli")
      y["loss"] = c.loss;
    else
    {
      y["p"] = c.p;
      y["r"] = c.r;
      y["loss_bad"] = c.loss_bad;
      y["loss_good"] = c.loss_good;
    }
    y["delay"] = c.delay;
    y["jitter"] = c.jitter;
    y["distribution"] = c.distribution;
    y["reorder"] = c.reorder;
    y["duplicate"] = c.duplicate;
    y["queue_limit"] = c.queue_limit;
    return y;
  }

  /// dynamic_reconfigure in ~reconfigure (its values are written back as parameters there, not
  /// as the nodelet's own). Starts from the settings in use; a change is validated as a whole as
  /// ~set_parameters does, and a refused one is undone in the config too.
  void startReconfigure(ros::NodeHandle& pnh)
  {
    reconfigure_ = std::make_unique<dynamic_reconfigure::Server<LossyChannelConfig>>(
        reconfigure_mutex_, ros::NodeHandle(pnh, "reconfigure"));
    reconfigure_->setCallback([this](LossyChannelConfig& c, uint32_t) {
      if (!reconfigure_ready_)
        return;
      std::lock_guard<std::mutex> lock(mutex_);
      try
      {
        const ChannelSettings next = mergeChannelSettings(
            settings_, toChanges(c), getPrivateNodeHandle().getNamespace() + "/reconfigure");
        channel_->reconfigure(next);
        settings_ = next;
        NODELET_INFO("LossyChannel reconfigured: %s", describe().c_str());
      }
      catch (const ConfigError& e)
      {
        NODELET_WARN("LossyChannel: rejected reconfigure: %s", e.what());
        c = toConfig(settings_);  // the server publishes what is in use
      }
    });
    reconfigure_ready_ = true;
    reconfigure_->updateConfig(toConfig(settings_));
  }

  bool setParameters(SetParameters::Request& req, SetParameters::Response& res)
  {
    try
    {
      std::lock_guard<std::mutex> lock(mutex_);
      const ChannelSettings next =
          mergeChannelSettings(settings_, YAML::Load(req.yaml), getPrivateNodeHandle().getNamespace() + "/set_parameters");
      channel_->reconfigure(next);
      settings_ = next;
      if (reconfigure_)
        reconfigure_->updateConfig(toConfig(settings_));
      res.success = true;
      res.message = describe();
      NODELET_INFO("LossyChannel reconfigured: %s", res.message.c_str());
    }
    catch (const std::exception& e)  // ConfigError, or a YAML syntax error in the request
    {
      res.success = false;
      res.message = e.what();
      NODELET_WARN("LossyChannel: rejected set_parameters: %s", e.what());
    }
    return true;
  }

  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat)
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const ChannelCounters& c = channel_->counters();
    stat.summaryf(diagnostic_msgs::DiagnosticStatus::OK, "loss %.3f over %lu messages", channel_->lossRate(),
                  static_cast<unsigned long>(c.received));
    if (c.dropped_queue > 0)
      stat.mergeSummary(diagnostic_msgs::DiagnosticStatus::WARN, "queue_limit reached: messages dropped");
    stat.add("received", c.received);
    stat.add("delivered", c.delivered);
    stat.add("dropped by model", c.dropped_model);
    stat.add("dropped by queue", c.dropped_queue);
    stat.add("duplicated", c.duplicated);
    stat.add("in flight", c.in_flight);
    stat.add("empirical loss rate", channel_->lossRate());
    stat.add("mean burst length", channel_->meanBurstLength());
    stat.add("delay p50 (s)", channel_->delayQuantile(0.5));
    stat.add("delay p90 (s)", channel_->delayQuantile(0.9));
    stat.add("delay p99 (s)", channel_->delayQuantile(0.99));
    stat.add("wrong type", wrong_type_.load());
    // Windowed estimates (last 1000 messages, 95 % Wilson intervals) of what the link does now.
    const RateEstimate a = monitor_.arrivalRate(), r = monitor_.recoveryRate();
    stat.addf("windowed arrival rate", "%.4f [%.4f, %.4f] over %zu", a.value, a.lower, a.upper, a.trials);
    stat.addf("windowed recovery rate", "%.4f [%.4f, %.4f] over %zu", r.value, r.lower, r.upper, r.trials);
    stat.add("settings", describe());
  }

  struct Held
  {
    topic_tools::ShapeShifter::ConstPtr msg;
    int remaining;
  };

  ChannelSettings settings_;
  std::unique_ptr<LossyChannel> channel_;
  int queue_size_ = 1000;
  std::string type_;
  std::atomic<std::uint64_t> wrong_type_{0};
  LinkMonitor monitor_{1000};
  ros::Time t0_;
  ros::Subscriber sub_;
  ros::Publisher out_pub_, events_pub_;
  ros::ServiceServer set_srv_;
  std::unique_ptr<diagnostic_updater::Updater> diagnostics_;
  ros::WallTimer diag_timer_;
  boost::recursive_mutex reconfigure_mutex_;
  std::unique_ptr<dynamic_reconfigure::Server<LossyChannelConfig>> reconfigure_;
  bool reconfigure_ready_ = false;
  std::mutex mutex_;
  std::condition_variable wake_;
  std::thread thread_;
  bool stop_ = false;
  bool advertised_ = false;
  bool has_header_ = false;
  std::uint64_t next_seq_ = 0;
  std::unordered_map<std::uint64_t, Held> in_flight_;
  std::vector<Delivery> due_;
};

}  // namespace networked_estimation

PLUGINLIB_EXPORT_CLASS(networked_estimation::LossyChannelNodelet, nodelet::Nodelet)
