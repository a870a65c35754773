// PlantSimulator nodelet: runs the core PlantSimulator of a model file at the model's period and
// publishes y_k per sensor, the ground truth (PlantState and a tf2 frame). Each sensor is published
// as networked_estimation/Measurement on measurement[/<name>] at every step, or, with a block in
// ~sensors, as a standard ROS type (Odometry, PoseWithCovarianceStamped, NavSatFix about ~datum,
// Imu, Range, ...) with y_k in the selected fields and R in the message's covariance, at the
// sensor's own rate (sensor_outputs.hpp, sensor_writers.hpp). With a
// sensor schedule in the model, only the sensors scheduled at step k publish y_k, and the draw is
// published on `schedule` (ScheduleStep) before them (random schedules: seed as in simulate). A command
// is applied at step k only when ControlInput k has arrived on `command` (the output of the
// actuator link) by then; otherwise the input is zero (as in Lin et al.'s model).
//
// Clock: wall time, a thread of its own stepping at t0 + k period (steady clock); under
// use_sim_time, a ros::Timer on /clock. With ~publish_clock the plant
// drives /clock itself (sim time advancing one period per step, ~time_scale times real time, and
// ~clock_tail seconds past the last step).
// Start: ~start_delay wall seconds after load, or after the first message on ~start_after
// (std_msgs/Empty, e.g. estimate_summary's latched ~ready).
#include <nodelet/nodelet.h>
#include <sys/prctl.h>
#include <pluginlib/class_list_macros.hpp>
#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>
#include <std_msgs/Empty.h>
#include <tf2_ros/transform_broadcaster.h>

#include <atomic>
#include <chrono>
#include <map>
#include <mutex>
#include <thread>

#include "networked_estimation/ControlInput.h"
#include "networked_estimation/Measurement.h"
#include "networked_estimation/PlantState.h"
#include "networked_estimation/ScheduleStep.h"
#include "networked_estimation/common/error.hpp"
#include "networked_estimation/config/model.hpp"
#include "networked_estimation/simulation/schedule_sampler.hpp"
#include "networked_estimation/simulation/sensor_outputs.hpp"
#include "networked_estimation/simulation/simulator.hpp"
#include "load_failure.hpp"
#include "param_yaml.hpp"
#include "simulated_sensors.hpp"

namespace networked_estimation
{

class PlantSimulatorNodelet : public nodelet::Nodelet
{
public:
  ~PlantSimulatorNodelet() override
  {
    quit_ = true;
    if (stepper_.joinable())
      stepper_.join();
  }

private:
  void onInit() override
  {
    ros::NodeHandle& nh = getNodeHandle();
    ros::NodeHandle& pnh = getPrivateNodeHandle();
    try
    {
      ParamReader p(privateParameters(pnh), pnh.getNamespace() + " parameters");
      model_ = loadModel(p.required("model"));
      seed_ = static_cast<std::uint64_t>(p.integer("seed", 0, 0, std::numeric_limits<long>::max()));
      period_ = p.number("period", model_.period, 1e-6, 3600.0);
      if (!(period_ > 0.0))
        throw ConfigError(p.source() + ": period: the model has no period and none was given");
      max_steps_ = p.integer("steps", 0, 0, std::numeric_limits<long>::max());
      const double duration = p.number("duration", 0.0, 0.0, 1e9);
      if (duration > 0.0)
        max_steps_ = static_cast<long>(std::floor(duration / period_ + 1e-9));
      frame_id_ = p.text("frame_id", "map");
      child_frame_id_ = p.text("child_frame_id", "plant");
      positions_ = p.indices("position_indices", defaultPositions(model_.n()), model_.n());
      publish_tf_ = p.flag("publish_tf", true);
      publish_clock_ = p.flag("publish_clock", false);
      time_scale_ = p.number("time_scale", 1.0, 1e-3, 1e4);
      tail_left_ = p.number("clock_tail", 1.0, 0.0, 3600.0);
      start_delay_ = p.number("start_delay", 1.0, 0.0, 3600.0);
      start_after_ = p.text("start_after", "");
      outputs_ = parseSimulatorOutputs(p, model_, period_, p.source());
      if (!outputs_.datum.empty())
        datum_ =
            std::make_unique<LocalEnu>(outputs_.datum[0], outputs_.datum[1], outputs_.datum[2], p.source() + ": datum");
      p.rejectUnknown();
    }
    catch (const ConfigError& e)
    {
      refuseLoad(getName(), std::string("PlantSimulator not started: ") + e.what());
    }
    sim_ = std::make_unique<PlantSimulator>(model_, seed_);
    // The same stream as LossyRun's (simulate), so one seed gives one schedule everywhere.
    schedule_ = std::make_unique<ScheduleSampler>(model_.schedule, model_.sensors.size(), deriveSeed(seed_, 300));
    if (model_.schedule.active())
      schedule_pub_ = nh.advertise<ScheduleStep>("schedule", 1000);
    sensors_.start(nh, model_, outputs_, datum_.get(), frame_id_, child_frame_id_);
    state_pub_ = nh.advertise<PlantState>("plant_state", 1000);
    if (model_.hasControl())
      cmd_sub_ =
          nh.subscribe("command", 1000, &PlantSimulatorNodelet::onCommand, this, ros::TransportHints().tcpNoDelay());
    if (publish_clock_)
      clock_pub_ = nh.advertise<rosgraph_msgs::Clock>("/clock", 10);
    if (start_after_.empty())
      scheduleStart();
    else  // e.g. estimate_summary's latched ~ready: every listener is connected
      start_sub_ = nh.subscribe<std_msgs::Empty>(start_after_, 1,
                                                 [this](const std_msgs::Empty::ConstPtr&)
                                                 {
                                                   if (!start_scheduled_)
                                                     scheduleStart();
                                                 });
    NODELET_INFO(
        "PlantSimulator '%s': n = %d, %zu sensor(s), period %g s, %s, seed %llu%s", model_.name.c_str(), model_.n(),
        model_.sensors.size(), period_,
        max_steps_ > 0 ? ("stops after " + std::to_string(max_steps_) + " steps").c_str() : "runs until shut down",
        static_cast<unsigned long long>(seed_), model_.hasControl() ? ", control input on 'command'" : "");
  }

  /// Starts stepping after ~start_delay (wall seconds), giving subscribers time to connect.
  void scheduleStart()
  {
    start_scheduled_ = true;
    ros::NodeHandle& nh = getNodeHandle();
    start_timer_ = nh.createWallTimer(
        ros::WallDuration(start_delay_ + 1e-3),
        [this](const ros::WallTimerEvent&)
        {
          ros::NodeHandle& n = getNodeHandle();
          if (publish_clock_)
          {
            sim_now_ = ros::Time(1.0);  // sim time starts at 1 s (0 means "no clock yet" to roscpp)
            wall_timer_ = n.createWallTimer(ros::WallDuration(period_ / time_scale_),
                                            [this](const ros::WallTimerEvent&) { clockTick(); });
          }
          else if (!ros::Time::isSimTime())
            stepper_ = std::thread(&PlantSimulatorNodelet::stepOnWallClock, this);
          else  // someone else's /clock
            ros_timer_ =
                n.createTimer(ros::Duration(period_), [this](const ros::TimerEvent& e) { tick(e.current_expected); });
        },
        true);
  }

  /// Wall time: steps from this thread at t0 + k period (steady clock, sleep_until), stamped with
  /// the ROS time of that instant: one wake-up per step, without the timer thread and the callback
  /// queue between the clock and the publication (a sensor's driver publishes as it samples).
  void stepOnWallClock()
  {
    using Clock = std::chrono::steady_clock;
    // The kernel's default timer slack (50 us) would wake each step up to that late: a sensor's
    // samples would leave later than their stamps say.
    prctl(PR_SET_TIMERSLACK, 1000UL, 0UL, 0UL, 0UL);
    const auto period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(period_));
    auto next = Clock::now();
    const ros::Time t0 = ros::Time::now();
    for (long i = 0; !quit_ && !finished_ && !stopped_; ++i)
    {
      std::this_thread::sleep_until(next);
      if (quit_)
        break;
      tick(t0 + ros::Duration(period_ * static_cast<double>(i)));
      next += period;
      if (Clock::now() > next + 100 * period)
        next = Clock::now();  // suspended (or far behind): go on from now instead of a burst
    }
  }

  static std::vector<int> defaultPositions(int n) { return n >= 2 ? std::vector<int>{0, 1} : std::vector<int>{0}; }

  void clockTick()
  {
    if (finished_)
    {
      // The clock runs ~clock_tail seconds past the last step (so that the estimators finalise
      // their last steps at their deadlines), then stops (a bag may drive it next).
      tail_left_ -= period_;
      if (tail_left_ < 0.0)
      {
        wall_timer_.stop();
        return;
      }
    }
    sim_now_ += ros::Duration(period_);
    rosgraph_msgs::Clock c;
    c.clock = sim_now_;
    clock_pub_.publish(c);
    // Publish step k's data only once this process's ROS time has reached stamp_k: a nodelet here
    // that receives y_k must not still read the previous time (its arrival time, its deadlines).
    if (ros::Time::isSimTime())
    {
      const ros::WallTime give_up = ros::WallTime::now() + ros::WallDuration(0.05);
      while (ros::Time::now() < sim_now_ && ros::WallTime::now() < give_up)
        ros::WallDuration(0.0001).sleep();
    }
    tick(sim_now_);
  }

  void onCommand(const ControlInput::ConstPtr& msg)
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (static_cast<long>(msg->step) <= k_)
    {
      ++late_commands_;
      NODELET_WARN_THROTTLE(1.0,
                            "PlantSimulator: command for step %lu arrived after the step was taken (zero input "
                            "was applied); %lu such commands so far",
                            static_cast<unsigned long>(msg->step), static_cast<unsigned long>(late_commands_));
      return;
    }
    if (msg->u.size() != static_cast<std::size_t>(model_.p()))
    {
      NODELET_WARN_THROTTLE(1.0, "PlantSimulator: command for step %lu rejected: u: expected %d values, found %zu",
                            static_cast<unsigned long>(msg->step), model_.p(), msg->u.size());
      return;
    }
    if (commands_.size() < 10000)
      commands_[static_cast<long>(msg->step)] = Eigen::Map<const Eigen::VectorXd>(msg->u.data(), model_.p());
  }

  void tick(const ros::Time& stamp)
  {
    if (stopped_)
      return;
    if (max_steps_ > 0 && k_ >= max_steps_)
    {
      if (!finished_)
      {
        finished_ = true;
        if (model_.hasControl())
          NODELET_INFO("PlantSimulator: finished after %ld steps (%lu commands applied, %lu lost or late)", k_,
                       static_cast<unsigned long>(applied_), static_cast<unsigned long>(k_ - applied_));
        else
          NODELET_INFO("PlantSimulator: finished after %ld steps", k_);
      }
      return;
    }
    if (!started_)
    {
      started_ = true;
      publishState(stamp, 0, sim_->state(), false);  // x_0
      return;
    }
    Eigen::VectorXd u;
    bool have_u = false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      const long k = k_ + 1;
      auto it = commands_.find(k);
      if (it != commands_.end())
      {
        u = it->second;
        have_u = true;
      }
      commands_.erase(commands_.begin(), commands_.upper_bound(k));
      k_ = k;
    }
    const SimulatedSample* sp = nullptr;
    try
    {
      sp = &sim_->stepApplied(have_u ? &u : nullptr);
    }
    catch (const DivergenceError& e)
    {
      // The state crossed the rounding floor (or overflowed): step k is not published, nor any
      // later one. The nodelet stays loaded; with ~publish_clock the clock runs its tail and stops.
      stopped_ = finished_ = true;
      if (ros_timer_)
        ros_timer_.stop();
      NODELET_ERROR("PlantSimulator: stopped at step k = %ld, nothing more is published: %s", k_, e.what());
      return;
    }
    const SimulatedSample& s = *sp;
    if (s.nu && model_.hasControl())
      ++applied_;
    const std::vector<bool>& transmitting = schedule_->next();
    if (model_.schedule.active())
    {
      ScheduleStep::Ptr sc = boost::make_shared<ScheduleStep>();
      sc->header.stamp = stamp;
      sc->step = static_cast<std::uint64_t>(s.k);
      sc->transmitting.assign(transmitting.begin(), transmitting.end());
      schedule_pub_.publish(sc);
    }
    for (std::size_t i = 0; i < model_.sensors.size(); ++i)
    {
      if (transmitting[i] && outputs_.sensors[i].dueAt(s.k))  // else nothing is sent (not a loss)
        sensors_.publish(i, stamp, s.k, s);
    }
    publishState(stamp, s.k, s.x, s.nu && model_.hasControl());
  }

  void publishState(const ros::Time& stamp, long k, const Eigen::VectorXd& x, bool applied)
  {
    PlantState::Ptr st = boost::make_shared<PlantState>();
    st->header.stamp = stamp;
    st->header.frame_id = frame_id_;
    st->step = static_cast<std::uint64_t>(k);
    st->x.assign(x.data(), x.data() + x.size());
    st->command_applied = applied;
    state_pub_.publish(st);
    if (publish_tf_ && (stamp - last_tf_).toSec() >= 0.02)  // at most 50 Hz: tf is for viewing
    {
      last_tf_ = stamp;
      geometry_msgs::TransformStamped t;
      t.header.stamp = stamp;
      t.header.frame_id = frame_id_;
      t.child_frame_id = child_frame_id_;
      double* xyz[3] = {&t.transform.translation.x, &t.transform.translation.y, &t.transform.translation.z};
      for (std::size_t i = 0; i < positions_.size(); ++i)
        *xyz[i] = x(positions_[i]);
      t.transform.rotation.w = 1.0;
      tf_.sendTransform(t);
    }
  }

  Model model_;
  std::uint64_t seed_ = 0;
  double period_ = 0.0;
  long max_steps_ = 0;
  std::string frame_id_, child_frame_id_;
  std::vector<int> positions_;
  bool publish_tf_ = true, publish_clock_ = false;
  double time_scale_ = 1.0, start_delay_ = 1.0, tail_left_ = 1.0;
  std::string start_after_;
  bool start_scheduled_ = false;
  ros::Subscriber start_sub_;
  std::unique_ptr<PlantSimulator> sim_;
  std::unique_ptr<ScheduleSampler> schedule_;
  ros::Publisher schedule_pub_;
  SimulatorOutputs outputs_;
  std::unique_ptr<LocalEnu> datum_;
  SimulatedSensors sensors_;
  ros::Publisher state_pub_, clock_pub_;
  ros::Subscriber cmd_sub_;
  ros::Timer ros_timer_;
  std::thread stepper_;  ///< wall time: the stepping thread (stepOnWallClock)
  std::atomic<bool> quit_{false};
  ros::WallTimer wall_timer_, start_timer_;
  tf2_ros::TransformBroadcaster tf_;
  ros::Time sim_now_, last_tf_;
  std::mutex mutex_;
  std::map<long, Eigen::VectorXd> commands_;
  long k_ = 0;
  bool started_ = false, finished_ = false, stopped_ = false;  // stopped_: beyond the rounding floor
  std::uint64_t applied_ = 0, late_commands_ = 0;
};

}  // namespace networked_estimation

PLUGINLIB_EXPORT_CLASS(networked_estimation::PlantSimulatorNodelet, nodelet::Nodelet)
