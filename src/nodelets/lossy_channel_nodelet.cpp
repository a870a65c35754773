// LossyChannel nodelet: forwards any message type from `in` to `out` through the core LossyChannel
// engine (loss, delay, jitter, reordering, duplication, queue limit), publishes the ground truth of
// every message on ~events and its health on /diagnostics.
//
// Zero-copy: the message object received is the one published (ShapeShifter keeps the serialized
// bytes; nothing is re-serialised by the channel). `in` is served by the channel's own thread
// (dispatch_thread.hpp: one thread hand-off per message instead of the manager's two): deliveries
// due immediately are published from the subscriber callback, later ones from the same thread when
// its wait for the next message ends at their due time (in ROS time, so delays hold under
// /use_sim_time).
#include <diagnostic_updater/diagnostic_updater.h>
#include <dynamic_reconfigure/server.h>
#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>
#include <ros/ros.h>
#include <topic_tools/shape_shifter.h>

#include <atomic>
#include <functional>
#include <limits>
#include <mutex>
#include <sstream>

#include "networked_estimation/channel/channel.hpp"
#include "networked_estimation/channel/channel_deliveries.hpp"
#include "networked_estimation/common/error.hpp"
#include "networked_estimation/stability/link_monitor.hpp"
#include "networked_estimation/ChannelEvent.h"
#include "networked_estimation/LossyChannelConfig.h"
#include "networked_estimation/SetParameters.h"
#include "load_failure.hpp"
#include "param_yaml.hpp"
#include "dispatch_thread.hpp"
#include "channel_message_types.hpp"
#include "channel_reports.hpp"
#include "lossy_channel_config.hpp"
#include "transport_watch.hpp"
#include "networked_estimation/config/param_reader.hpp"

namespace networked_estimation
{

using namespace channel_types;

class LossyChannelNodelet : public nodelet::Nodelet
{
public:
  ~LossyChannelNodelet() override
  {
    dispatch_.stop();
    sub_.shutdown();  // while its queue exists
  }

private:
  void onInit() override
  {
    ros::NodeHandle& nh = getNodeHandle();
    ros::NodeHandle& pnh = getPrivateNodeHandle();
    const std::string source = pnh.getNamespace() + " parameters";
    try
    {
      settings_ = parseChannelSettings(privateParameters(pnh, {"diagnostic_period", "queue_size", "type", "reconfigure",
                                                               "transport", "tcp_nodelay"}),
                                       source);
      ParamReader transport_keys(privateParameters(pnh), source);  // ~transport, ~tcp_nodelay of `in`
      transport_ = parseInputTransport(transport_keys, source + ": ");
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
    deliveries_ = std::make_unique<ChannelDeliveries<boost::shared_ptr<const void>>>(*channel_);
    t0_ = ros::Time::now();
    events_pub_ = pnh.advertise<ChannelEvent>("events", 1000);
    set_srv_ = pnh.advertiseService("set_parameters", &LossyChannelNodelet::setParameters, this);
    startReconfigure(pnh);
    diagnostics_ = std::make_unique<diagnostic_updater::Updater>(nh, pnh, getName());
    diagnostics_->setHardwareID("lossy_channel");
    diagnostics_->add("channel", this, &LossyChannelNodelet::diagnose);
    diag_timer_ =
        nh.createWallTimer(ros::WallDuration(0.5), [this](const ros::WallTimerEvent&) { diagnostics_->update(); });
    // `in` is served by the channel's own thread, which also publishes the delayed deliveries.
    dispatch_.start([this] { return deliveryWork(); });
    const auto q = static_cast<uint32_t>(queue_size_);
    if (type_.empty())  // any type: ShapeShifter, `out` advertised with the first message's type
    {
      publish_ = [this](const boost::shared_ptr<const void>& m)
      { out_pub_.publish(boost::static_pointer_cast<const topic_tools::ShapeShifter>(m)); };
      ros::SubscribeOptions o;
      o.template initByFullCallbackType<const ros::MessageEvent<topic_tools::ShapeShifter const>&>(
          "in", q, [this](const ros::MessageEvent<topic_tools::ShapeShifter const>& e) { onMessage(e); });
      subscribeIn(nh, o, dispatch_.queue());  // not direct: onMessage advertises `out` (roscpp's publication lock)
    }
    else  // ~type: typed in and out, the received object forwarded as it is (no serialization in-process)
    {
      const bool known = withKnownType(type_,
                                       [&](auto tag)
                                       {
                                         using M = typename decltype(tag)::type;
                                         out_pub_ = nh.advertise<M>("out", q);
                                         publish_ = [this](const boost::shared_ptr<const void>& m)
                                         { out_pub_.publish(boost::static_pointer_cast<const M>(m)); };
                                         ros::SubscribeOptions o;
                                         o.template init<M>("in", q,
                                                            [this](const boost::shared_ptr<const M>& m)
                                                            { onInput(m, [&m] { return stampOf(*m); }); });
                                         subscribeIn(nh, o, dispatch_.directQueue());
                                       });
      if (!known)
        refuseLoad(getName(), "LossyChannel not started: " + source + ": type: expected one of " +
                                  std::string(kKnownTypes) + ", found '" + type_ + "'");
      advertised_ = true;
    }
    NODELET_INFO("LossyChannel %s -> %s: %s", nh.resolveName("in").c_str(), nh.resolveName("out").c_str(),
                 describe().c_str());
  }

  double now() const { return (ros::Time::now() - t0_).toSec(); }

  /// `in` on `queue`: the dispatch thread's, or (~type) its DirectQueue, where in-process
  /// publishers' messages are handled in their thread (callbacks may then run concurrently: mutex_
  /// serializes the engine). Over ~transport (tcp, or udp with the TCPROS fallback, which is said
  /// once in the log and shown by the "input transport" diagnostic: transport_watch.hpp).
  void subscribeIn(ros::NodeHandle& nh, ros::SubscribeOptions& o, ros::CallbackQueueInterface* queue)
  {
    o.callback_queue = queue;
    o.allow_concurrent_callbacks = true;
    o.transport_hints = transportHints(transport_);
    sub_ = nh.subscribe(o);
    const std::string in = nh.resolveName("in");
    transports_.add("LossyChannel input (" + in + ")", "transport", in, transport_, sub_);
    diagnostics_->add("input transport",
                      [this](diagnostic_updater::DiagnosticStatusWrapper& stat)
                      {
                        transports_.update([this](const std::string& w) { NODELET_WARN("%s", w.c_str()); });
                        const std::vector<std::string> fallbacks = transports_.fallbacks();
                        if (fallbacks.empty())
                          stat.summary(diagnostic_msgs::DiagnosticStatus::OK, transports_.values().front().second);
                        else
                          stat.summary(diagnostic_msgs::DiagnosticStatus::WARN,
                                       fallbacks.front() + ": udp fell back to TCPROS");
                        for (const auto& kv : transports_.values())
                          stat.add(kv.first, kv.second);
                      });
  }

  std::string describe() const
  {
    YAML::Emitter e;
    e << YAML::Flow << toYaml(settings_);
    return e.c_str();
  }

  /// Any type (no ~type): `out` is advertised with the type and latching of the first message.
  void onMessage(const ros::MessageEvent<topic_tools::ShapeShifter const>& event)
  {
    const topic_tools::ShapeShifter::ConstPtr& msg = event.getConstMessage();
    {
      std::lock_guard<std::mutex> lock(mutex_);
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
    }
    onInput(msg, [this, &msg] { return inputStamp(*msg, has_header_); });
  }

  /// One message on `in` through the engine; `stamp` gives its header.stamp (for ~events).
  template <class Stamp>
  void onInput(const boost::shared_ptr<const void>& msg, const Stamp& stamp)
  {
    const double t = now();
    std::unique_lock<std::mutex> lock(mutex_);
    const ChannelRecord rec = deliveries_->offer(t, msg);
    monitor_.add(rec.outcome == ChannelOutcome::DELIVERED);
    deliveries_->popDue(t, outbox_);
    // Called in a publisher's thread (DirectQueue), nothing else wakes the dispatch thread: tell it
    // when the next delivery is due before the time it waits for.
    const bool wake = !dispatch_.inThisThread() && channel_->nextDue() < armed_due_;
    lock.unlock();
    if (wake)
      dispatch_.wake();
    flush();
    if (events_pub_.getNumSubscribers() > 0)  // the event (and its stamp) only when wanted
      events_pub_.publish(channelEventMessage(rec, t0_, stamp()));
  }

  /// Publishes the outbox in order, without holding mutex_ (`in` is a DirectQueue: an in-process
  /// publisher's thread runs onInput inside roscpp's publish, holding roscpp's publication lock, and
  /// takes mutex_; a thread holding mutex_ while it publishes would deadlock with it). One thread
  /// publishes at a time; a thread that finds another publishing leaves its messages to it.
  void flush()
  {
    for (;;)
    {
      std::unique_lock<std::mutex> publishing(publishing_, std::try_to_lock);
      if (!publishing.owns_lock())
        return;
      for (;;)
      {
        {
          std::lock_guard<std::mutex> lock(mutex_);
          sending_.swap(outbox_);
        }
        if (sending_.empty())
          break;
        for (const auto& m : sending_)
          publish_(m);
        sending_.clear();
      }
      publishing.unlock();
      std::lock_guard<std::mutex> lock(mutex_);  // pushed after our last look, while we held publishing_?
      if (outbox_.empty())
        return;
    }
  }

  /// Publishes the deliveries that are due; returns the wall seconds until the next one (the
  /// dispatch thread's wait; it runs on that thread, after every message too).
  double deliveryWork()
  {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      const double due = channel_->nextDue();
      armed_due_ = due;  // what the wait below is for (onInput wakes the thread for an earlier one)
      if (due == std::numeric_limits<double>::infinity())
        return due;
      const double wait = due - now();
      if (wait > 0.0)  // wall-clock wait; under sim time the clock may run at another rate: re-check often
        return ros::Time::isSimTime() ? std::min(wait, 0.0005) : wait;
      armed_due_ = -std::numeric_limits<double>::infinity();  // runs again at once
      deliveries_->popDue(now(), outbox_);
    }
    flush();
    return 0.0;
  }

  /// dynamic_reconfigure in ~reconfigure (its values are written back as parameters there, not
  /// as the nodelet's own). Starts from the settings in use; a change is validated as a whole as
  /// ~set_parameters does, and a refused one is undone in the config too.
  void startReconfigure(ros::NodeHandle& pnh)
  {
    reconfigure_ = std::make_unique<dynamic_reconfigure::Server<LossyChannelConfig>>(
        reconfigure_mutex_, ros::NodeHandle(pnh, "reconfigure"));
    reconfigure_->setCallback(
        [this](LossyChannelConfig& c, uint32_t)
        {
          if (!reconfigure_ready_)
            return;
          std::lock_guard<std::mutex> lock(mutex_);
          try
          {
            const ChannelSettings next =
                mergeChannelSettings(settings_, toChanges(c), getPrivateNodeHandle().getNamespace() + "/reconfigure");
            channel_->reconfigure(next);
            settings_ = next;
            NODELET_INFO("LossyChannel reconfigured: %s", describe().c_str());
            dispatch_.wake();
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
      LossyChannelConfig config;
      {
        std::lock_guard<std::mutex> lock(mutex_);
        const ChannelSettings next = mergeChannelSettings(settings_, YAML::Load(req.yaml),
                                                          getPrivateNodeHandle().getNamespace() + "/set_parameters");
        channel_->reconfigure(next);
        settings_ = next;
        config = toConfig(settings_);
        res.message = describe();
      }
      if (reconfigure_)  // publishes: not with mutex_ held (flush)
        reconfigure_->updateConfig(config);
      res.success = true;
      NODELET_INFO("LossyChannel reconfigured: %s", res.message.c_str());
      dispatch_.wake();
    }
    catch (const std::exception& e)  // ConfigError, or a YAML syntax error in the request
    {
      res.success = false;
      res.message = e.what();
      NODELET_WARN("LossyChannel: rejected set_parameters: %s", e.what());
    }
    return true;
  }

  /// With ~type: "<in> is <type>, expected <~type>" when the master has `in` with another type
  /// (roscpp then connects nothing: without this check the link would just look silent); "" if not.
  std::string wrongType() const
  {
    ros::master::V_TopicInfo topics;
    if (type_.empty() || !ros::master::getTopics(topics))
      return "";
    const std::string in = const_cast<LossyChannelNodelet*>(this)->getNodeHandle().resolveName("in");
    for (const ros::master::TopicInfo& t : topics)
      if (t.name == in && t.datatype != type_)
        return in + " is " + t.datatype + ", expected " + type_ + " (~type)";
    return "";
  }

  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat)
  {
    const std::string wrong = wrongType();  // asks the master: outside the lock
    if (!wrong.empty())
      NODELET_WARN_THROTTLE(10.0, "LossyChannel: wrong message type on `in`: %s", wrong.c_str());
    std::lock_guard<std::mutex> lock(mutex_);
    addChannelStatus(stat, *channel_, monitor_, wrong);
    stat.add("settings", describe());
  }

  ChannelSettings settings_;
  std::unique_ptr<LossyChannel> channel_;
  /// The messages in flight: a ShapeShifter, or the ~type message class (mutex_).
  std::unique_ptr<ChannelDeliveries<boost::shared_ptr<const void>>> deliveries_;
  int queue_size_ = 1000;
  std::string type_;
  /// Publishes a held message on `out` (its class: ShapeShifter, or ~type's).
  std::function<void(const boost::shared_ptr<const void>&)> publish_;
  LinkMonitor monitor_{1000};
  ros::Time t0_;
  DispatchThread dispatch_;  ///< serves `in` and the delayed deliveries (before sub_: outlives it)
  ros::Subscriber sub_;
  InputTransport transport_;   ///< ~transport, ~tcp_nodelay of `in`
  TransportWatch transports_;  ///< the transport `in` got (the diagnostics' thread)
  ros::Publisher out_pub_, events_pub_;
  ros::ServiceServer set_srv_;
  std::unique_ptr<diagnostic_updater::Updater> diagnostics_;
  ros::WallTimer diag_timer_;
  boost::recursive_mutex reconfigure_mutex_;
  std::unique_ptr<dynamic_reconfigure::Server<LossyChannelConfig>> reconfigure_;
  bool reconfigure_ready_ = false;
  std::mutex mutex_;
  double armed_due_ = std::numeric_limits<double>::infinity();  ///< the dispatch thread waits for it (mutex_)
  std::mutex publishing_;                               ///< held by the one thread that publishes the outbox (flush)
  std::vector<boost::shared_ptr<const void>> outbox_;   ///< due, not yet published (mutex_)
  std::vector<boost::shared_ptr<const void>> sending_;  ///< being published (publishing_)

  bool advertised_ = false;
  bool has_header_ = false;
};

}  // namespace networked_estimation

PLUGINLIB_EXPORT_CLASS(networked_estimation::LossyChannelNodelet, nodelet::Nodelet)
