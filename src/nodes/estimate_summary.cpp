// estimate_summary: scores estimators against the plant's ground truth in a running graph and
// prints a summary table when the plant has finished (the end of launch/demo.launch).
//
// Subscribes to ~truth (PlantState) and every topic in ~estimates (Estimate). When every estimator
// has reported step ~steps (0: the plant's last step) (or ~timeout wall seconds pass without a new message after the plant's
// last step) it prints, per estimator: steps, arrival rate seen (mean gamma_k), time-averaged
// squared error |x_k - xhat_k|^2 against the truth, mean covariance trace and their ratio, then
// writes the same as YAML to ~output and as text to ~text_output (if set) and exits (the launch file marks it required, so
// the whole graph stops with it).
#include <ros/ros.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <map>
#include <mutex>
#include <sstream>
#include <string>
#include <vector>

#include <std_msgs/Empty.h>

#include "networked_estimation/Estimate.h"
#include "networked_estimation/PlantState.h"

namespace
{

struct Track
{
  std::string topic;
  std::string algorithm;
  std::map<long, networked_estimation::Estimate::ConstPtr> by_step;
  long last_step = 0;
};

/// "/kfio/estimate" -> "kfio": the estimator's namespace names it (several may run one algorithm).
std::string label(const std::string& topic)
{
  std::string t = topic;
  const std::string suffix = "/estimate";
  if (t.size() > suffix.size() && t.compare(t.size() - suffix.size(), suffix.size(), suffix) == 0)
    t.resize(t.size() - suffix.size());
  while (!t.empty() && t[0] == '/')
    t.erase(0, 1);
  return t.empty() ? topic : t;
}

struct Score
{
  long steps = 0;
  double arrival = 0.0, mse = 0.0, trace = 0.0;
};

}  // namespace

int main(int argc, char** argv)
{
  ros::init(argc, argv, "estimate_summary");
  ros::NodeHandle nh, pnh("~");
  std::vector<std::string> topics;
  int steps = 0;
  double timeout = 5.0;
  std::string output, truth_topic;
  pnh.param("estimates", topics, std::vector<std::string>{});
  pnh.param("steps", steps, 0);
  pnh.param("timeout", timeout, 5.0);
  pnh.param("output", output, std::string());
  std::string text_output;
  pnh.param("text_output", text_output, std::string());
  pnh.param("truth", truth_topic, std::string("plant_state"));
  if (topics.empty() || steps < 0 || !(timeout > 0.0))
  {
    ROS_FATAL(
        "estimate_summary: ~estimates must list Estimate topics (found %zu), ~steps must be >= 0 (found %d), "
        "~timeout > 0 (found %g)",
        topics.size(), steps, timeout);
    return 2;
  }

  std::mutex mutex;
  std::map<long, std::vector<double>> truth;
  std::vector<Track> tracks(topics.size());
  ros::WallTime last_msg = ros::WallTime::now(), last_msg_truth = last_msg;
  long last_truth = -1;
  std::vector<ros::Subscriber> subs;
  subs.push_back(nh.subscribe<networked_estimation::PlantState>(truth_topic, 10000,
                                                                [&](const networked_estimation::PlantState::ConstPtr& s)
                                                                {
                                                                  std::lock_guard<std::mutex> lock(mutex);
                                                                  truth[static_cast<long>(s->step)] = s->x;
                                                                  last_truth =
                                                                      std::max(last_truth, static_cast<long>(s->step));
                                                                  last_msg = last_msg_truth = ros::WallTime::now();
                                                                }));
  for (std::size_t i = 0; i < topics.size(); ++i)
  {
    tracks[i].topic = nh.resolveName(topics[i]);
    subs.push_back(
        nh.subscribe<networked_estimation::Estimate>(topics[i], 10000,
                                                     [&, i](const networked_estimation::Estimate::ConstPtr& e)
                                                     {
                                                       std::lock_guard<std::mutex> lock(mutex);
                                                       Track& t = tracks[i];
                                                       t.algorithm = e->algorithm;
                                                       if (steps == 0 || static_cast<long>(e->step) <= steps)
                                                         t.by_step[static_cast<long>(e->step)] = e;
                                                       t.last_step = std::max(t.last_step, static_cast<long>(e->step));
                                                       last_msg = ros::WallTime::now();
                                                     }));
  }

  ros::AsyncSpinner spinner(1);
  spinner.start();
  // ~ready (latched) once every subscription is connected: a plant with ~start_after: summary/ready
  // starts only then, so that no estimate is published before this node listens.
  ros::Publisher ready = pnh.advertise<std_msgs::Empty>("ready", 1, true);
  {
    bool connected = false;
    while (ros::ok() && !connected)
    {
      connected = true;
      for (const ros::Subscriber& s : subs)
        connected = connected && s.getNumPublishers() > 0;
      if (!connected)
        ros::WallDuration(0.05).sleep();
    }
    ready.publish(std_msgs::Empty());
  }
  ros::WallRate poll(20.0);
  bool timed_out = false;
  while (ros::ok())
  {
    {
      std::lock_guard<std::mutex> lock(mutex);
      // ~steps = 0: the plant's last step is the target, once the truth has been quiet for 1 s.
      const bool settled = last_truth > 0 && (ros::WallTime::now() - last_msg_truth).toSec() > 1.0;
      const long target = steps > 0 ? steps : (settled ? last_truth : -1);
      bool done = target > 0;
      for (const Track& t : tracks)
        done = done && t.last_step >= target;
      if (done)
      {
        steps = static_cast<int>(target);
        break;
      }
      if (last_truth >= 0 && (ros::WallTime::now() - last_msg).toSec() > timeout)
      {
        timed_out = true;
        steps = static_cast<int>(last_truth);
        break;
      }
    }
    poll.sleep();
  }
  spinner.stop();
  if (!ros::ok())
    return 1;

  std::lock_guard<std::mutex> lock(mutex);
  std::vector<Score> scores(tracks.size());
  for (std::size_t i = 0; i < tracks.size(); ++i)
  {
    Score& s = scores[i];
    long arrived = 0;
    for (const auto& kv : tracks[i].by_step)
    {
      const auto tr = truth.find(kv.first);
      if (tr == truth.end() || tr->second.size() != kv.second->state.size())
        continue;
      double e2 = 0.0;
      for (std::size_t j = 0; j < tr->second.size(); ++j)
        e2 += (tr->second[j] - kv.second->state[j]) * (tr->second[j] - kv.second->state[j]);
      s.mse += e2;
      s.trace += kv.second->covariance_trace;
      arrived += kv.second->gamma ? 1 : 0;
      ++s.steps;
    }
    if (s.steps > 0)
    {
      s.mse /= static_cast<double>(s.steps);
      s.trace /= static_cast<double>(s.steps);
      s.arrival = static_cast<double>(arrived) / static_cast<double>(s.steps);
    }
  }

  std::ostringstream out;
  out << "\n=== networked_estimation demo summary (" << steps << " plant steps"
      << (timed_out ? ", stopped by timeout" : "") << ") ===\n";
  out << std::left << std::setw(10) << "estimator" << std::right << std::setw(8) << "steps" << std::setw(10)
      << "arrivals" << std::setw(14) << "mean |e|^2" << std::setw(14) << "mean tr(P)" << std::setw(14) << "|e|^2/tr(P)"
      << "\n";
  for (std::size_t i = 0; i < tracks.size(); ++i)
  {
    const Score& s = scores[i];
    out << std::left << std::setw(10) << label(tracks[i].topic) << std::right << std::setw(8) << s.steps
        << std::setw(10) << std::fixed << std::setprecision(3) << s.arrival << std::setw(14) << std::setprecision(4)
        << s.mse << std::setw(14) << s.trace << std::setw(14) << std::setprecision(3)
        << (s.trace > 0.0 && std::isfinite(s.mse / s.trace) ? s.mse / s.trace : std::nan("")) << "\n";
  }
  out << "mean |e|^2: time-averaged squared error against PlantState; tr(P): the filter's own claim of it\n"
         "(a ratio near 1 means the filter is consistent; one run's ratio scatters widely when long loss bursts\n"
         "dominate; rseio's P is the paper's pseudo-covariance, and rseio equals kfio on a model without\n"
         "uncertainty, docs/algorithms.md 4.7).\n";
  std::fputs(out.str().c_str(), stdout);
  std::fflush(stdout);
  if (!text_output.empty())
  {
    std::ofstream f(text_output);
    f << out.str();
    if (!f)
    {
      ROS_ERROR("estimate_summary: could not write ~text_output '%s'", text_output.c_str());
      return 1;
    }
  }

  if (!output.empty())
  {
    std::ofstream f(output);
    f << std::setprecision(17) << "steps: " << steps << "\ntimed_out: " << (timed_out ? "true" : "false")
      << "\nestimators:\n";
    for (std::size_t i = 0; i < tracks.size(); ++i)
      f << "  - {name: '" << label(tracks[i].topic) << "', topic: '" << tracks[i].topic << "', algorithm: '"
        << tracks[i].algorithm << "', steps: " << scores[i].steps << ", arrival_rate: " << scores[i].arrival
        << ", mean_squared_error: " << scores[i].mse << ", mean_covariance_trace: " << scores[i].trace << "}\n";
    if (!f)
    {
      ROS_ERROR("estimate_summary: could not write ~output '%s'", output.c_str());
      return 1;
    }
  }
  return 0;
}
