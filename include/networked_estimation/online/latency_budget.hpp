// How late each sensor's messages arrive, the latency budget that covers it, and what is lost to
// lateness (the Estimator's `latency_budget: auto`, docs/ros_interface.md).
//
// A step k is taken at its deadline stamp_k + budget (or earlier, once everything due at it is in
// hand); a message for it that arrives later is late. So a message is late exactly when its delay
// d = (ROS time at receipt) - stamp_k reaches the budget. Each sensor keeps the delays of its last
// kWindow messages; with an adaptive budget the budget is the largest over the sensors of their
// kQuantile delay plus a margin (half a model period plus half that delay: room for the scatter
// beyond the quantile, as a loaded machine's scheduling adds it), kept within [min, max]. The quantile never takes the single largest
// delay of a window (for fewer than 100 messages it is the second largest), so one stray message
// cannot move the budget. For the first kStartup seconds after start() (the timeline's start), a
// sensor not heard from yet counts with the maximum: the first steps wait for every sensor's first
// message (a step whose data is all in hand is taken at once anyway). A fixed budget ignores the
// delays.
//
// Losses to lateness are counted per sensor over the last kLateSeconds seconds of ROS time, so
// that the diagnostics can name a sensor that loses more than 1 % of its messages, with its delay.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

namespace networked_estimation
{

struct LatencyOptions
{
  bool adaptive = true;  ///< latency_budget: auto
  double fixed = 0.0;    ///< the budget when not adaptive (s)
  double min = 0.0;      ///< latency_budget_min (s)
  double max = 1.0;      ///< latency_budget_max (s)
  double period = 0.0;   ///< the model's period (s): the margin's floor is half of it
};

class LatencyBudget
{
public:
  static constexpr std::size_t kWindow = 256;
  static constexpr double kQuantile = 0.99;
  static constexpr int kLateSeconds = 10;
  static constexpr double kStartup = 2.0;

  /// Options are not validated here (validateRuntimeSettings does it).
  LatencyBudget(std::size_t sensors, const LatencyOptions& options);

  void setOptions(const LatencyOptions& options);
  const LatencyOptions& options() const { return options_; }

  /// A message of `sensor` arrived `delay` s after its step's stamp, at ROS time `now` (s). The
  /// budget follows at once, so the message itself is judged against it.
  void arrived(std::size_t sensor, double delay, double now);
  /// That message was dropped as late.
  void lost(std::size_t sensor, double now);
  /// A message of `sensor` refused before it was placed (its stamp): received and lost.
  void refused(std::size_t sensor, double now);

  /// The timeline started at ROS time `now`: the start-up period begins.
  void start(double now);
  /// ROS time is `now`: ends the start-up period when it is over.
  void at(double now);

  /// The budget in force (s).
  double budget() const { return budget_; }
  /// The sensor's kQuantile delay over its window (s); NaN before its first message.
  double delay(std::size_t sensor) const { return sensors_[sensor].quantile; }
  /// The median (nearest rank) of the sensor's delays over its window (s); NaN before its first
  /// message. O(kWindow): for reports, not per message.
  double medianDelay(std::size_t sensor) const;

  struct Window
  {
    std::uint64_t received = 0, lost = 0;
    double fraction() const { return received ? static_cast<double>(lost) / static_cast<double>(received) : 0.0; }
  };
  /// The sensor's messages and losses over the last kLateSeconds s of ROS time before `now`.
  Window window(std::size_t sensor, double now) const;

  /// One sensor's lateness as numbers (the Estimator's diagnostics and ~link_status).
  struct Figures
  {
    double delay_p50 = 0.0;      ///< medianDelay()
    double delay_p99 = 0.0;      ///< delay()
    double late_fraction = 0.0;  ///< window(now).fraction()
  };
  Figures figures(std::size_t sensor, double now) const
  {
    return Figures{medianDelay(sensor), delay(sensor), window(sensor, now).fraction()};
  }

  /// Forgets every delay and loss (a timeline restart).
  void clear();

private:
  struct Bucket
  {
    long second = -1;
    std::uint64_t received = 0, lost = 0;
  };
  struct PerSensor
  {
    std::vector<double> delays;  ///< ring of the last kWindow delays
    std::size_t next = 0;
    double quantile;
    std::array<Bucket, kLateSeconds> buckets;
  };
  Bucket& bucket(PerSensor& s, double now);
  void update();

  LatencyOptions options_;
  std::vector<PerSensor> sensors_;
  std::vector<double> scratch_;
  double budget_ = 0.0;
  double start_ = 0.0;
  bool starting_ = false;
};

}  // namespace networked_estimation
