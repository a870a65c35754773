// One message as the online API takes it (OnlineEstimator's offer functions, OnlineStream's
// measurement and command): a sensor's y_k, or a command u_k, with the step it names and its
// stamp. Both are views: they point into the caller's values (a ROS message's array, a vector, an
// Eigen vector), which must outlive the call; nothing is copied or allocated until the
// OnlineEstimator stores the values in their step's slot. Aggregates, written as
//   offerMeasurement({k, sensor, y.data(), y.size()})
//   stream.measurement({-1, sensor, y.data(), y.size(), R, stamp}, now)
// (the fields left out keep their defaults).
#pragma once

#include <cstddef>

namespace networked_estimation
{

/// y_k of one sensor.
struct SensorSample
{
  /// >= 1: the step k the message names (Measurement.step). Anything else: the message names none
  /// and its step comes from its stamp (OnlineStream::measurement; OnlineEstimator::offerSample
  /// takes a step position instead). OnlineEstimator::offerMeasurement takes it as k whatever it
  /// is (a k < 1 is rejected there).
  long step = -1;
  std::size_t sensor = 0;     ///< index into model.sensors
  const double* y = nullptr;  ///< `size` values: the sensor's rows, in its order
  std::size_t size = 0;       ///< must equal the sensor's rows (checked)
  /// Optionally the sensor's own R_k block for this sample (size x size, row-major; e.g. the
  /// message's covariance, validated by the caller); null: the model's R.
  const double* R = nullptr;
  double stamp = 0.0;  ///< s, the sampling time (read by OnlineStream, not by OnlineEstimator)
};

/// u_k, the known command of a model with control.
struct CommandSample
{
  /// The step k the command is for (ControlInput.step; OnlineStream::command and
  /// OnlineEstimator::offerCommand). Not read by OnlineStream::heldCommand, which takes the step
  /// nearest to the stamp.
  long step = -1;
  const double* u = nullptr;  ///< `size` values
  std::size_t size = 0;       ///< must equal the model's p (checked)
  double stamp = 0.0;         ///< s (read by OnlineStream, not by OnlineEstimator)
};

}  // namespace networked_estimation
