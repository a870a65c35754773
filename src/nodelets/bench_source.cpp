// BenchSource: the benchmarks' Measurement stream (bench_util.hpp has the set).
#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>
#include <ros/ros.h>

#include <sys/prctl.h>

#include <atomic>
#include <cinttypes>
#include <thread>

#include "networked_estimation/Measurement.h"
#include "bench_util.hpp"
#include "load_failure.hpp"

namespace networked_estimation
{

using namespace bench;

class BenchSource : public nodelet::Nodelet
{
public:
  ~BenchSource() override
  {
    stop_ = true;
    if (thread_.joinable())
      thread_.join();
  }

private:
  void onInit() override
  {
    ros::NodeHandle& nh = getNodeHandle();
    ros::NodeHandle& pnh = getPrivateNodeHandle();
    pnh.param("rate", rate_, 1000.0);
    pnh.param("duration", duration_, 5.0);
    pnh.param("start_delay", start_delay_, 2.0);
    pnh.param("frame_id", frame_id_, std::string("bench"));
    pnh.param("dimension", dimension_, 2);                // values per Measurement
    pnh.param("nominal_stamps", nominal_stamps_, false);  // stamp = scheduled time instead of now
    if (!(rate_ > 0.0) || !(duration_ > 0.0) || !(start_delay_ >= 0.0))
    {
      refuseLoad(getName(), "BenchSource not started: rate and duration must be > 0 and start_delay >= 0 (rate " +
                                std::to_string(rate_) + ", duration " + std::to_string(duration_) + ", start_delay " +
                                std::to_string(start_delay_) + ")");
    }
    pub_ = nh.advertise<Measurement>("out", 1000);
    thread_ = std::thread(&BenchSource::run, this);
    NODELET_INFO("BenchSource -> %s: %g Hz for %g s after %g s", nh.resolveName("out").c_str(), rate_, duration_,
                 start_delay_);
  }

  void run()
  {
    // The default timer slack (50 us) would make sleep_until wake up to 4 periods late at 80 kHz.
    prctl(PR_SET_TIMERSLACK, 1000UL, 0UL, 0UL, 0UL);
    if (!interruptibleSleepUntil(SteadyClock::now() + seconds(start_delay_), stop_))
      return;
    const auto wait_end = SteadyClock::now() + std::chrono::seconds(10);
    while (!stop_ && pub_.getNumSubscribers() == 0 && SteadyClock::now() < wait_end)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    if (pub_.getNumSubscribers() == 0)
      NODELET_WARN("BenchSource: no subscriber on %s, publishing anyway", pub_.getTopic().c_str());

    const auto total = static_cast<std::uint64_t>(std::llround(rate_ * duration_));
    const double period_ns = 1e9 / rate_;
    const auto start = SteadyClock::now();
    start_ros_ = ros::Time::now();
    const auto due = [&](std::uint64_t k) {  // due time of message k (0-based)
      return start + std::chrono::nanoseconds(std::llround(static_cast<double>(k) * period_ns));
    };
    std::uint64_t sent = 0, wakeups = 0, max_batch = 0;
    SteadyClock::duration max_lag{0};
    while (!stop_ && ros::ok() && sent < total)
    {
      const auto next = due(sent);
      auto now = SteadyClock::now();
      if (now < next)
      {
        std::this_thread::sleep_until(next);
        now = SteadyClock::now();
      }
      ++wakeups;
      max_lag = std::max(max_lag, now - next);
      // Everything due by now leaves in this batch: the average rate holds when a wake-up is late.
      std::uint64_t batch = 0;
      while (sent < total && due(sent) <= now)
      {
        ++sent;
        publish(sent, start_ros_ + ros::Duration(1e-9 * static_cast<double>(sent - 1) * period_ns));
        ++batch;
      }
      max_batch = std::max(max_batch, batch);
    }
    const double elapsed = std::chrono::duration<double>(SteadyClock::now() - start).count();
    getPrivateNodeHandle().setParam("sent", static_cast<int>(sent));
    NODELET_INFO("bench_source: sent=%" PRIu64 " of %" PRIu64 " in %.3f s (%.0f Hz) wakeups=%" PRIu64
                 " max_batch=%" PRIu64 " max_lag_us=%.0f",
                 sent, total, elapsed, elapsed > 0.0 ? static_cast<double>(sent) / elapsed : 0.0, wakeups, max_batch,
                 std::chrono::duration<double, std::micro>(max_lag).count());
  }

  void publish(std::uint64_t step, const ros::Time& scheduled)
  {
    // A fresh object per message, published as a shared_ptr and never touched again: typed
    // subscribers in the manager receive this very object (no serialization).
    auto msg = boost::make_shared<Measurement>();
    msg->header.frame_id = frame_id_;
    msg->step = step;
    msg->sensor = "y";
    msg->y.assign(static_cast<std::size_t>(std::max(1, dimension_)), 0.0);
    for (std::size_t i = 0; i < msg->y.size(); ++i)
      msg->y[i] = (i % 2 ? -1.0 : 1.0) * static_cast<double>(step);
    msg->header.stamp = nominal_stamps_ ? scheduled : ros::Time::now();
    pub_.publish(msg);
  }

  double rate_ = 1000.0, duration_ = 5.0, start_delay_ = 2.0;
  int dimension_ = 2;
  bool nominal_stamps_ = false;
  ros::Time start_ros_;
  std::string frame_id_;
  ros::Publisher pub_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
};

}  // namespace networked_estimation

PLUGINLIB_EXPORT_CLASS(networked_estimation::BenchSource, nodelet::Nodelet)
