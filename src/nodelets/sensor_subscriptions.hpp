// Subscriptions of the Estimator's inputs of every type (sensor_inputs.hpp), sensors' and the
// command's: each message's selected fields (the package's own Measurement and ControlInput: its
// values whole, with its step) go to `ok` with the message's stamp and the ROS time roscpp received
// it at (its receipt time: what decides whether it came before its step's deadline, however long it
// then waited in a queue), or a reason to `bad`.
#pragma once

#include <ros/ros.h>

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "input_message_types.hpp"
#include "frame_transforms.hpp"
#include "gnss_alignment.hpp"
#include "input_preprocessing.hpp"
#include "networked_estimation/online/sensor_sample.hpp"
#include "sensor_adapters.hpp"
#include "transport_watch.hpp"

namespace networked_estimation
{

struct SensorSink
{
  /// A valid message, received at `receipt`: its stamp, its fields (y), and (covariance: message)
  /// their R_k block, or null for the model's R. The sample does not know its sensor (index 0), and
  /// its values live only during the call.
  std::function<void(const ros::Time& receipt, const SensorSample& s)> ok;
  /// The model's name of the sensor fed (a Measurement naming another one goes to `bad`); empty
  /// for the command.
  std::string sensor;
  std::function<void(const std::string& why)> bad;
  /// covariance: message, and the message said it has none: the model's R is used (counted).
  std::function<void(const std::string& why)> fallback;
  /// The message has no estimate of a selected field (sensor_msgs/Imu: a covariance block whose
  /// element 0 is -1): nothing of it is fused, the sensor is not due at its step (not a loss).
  std::function<void(const ros::Time& stamp, const ros::Time& receipt, const std::string& why)> disabled;
  /// NavSatFix only: a fix became the datum.
  std::function<void(const LocalEnu& datum)> datum;
  /// NavSatFix with gnss_alignment: navsat_transform: the fix's ENU antenna position and ENU
  /// covariance (row-major) in place into base_link's world position and world covariance
  /// (GnssAligner::apply); NOT_YET goes to `disabled`. Empty: ENU about the datum is world_frame.
  std::function<GnssStep(const sensor_msgs::NavSatFix& m, const LocalEnu& datum, Eigen::Vector3d& local,
                         boost::array<double, 9>& cov, std::string& why)>
      gnss;
  /// The model's frames and the tf2 lookup (frame_transforms.hpp); no lookup: frames are not used.
  Frames frames;
};

template <class M>
ros::Time stampOf(const M& m, const ros::Time&)
{
  return m.header.stamp;
}
/// std_msgs/Float64, Float64MultiArray and geometry_msgs/Twist have no header: they are stamped by
/// their arrival.
inline ros::Time stampOf(const std_msgs::Float64&, const ros::Time& receipt)
{
  return receipt;
}
inline ros::Time stampOf(const std_msgs::Float64MultiArray&, const ros::Time& receipt)
{
  return receipt;
}
inline ros::Time stampOf(const geometry_msgs::Twist&, const ros::Time& receipt)
{
  return receipt;
}

/// A subscription whose callback gets the message event (publisher, receipt time), on the node
/// handle's callback queue, over the input's transport (transportHints). (A callback taking a
/// MessageEvent passed to subscribe() directly would be wrapped as a plain message callback, losing
/// both.)
template <class M, class F>
ros::Subscriber subscribeEvents(ros::NodeHandle& nh, const std::string& topic, uint32_t queue, F f,
                                const InputTransport& transport)
{
  ros::SubscribeOptions o;
  o.initByFullCallbackType<const ros::MessageEvent<M const>&>(topic, queue, f);
  o.transport_hints = transportHints(transport);
  return nh.subscribe(o);
}

/// The fields of a message's view (and their covariance with covariance: message) to the sink.
inline void deliver(const SensorInput& in, const MessageView& v, const ros::Time& stamp, const ros::Time& receipt,
                    const SensorSink& sink)
{
  const std::size_t n = in.fields.size();
  std::vector<double> y(n), R(n * n);
  std::string why;
  if (disabledBlock(in.type, v, in.fields, why))
  {
    if (sink.disabled)
      sink.disabled(stamp, receipt, why);
    else
      sink.bad(why);
    return;
  }
  if (!readFields(v, in.fields, y.data(), why))
  {
    sink.bad(why);
    return;
  }
  const double* own = nullptr;
  if (in.message_covariance)
    switch (readCovariance(in.type, v, in.fields, R.data(), why))
    {
      case CovarianceRead::OK:
        own = R.data();
        break;
      case CovarianceRead::FALLBACK:
        if (sink.fallback)
          sink.fallback(why);
        break;
      case CovarianceRead::BAD:
      case CovarianceRead::DISABLED:  // caught by disabledBlock above
        sink.bad(why);
        return;
    }
  SensorSample s;
  s.y = y.data();
  s.size = n;
  s.R = own;
  s.stamp = stamp.toSec();
  sink.ok(receipt, s);
}

template <class M>
ros::Subscriber subscribeFields(ros::NodeHandle& nh, const SensorInput& in, uint32_t queue, const SensorSink& sink)
{
  auto memory = std::make_shared<InputMemory>();
  return subscribeEvents<M>(
      nh, in.topic, queue,
      [in, sink, memory](const ros::MessageEvent<M const>& e)
      {
        std::string why;
        M local = *e.getConstMessage();  // into the model's frames, then relative / without gravity
        if (!intoFrames(sink.frames, local, why) || !preprocess(in, *memory, local, why))
        {
          sink.bad(why);
          return;
        }
        const ros::Time stamp = stampOf(local, e.getReceiptTime());
        MessageView v = view(local);
        if (in.differential)
          switch (differentiate(*memory, poseOf(local), stamp.toSec(), v, why))
          {
            case Differential::OK:
              break;
            case Differential::FIRST:  // not a loss: nothing was due yet
              if (sink.disabled)
                sink.disabled(stamp, e.getReceiptTime(), why);
              return;
            case Differential::BAD:
              sink.bad(why);
              return;
          }
        deliver(in, v, stamp, e.getReceiptTime(), sink);
      },
      in.transport);
}

inline ros::Subscriber subscribeNavSatFix(ros::NodeHandle& nh, const SensorInput& in, uint32_t queue,
                                          const SensorSink& sink, const std::vector<double>& datum)
{
  auto enu = std::make_shared<NavSatFixEnu>(datum);
  return subscribeEvents<sensor_msgs::NavSatFix>(
      nh, in.topic, queue,
      [in, sink, enu](const ros::MessageEvent<sensor_msgs::NavSatFix const>& e)
      {
        const sensor_msgs::NavSatFix::ConstPtr m = e.getConstMessage();
        Eigen::Vector3d local;
        std::string why;
        bool new_datum = false;
        if (!enu->convert(*m, local, why, new_datum))
        {
          sink.bad(why);
          return;
        }
        if (new_datum && sink.datum)
          sink.datum(*enu->datum());
        boost::array<double, 9> cov = m->position_covariance;  // ENU already (sensor_msgs/NavSatFix)
        if (sink.gnss)
          switch (sink.gnss(*m, *enu->datum(), local, cov, why))
          {
            case GnssStep::OK:
              break;
            case GnssStep::NOT_YET:
              if (sink.disabled)
                sink.disabled(m->header.stamp, e.getReceiptTime(), why);
              return;
            case GnssStep::BAD:
              sink.bad(why);
              return;
          }
        MessageView v;
        v.enu = &local;
        v.enu_cov = cov.data();
        v.enu_cov_type = m->position_covariance_type;
        deliver(in, v, m->header.stamp, e.getReceiptTime(), sink);
      },
      in.transport);
}

/// Measurement and ControlInput: the values whole, with their step (wholeSample); no copy of the
/// message, no frames (they have none).
template <class M>
ros::Subscriber subscribeWhole(ros::NodeHandle& nh, const SensorInput& in, uint32_t queue, const SensorSink& sink)
{
  return subscribeEvents<M>(
      nh, in.topic, queue,
      [sink](const ros::MessageEvent<M const>& e)
      {
        SensorSample s;
        std::string why;
        if (wholeSample(*e.getConstMessage(), sink.sensor, s, why))
          sink.ok(e.getReceiptTime(), s);
        else
          sink.bad(why);
      },
      in.transport);
}

/// The subscription of an input of any type (a sensor's or the command's).
inline ros::Subscriber subscribeSensor(ros::NodeHandle& nh, const SensorInput& in, uint32_t queue,
                                       const SensorSink& sink, const std::vector<double>& datum)
{
  return withInputMessage(in.type,
                          [&](auto tag)
                          {
                            using M = MessageOf<decltype(tag)>;
                            if constexpr (kWholeVector<M>)
                              return subscribeWhole<M>(nh, in, queue, sink);
                            else if constexpr (std::is_same<M, sensor_msgs::NavSatFix>::value)
                              return subscribeNavSatFix(nh, in, queue, sink, datum);
                            else
                              return subscribeFields<M>(nh, in, queue, sink);
                          });
}

}  // namespace networked_estimation
