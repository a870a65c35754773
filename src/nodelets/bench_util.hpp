// Benchmark nodelets for the LossyChannel and Estimator nodelets (scripts/bench_channel.sh,
// launch/bench_channel.launch, launch/bench_estimator.launch, scripts/bench_robot.sh): all in ONE
// nodelet manager, so every hop is an intra-process shared_ptr hand-over. Each in its own file:
//
//  - BenchSource (bench_source.cpp):       publishes Measurement (y of size 2) at ~rate Hz for
//                      ~duration s from its own thread (steady-clock sleep_until, batches the
//                      messages that are due when it wakes late); header.stamp = ros::Time::now() at
//                      publish, step = 1, 2, ...
//  - BenchPassThrough (bench_pass_through.cpp): ShapeShifter `in` -> the same object on `out`,
//                      nothing else (the baseline the channel is compared with: same subscription
//                      type, same hand-overs).
//  - BenchSink, BenchEstimateSink (bench_sink.cpp): record now - header.stamp of every Measurement
//                      (Estimate) on `in`, report once; also the CPU time of the whole manager
//                      process per message received (every thread: source, element under test, sink,
//                      ROS's), a load measure less noisy than latency, and the CPU the rest of the
//                      machine used meanwhile (other processes: noise).
//  - BenchNullReceiver (bench_null_receiver.cpp): subscribes to every topic of ~topics (any type)
//                      and does nothing with the messages, served by its own thread as the
//                      Estimator's inputs are: what receiving a stream costs in roscpp
//                      (scripts/bench_robot.sh, the bag's floor).
//
// This header: the clocks and statistics they share.
#pragma once

#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

namespace networked_estimation
{
namespace bench
{

using SteadyClock = std::chrono::steady_clock;

inline SteadyClock::duration seconds(double s)
{
  return std::chrono::duration_cast<SteadyClock::duration>(std::chrono::duration<double>(s));
}

/// Sleeps until `until` or until `stop` is set (checked every 50 ms); false when stopped.
inline bool interruptibleSleepUntil(SteadyClock::time_point until, const std::atomic<bool>& stop)
{
  while (!stop && SteadyClock::now() < until)
    std::this_thread::sleep_until(std::min(until, SteadyClock::now() + std::chrono::milliseconds(50)));
  return !stop;
}

/// CPU time used so far by the whole process (every thread of the nodelet manager), in seconds.
inline double processCpuSeconds()
{
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

/// Busy CPU time of the whole machine so far (all cores, steal included), in seconds; 0 if unknown.
inline double machineBusySeconds()
{
  std::ifstream in("/proc/stat");
  std::string cpu;
  unsigned long long user = 0, nice = 0, system = 0, idle = 0, iowait = 0, irq = 0, softirq = 0, steal = 0;
  if (!(in >> cpu >> user >> nice >> system >> idle >> iowait >> irq >> softirq >> steal) || cpu != "cpu")
    return 0.0;
  return static_cast<double>(user + nice + system + irq + softirq + steal) / static_cast<double>(sysconf(_SC_CLK_TCK));
}

/// Nearest-rank quantile of v (reordered in place); 0 when empty.
inline double quantile(std::vector<double>& v, double q)
{
  if (v.empty())
    return 0.0;
  const auto rank = static_cast<std::size_t>(std::ceil(q * static_cast<double>(v.size())));
  const std::size_t k = std::min(v.size() - 1, rank > 0 ? rank - 1 : 0);
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

}  // namespace bench
}  // namespace networked_estimation
