// BenchSink and BenchEstimateSink: latency, missed messages and CPU per message of a benchmark
// (bench_util.hpp has the set).
#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>
#include <ros/ros.h>
#include <diagnostic_msgs/DiagnosticArray.h>

#include <cinttypes>
#include <cstdio>
#include <limits>
#include <map>
#include <mutex>
#include <thread>
#include <vector>

#include "networked_estimation/Estimate.h"
#include "networked_estimation/Measurement.h"
#include "bench_util.hpp"
#include "load_failure.hpp"

namespace networked_estimation
{

using namespace bench;

/// Messages a sink counts as missed: an Estimate of a step whose measurement was not in hand at
/// its deadline (gamma = 0); a Measurement later than ~late_after seconds after its stamp (the
/// same criterion for a bare hop, when the source stamps its scheduled times).
inline bool missed(const Measurement&, double latency_s, double late_after)
{
  return latency_s > late_after;
}
inline bool missed(const Estimate& e, double, double)
{
  return !e.gamma;
}

template <class M>
class BenchSinkT : public nodelet::Nodelet
{
public:
  ~BenchSinkT() override
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
    double rate = 1000.0;
    int queue_size = 100000;
    pnh.param("label", label_, getName());
    pnh.param("rate", rate, 1000.0);
    pnh.param("duration", duration_, 5.0);
    pnh.param("start_delay", start_delay_, 2.0);
    pnh.param("grace", grace_, 1.0);
    pnh.param("result_file", result_file_, std::string());
    pnh.param("source", source_, std::string());
    pnh.param("queue_size", queue_size, 100000);
    pnh.param("late_after", late_after_, std::numeric_limits<double>::infinity());
    // ~diagnostics: the name of an Estimator's `estimator` status (e.g. "bench_estimator: estimator"):
    // its `late dropped`, `accepted` and `rejected` at the end are reported too (a due sample that
    // came after its step was taken is a missed one, whatever gamma says).
    pnh.param("diagnostics", diagnostics_, std::string());
    if (!diagnostics_.empty())
      diag_sub_ =
          nh.subscribe<diagnostic_msgs::DiagnosticArray>("/diagnostics", 100,
                                                         [this](const diagnostic_msgs::DiagnosticArray::ConstPtr& a)
                                                         {
                                                           for (const auto& st : a->status)
                                                             if (st.name.find(diagnostics_) != std::string::npos)
                                                             {
                                                               std::lock_guard<std::mutex> lock(diag_mutex_);
                                                               for (const auto& kv : st.values)
                                                                 diag_[kv.key] = kv.value;
                                                               ++diag_updates_;
                                                             }
                                                         });
    // Preallocated: no reallocation while recording (50 % headroom over rate * duration).
    latency_us_.assign(static_cast<std::size_t>(std::max(1000.0, 1.5 * rate * duration_ + 1000.0)), 0.0);
    sample_every_ = static_cast<std::uint64_t>(std::max(10.0, rate / 100.0));
    expected_ = static_cast<std::uint64_t>(std::llround(rate * duration_));
    init_ = SteadyClock::now();
    sub_ = nh.subscribe("in", static_cast<uint32_t>(queue_size), &BenchSinkT::onMessage, this,
                        ros::TransportHints().tcpNoDelay());
    thread_ = std::thread(&BenchSinkT::waitAndReport, this);
    NODELET_INFO("BenchSink <- %s: label %s, reports %g s after the first message", nh.resolveName("in").c_str(),
                 label_.c_str(), duration_ + grace_);
  }

  void onMessage(const typename M::ConstPtr& msg)
  {
    const ros::Time now = ros::Time::now();
    // An estimator keeps stepping (on its deadlines, without data) after the source has stopped:
    // those steps are not part of the run.
    if (msg->step > expected_)
      return;
    const auto t = SteadyClock::now();
    std::lock_guard<std::mutex> lock(mutex_);
    if (done_)
      return;
    if (received_ == 0)
    {
      first_ = t;
      cpu_first_ = processCpuSeconds();
      busy_first_ = machineBusySeconds();
    }
    else if (received_ % sample_every_ == 0)  // system calls: about 100 times a second, not every message
    {
      cpu_last_ = processCpuSeconds();
      busy_last_ = machineBusySeconds();
      cpu_last_t_ = t;
      cpu_last_count_ = received_;
    }
    last_ = t;
    if (received_ < latency_us_.size())
      latency_us_[received_] = static_cast<double>((now - msg->header.stamp).toNSec()) * 1e-3;
    ++received_;
    missed_ += missed(*msg, (now - msg->header.stamp).toSec(), late_after_) ? 1 : 0;
    max_step_ = std::max<std::uint64_t>(max_step_, msg->step);
  }

  void waitAndReport()
  {
    // Report duration + grace after the first message; if none comes, a while after the source's
    // planned end (it waits up to 10 s for a subscriber).
    const auto give_up = init_ + seconds(start_delay_ + duration_ + grace_ + 15.0);
    while (!stop_)
    {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      std::lock_guard<std::mutex> lock(mutex_);
      const auto now = SteadyClock::now();
      if ((received_ > 0 && now >= first_ + seconds(duration_ + grace_)) || now >= give_up)
      {
        done_ = true;  // stop recording: onMessage returns at once from now on
        break;
      }
    }
    if (!stop_ && !diagnostics_.empty())
    {
      // One more update of the estimator's diagnostics (once a second) after the run.
      std::uint64_t seen = 0;
      {
        std::lock_guard<std::mutex> lock(diag_mutex_);
        seen = diag_updates_;
      }
      const auto until = SteadyClock::now() + std::chrono::milliseconds(2500);
      while (!stop_ && SteadyClock::now() < until)
      {
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
        std::lock_guard<std::mutex> lock(diag_mutex_);
        if (diag_updates_ > seen)
          break;
      }
    }
    if (!stop_)
      report();
  }

  /// An integer value of the estimator's diagnostics; -1 when unknown.
  long diagValue(const std::string& key)
  {
    std::lock_guard<std::mutex> lock(diag_mutex_);
    auto it = diag_.find(key);
    return it == diag_.end() ? -1 : std::atol(it->second.c_str());
  }

  void report()
  {
    // done_ is set: onMessage no longer touches the members read below.
    const std::size_t n = std::min<std::size_t>(received_, latency_us_.size());
    std::vector<double> all(latency_us_.begin(), latency_us_.begin() + static_cast<std::ptrdiff_t>(n));
    // Growth of the latency during the run, in arrival order: p99 of each half, and the median of the
    // first and of the last tenth (robust to one stall: a backlog that keeps growing raises the last).
    const auto part = [&](std::size_t from, std::size_t to)
    {
      return std::vector<double>(all.begin() + static_cast<std::ptrdiff_t>(from),
                                 all.begin() + static_cast<std::ptrdiff_t>(to));
    };
    std::vector<double> first_half = part(0, n / 2), second_half = part(n / 2, n);
    std::vector<double> first_tenth = part(0, n / 10), last_tenth = part(n - n / 10, n);
    const double span = std::chrono::duration<double>(last_ - first_).count();
    const double rate = received_ > 1 && span > 0.0 ? static_cast<double>(received_ - 1) / span : 0.0;
    // Messages sent: the source's count (its ~sent, set when it finishes), else the largest step seen.
    std::uint64_t sent = max_step_;
    int sent_param = 0;
    if (!source_.empty() && getNodeHandle().getParam(source_ + "/sent", sent_param))
      sent = static_cast<std::uint64_t>(sent_param);
    const double median = quantile(all, 0.5), p90 = quantile(all, 0.9), p99 = quantile(all, 0.99);
    const double max = all.empty() ? 0.0 : *std::max_element(all.begin(), all.end());
    const double p99_first = quantile(first_half, 0.99), p99_second = quantile(second_half, 0.99);
    const double median_first = quantile(first_tenth, 0.5), median_last = quantile(last_tenth, 0.5);
    // CPU of the process between the first message and the last sample (every sample_every_ messages), and
    // that of the rest of the machine (/proc/stat, 10 ms resolution).
    const double cpu = cpu_last_count_ > 0 ? cpu_last_ - cpu_first_ : 0.0;
    const double cpu_span = cpu_last_count_ > 0 ? std::chrono::duration<double>(cpu_last_t_ - first_).count() : 0.0;
    const double cpu_us_per_msg = cpu_last_count_ > 0 ? 1e6 * cpu / static_cast<double>(cpu_last_count_) : 0.0;
    const double cpu_cores = cpu_span > 0.0 ? cpu / cpu_span : 0.0;
    const double other_cores = cpu_span > 0.0 ? std::max(0.0, (busy_last_ - busy_first_ - cpu) / cpu_span) : 0.0;
    const long late = diagValue("late dropped"), accepted = diagValue("accepted"), rejected = diagValue("rejected");
    char line[640];
    std::snprintf(line, sizeof line,
                  "sent=%" PRIu64 " received=%" PRIu64
                  " rate=%.1f latency_us median=%.1f p90=%.1f p99=%.1f "
                  "max=%.1f p99_first_half=%.1f p99_second_half=%.1f median_first_tenth=%.1f median_last_tenth=%.1f "
                  "cpu_us_per_msg=%.2f cpu_cores=%.2f other_cores=%.2f missed=%" PRIu64
                  " late_dropped=%ld accepted=%ld rejected=%ld",
                  sent, received_, rate, median, p90, p99, max, p99_first, p99_second, median_first, median_last,
                  cpu_us_per_msg, cpu_cores, other_cores, missed_, late, accepted, rejected);
    ROS_INFO("bench_sink %s: %s", label_.c_str(), line);
    if (received_ > latency_us_.size())
      ROS_WARN("bench_sink %s: %zu messages beyond the preallocated %zu are not in the latency statistics",
               label_.c_str(), static_cast<std::size_t>(received_ - latency_us_.size()), latency_us_.size());
    if (result_file_.empty())
      return;
    bool empty = true;
    {
      std::ifstream in(result_file_);
      empty = !in || in.peek() == std::ifstream::traits_type::eof();
    }
    std::ofstream out(result_file_, std::ios::app);
    if (!out)
    {
      ROS_ERROR("bench_sink %s: cannot write %s", label_.c_str(), result_file_.c_str());
      return;
    }
    if (empty)
      out << "label,sent,received,rate_hz,median_us,p90_us,p99_us,max_us,p99_first_half_us,p99_second_half_us,"
             "median_first_tenth_us,median_last_tenth_us,cpu_us_per_msg,cpu_cores,other_cores,missed,late_dropped,"
             "accepted,rejected\n";
    std::snprintf(line, sizeof line,
                  "%s,%" PRIu64 ",%" PRIu64 ",%.1f,%.1f,%.1f,%.1f,%.1f,%.1f,%.1f,%.1f,%.1f,%.2f,%.2f,%.2f,%" PRIu64
                  ",%ld,%ld,%ld\n",
                  label_.c_str(), sent, received_, rate, median, p90, p99, max, p99_first, p99_second, median_first,
                  median_last, cpu_us_per_msg, cpu_cores, other_cores, missed_, late, accepted, rejected);
    out << line;
  }

  std::string label_, result_file_, source_, diagnostics_;
  ros::Subscriber diag_sub_;
  std::mutex diag_mutex_;
  std::map<std::string, std::string> diag_;
  std::uint64_t diag_updates_ = 0;
  double duration_ = 5.0, start_delay_ = 2.0, grace_ = 1.0;
  ros::Subscriber sub_;
  std::mutex mutex_;
  std::vector<double> latency_us_;
  std::uint64_t received_ = 0, max_step_ = 0, cpu_last_count_ = 0, sample_every_ = 100, missed_ = 0;
  std::uint64_t expected_ = 0;  ///< messages the source sends (rate x duration): steps 1..expected_
  double late_after_ = std::numeric_limits<double>::infinity();
  SteadyClock::time_point init_, first_, last_, cpu_last_t_;
  double cpu_first_ = 0.0, cpu_last_ = 0.0, busy_first_ = 0.0, busy_last_ = 0.0;
  bool done_ = false;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

/// Sink of Measurement (bench_channel.launch).
class BenchSink : public BenchSinkT<Measurement>
{
};

/// Sink of Estimate (bench_estimator.launch): also counts the steps estimated without their
/// measurement (missed).
class BenchEstimateSink : public BenchSinkT<Estimate>
{
};

}  // namespace networked_estimation

PLUGINLIB_EXPORT_CLASS(networked_estimation::BenchSink, nodelet::Nodelet)
PLUGINLIB_EXPORT_CLASS(networked_estimation::BenchEstimateSink, nodelet::Nodelet)
