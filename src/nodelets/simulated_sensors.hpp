// The PlantSimulator's sensors, an owned part of the nodelet (plant_simulator_nodelet.cpp): each
// sensor's y_k published as its configured message type (input_message_types.hpp) with R in the
// message's covariance, or as networked_estimation/Measurement.
#pragma once

#include <ros/ros.h>

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <string>
#include <type_traits>
#include <vector>

#include "input_message_types.hpp"
#include "networked_estimation/config/model.hpp"
#include "networked_estimation/geodesy/local_enu.hpp"
#include "networked_estimation/simulation/sensor_outputs.hpp"
#include "networked_estimation/simulation/simulator.hpp"
#include "sensor_writers.hpp"

namespace networked_estimation
{

class SimulatedSensors
{
public:
  /// Advertises each sensor's topic. `datum`: the NavSatFix outputs' ENU origin (null: none);
  /// frames: the world's and the plant's, for messages whose sensor names none.
  void start(ros::NodeHandle& nh, const Model& model, const SimulatorOutputs& outputs, const LocalEnu* datum,
             const std::string& frame_id, const std::string& child_frame_id)
  {
    model_ = &model;
    outputs_ = &outputs;
    datum_ = datum;
    frame_id_ = frame_id;
    child_frame_id_ = child_frame_id;
    for (const SensorOutput& o : outputs.sensors)
      meas_pubs_.push_back(advertiseOutput(nh, o));
    published_.assign(model.sensors.size(), 0);
  }

private:
  static ros::Publisher advertiseOutput(ros::NodeHandle& nh, const SensorOutput& o)
  {
    return withInputMessage(o.format.type,
                            [&](auto tag) { return nh.advertise<MessageOf<decltype(tag)>>(o.format.topic, 1000); });
  }

  /// A standard message of sensor i: y and R in its fields, the sensor's frames.
  template <class M>
  void publishFields(std::size_t i, M m, const ros::Time& stamp, bool world_frame, const double* y, const double* R)
  {
    const SensorOutput& o = outputs_->sensors[i];
    m.header.stamp = stamp;
    m.header.frame_id = !o.frame_id.empty() ? o.frame_id : world_frame ? frame_id_ : child_frame_id_;
    const MessageSlots s = slots(m);
    writeFields(s, o.format.fields, y);
    writeCovariance(o.format.type, s, o.format.fields, R);
    meas_pubs_[i].publish(boost::make_shared<const M>(std::move(m)));  // shared: no serialization in-process
  }

public:
  /// Sensor i's sample of step k, stamped `stamp`.
  void publish(std::size_t i, const ros::Time& stamp, long k, const SimulatedSample& s)
  {
    const Sensor& sn = model_->sensors[i];
    const SensorOutput& o = outputs_->sensors[i];
    // The j-th sample of this sensor is drawn with R_j = s_j R: noise sqrt(s_j) v_k.
    const double scale = o.scaleOf(static_cast<long>(published_[i]++));
    y_ = s.y.segment(sn.offset, sn.size) + (std::sqrt(scale) - 1.0) * s.v.segment(sn.offset, sn.size);
    if (o.format.type != InputType::MEASUREMENT)                             // a Measurement carries no covariance
      R_ = scale * model_->R.block(sn.offset, sn.offset, sn.size, sn.size);  // column-major = row-major: symmetric
    withInputMessage(o.format.type,
                     [&](auto tag)
                     {
                       using M = MessageOf<decltype(tag)>;
                       if constexpr (kWholeVector<M>)
                       {
                         Measurement::Ptr m = boost::make_shared<Measurement>();
                         m->header.stamp = stamp;
                         m->header.frame_id = sn.name;
                         m->step = static_cast<std::uint64_t>(k);
                         m->sensor = sn.name;
                         m->y.assign(y_.data(), y_.data() + y_.size());
                         meas_pubs_[i].publish(m);
                       }
                       else if constexpr (std::is_same<M, sensor_msgs::NavSatFix>::value)
                       {
                         Eigen::Vector3d enu = Eigen::Vector3d::Zero();
                         writeFields(MessageSlots(), o.format.fields, y_.data(), &enu);
                         sensor_msgs::NavSatFix f = fixAt(*datum_, enu, o.format.fields, R_.data());
                         f.header.stamp = stamp;
                         f.header.frame_id = !o.frame_id.empty() ? o.frame_id : child_frame_id_;
                         meas_pubs_[i].publish(boost::make_shared<const sensor_msgs::NavSatFix>(std::move(f)));
                       }
                       else if constexpr (ros::message_traits::HasHeader<M>::value)  // sensorOutputTypes(): all stamped
                       {
                         M m;
                         prepare(m, o);
                         const bool world = inWorldFrame(m);
                         publishFields(i, std::move(m), stamp, world, y_.data(), R_.data());
                       }
                     });
  }

private:
  /// A simulated sensor's message before its fields: Odometry's child frame, Range's limits.
  template <class M>
  void prepare(M&, const SensorOutput&) const
  {
  }
  void prepare(nav_msgs::Odometry& m, const SensorOutput& o) const
  {
    m.child_frame_id = !o.child_frame_id.empty() ? o.child_frame_id : child_frame_id_;
  }
  void prepare(sensor_msgs::Range& m, const SensorOutput&) const
  {
    m.radiation_type = sensor_msgs::Range::INFRARED;
    m.min_range = -std::numeric_limits<float>::max();  // a simulated range may take any value
    m.max_range = std::numeric_limits<float>::max();
  }
  /// Poses and points are in the world frame (~frame_id), the rest in the plant's (~child_frame_id).
  template <class M>
  static bool inWorldFrame(const M&)
  {
    return std::is_same<M, nav_msgs::Odometry>::value ||
           std::is_same<M, geometry_msgs::PoseWithCovarianceStamped>::value ||
           std::is_same<M, geometry_msgs::PoseStamped>::value || std::is_same<M, geometry_msgs::PointStamped>::value;
  }

  const Model* model_ = nullptr;
  const SimulatorOutputs* outputs_ = nullptr;
  const LocalEnu* datum_ = nullptr;
  std::string frame_id_, child_frame_id_;
  std::vector<ros::Publisher> meas_pubs_;
  std::vector<std::uint64_t> published_;  ///< samples published per sensor (the covariance scale cycle)
  Eigen::VectorXd y_;
  Eigen::MatrixXd R_;
};

}  // namespace networked_estimation
