// What the Estimator publishes (estimator_outputs.hpp).
#include "estimator_outputs.hpp"

#include "networked_estimation/common/error.hpp"
#include "networked_estimation/estimators/estimator.hpp"
#include "odometry_output.hpp"

#include <limits>

namespace networked_estimation
{

Estimate::Ptr estimateMessage(const StepEstimate& e, const std::string& frame_id, Algorithm algorithm)
{
  Estimate::Ptr m = boost::make_shared<Estimate>();
  m->header.stamp = e.stamp;
  m->header.frame_id = frame_id;
  m->step = e.step;
  m->algorithm = toString(algorithm);
  m->gamma = e.gamma;
  const Eigen::Index n = e.x.size();
  m->state.assign(e.x.data(), e.x.data() + n);
  m->covariance.resize(static_cast<std::size_t>(n * n));
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index j = 0; j < n; ++j)
      m->covariance[static_cast<std::size_t>(i * n + j)] = e.P(i, j);  // row-major (REP-103)
  m->covariance_trace = e.trace;
  m->covariance_is_pseudo = algorithm == Algorithm::RSEIO;
  m->command_arrival_probability = e.command_arrival_probability;
  return m;
}

geometry_msgs::PoseWithCovarianceStamped::Ptr poseMessage(const StepEstimate& e, const std::vector<int>& positions,
                                                          const std::string& frame_id)
{
  geometry_msgs::PoseWithCovarianceStamped::Ptr p = boost::make_shared<geometry_msgs::PoseWithCovarianceStamped>();
  p->header.stamp = e.stamp;
  p->header.frame_id = frame_id;
  double* xyz[3] = {&p->pose.pose.position.x, &p->pose.pose.position.y, &p->pose.pose.position.z};
  for (std::size_t i = 0; i < positions.size() && i < 3; ++i)
    *xyz[i] = e.x(positions[i]);
  p->pose.pose.orientation.w = 1.0;
  // 6x6 row-major (x y z roll pitch yaw): the position block from P; axes that are not
  // estimated get a large variance rather than a false certainty.
  for (int i = 0; i < 6; ++i)
    p->pose.covariance[static_cast<std::size_t>(i * 6 + i)] = kUnmappedVariance;
  for (std::size_t a = 0; a < positions.size() && a < 3; ++a)
    for (std::size_t b = 0; b < positions.size() && b < 3; ++b)
      p->pose.covariance[a * 6 + b] = e.P(positions[a], positions[b]);
  return p;
}

void EstimatorOutputs::start(ros::NodeHandle& nh, const EstimatorNodeConfig& config, const std::string& name,
                             std::function<const Frames&()> frames, GnssAligner* gnss, std::function<void()> wake)
{
  config_ = &config;
  name_ = name;
  frames_ = std::move(frames);
  gnss_ = gnss;
  wake_ = std::move(wake);
  estimate_pub_ = nh.advertise<Estimate>("estimate", 1000);
  trace_pub_ = nh.advertise<std_msgs::Float64>("covariance_trace", 1000);
  pose_pub_ = nh.advertise<geometry_msgs::PoseWithCovarianceStamped>("pose", 100);
  odom_pub_ = nh.advertise<nav_msgs::Odometry>("odometry/filtered", 100);
  if (config.publish_tf)
  {
    if (config.child_frame_id == config.base_link_frame)
    {
      frames_();  // listen to tf from the start: base_link's parent decides what we publish
      // With the message event (a plain callback would lose the publisher's name).
      for (const bool static_tf : {false, true})
      {
        ros::SubscribeOptions o;
        o.initByFullCallbackType<const ros::MessageEvent<tf2_msgs::TFMessage const>&>(
            static_tf ? "/tf_static" : "/tf", 100,
            [this, static_tf](const ros::MessageEvent<tf2_msgs::TFMessage const>& e) { onTf(e, static_tf); });
        o.callback_queue = &tf_queue_;
        (static_tf ? tf_static_sub_ : tf_sub_) = nh.subscribe(o);
      }
    }
    tf_pub_ = nh.advertise<tf2_msgs::TFMessage>("/tf", 100);
  }
  inRoscppPollThread();  // learnt now, where no roscpp lock is held
  poll_turn_ = ros::PollManager::instance()->addPollThreadListener([this] { onPollTurn(); });
  if (config.predict_to_current_time)
  {
    predict_timer_ = nh.createWallTimer(ros::WallDuration(1.0 / config.frequency),
                                        [this](const ros::WallTimerEvent&) { predictTimer(); });
    ROS_INFO_NAMED(name_,
                   "Estimator: odometry/filtered%s at %g Hz, predicted to the current time "
                   "(predict_to_current_time)",
                   config.publish_tf ? " and tf" : "", config.frequency);
  }
}

void EstimatorOutputs::stop()
{
  // Waits for a turn in progress (roscpp calls its listeners under its own lock).
  ros::PollManager::instance()->removePollThreadListener(poll_turn_);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopped_ = true;
  }
  tf_sub_.shutdown();
  tf_static_sub_.shutdown();
}

void EstimatorOutputs::queueStep(StepEstimatePtr e)
{
  bool first = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopped_)
      return;
    first = queued_.empty();
    queued_.push_back(std::move(e));
    queued_any_.store(true, std::memory_order_release);
  }
  // In roscpp's receive thread, onPollTurn() publishes it when the thread's turn ends.
  if (first && wake_ && !inRoscppPollThread())
    wake_();
}

void EstimatorOutputs::flush()
{
  std::lock_guard<std::mutex> order(flush_mutex_);  // one publisher at a time: step order
  {
    std::lock_guard<std::mutex> lock(mutex_);
    queued_any_.store(false, std::memory_order_relaxed);
    if (queued_.empty())
      return;
    flushing_.swap(queued_);  // both keep their capacity: no allocation per step
  }
  for (const StepEstimatePtr& e : flushing_)
    publishStep(e);
  flushing_.clear();
}

void EstimatorOutputs::onPollTurn()
{
  if (queued_any_.load(std::memory_order_acquire))
    flush();
  if (tf_waiting_.load(std::memory_order_acquire))
    tfWork();
}

void EstimatorOutputs::publishStep(const StepEstimatePtr& e)
{
  const EstimatorNodeConfig& c = *config_;
  if (estimate_pub_.getNumSubscribers() > 0)
    estimate_pub_.publish(estimateMessage(*e, c.frame_id, c.settings.algorithm));
  if (trace_pub_.getNumSubscribers() > 0)
  {
    std_msgs::Float64::Ptr t = boost::make_shared<std_msgs::Float64>();
    t->data = e->trace;
    trace_pub_.publish(t);
  }
  if (c.predict_to_current_time)
  {
    std::lock_guard<std::mutex> lock(mutex_);
    last_step_ = e;  // odometry/filtered and tf come from predictTimer()
  }
  else
  {
    if (odom_pub_.getNumSubscribers() > 0)
      publishOdometry(*e);
    if (c.publish_tf)
      offerTf(e);  // tf leaves from tfWork(), at most 20 times a second, not with every step
  }
  if (gnss_ && gnss_->wantsFiltered())
    publishFilteredGps(*e);
  if (pose_pub_.getNumSubscribers() > 0)
    pose_pub_.publish(poseMessage(*e, c.position_indices, c.frame_id));
}

void EstimatorOutputs::publishOdometry(const StepEstimate& e)
{
  const EstimatorNodeConfig& c = *config_;
  // Shared: an intra-process subscriber (a nodelet) gets it without serialization.
  odom_pub_.publish(boost::make_shared<const nav_msgs::Odometry>(
      toOdometry(e.x, e.P, c.state_map, e.stamp, c.world_frame, c.base_link_frame)));
}

void EstimatorOutputs::publishFilteredGps(const StepEstimate& e)
{
  const EstimatorNodeConfig& c = *config_;
  const int xyz[3] = {c.state_map.x, c.state_map.y, c.state_map.z};
  Eigen::Matrix3d Pw = Eigen::Matrix3d::Zero();
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b)
      Pw(a, b) = xyz[a] >= 0 && xyz[b] >= 0 ? e.P(xyz[a], xyz[b]) : (a == b ? kUnmappedVariance : 0.0);
  gnss_->publishFiltered(basePoseOf(e.x, c.state_map, c.gnss.roll, c.gnss.pitch), Pw, e.stamp);
}

void EstimatorOutputs::offerTf(const StepEstimatePtr& e)
{
  {
    std::lock_guard<std::mutex> lock(mutex_);
    last_tf_estimate_ = e;
    tf_waiting_.store(true, std::memory_order_release);
    if (stopped_)
      return;
  }
  if (wake_ && !inRoscppPollThread())  // there, onPollTurn() sends it
    wake_();
}

double EstimatorOutputs::tfWork()
{
  if (!config_ || !config_->publish_tf)
    return std::numeric_limits<double>::infinity();
  StepEstimatePtr e;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    // Nothing new (no input, a stopped clock): no wait at all, rather than waking the input thread
    // 20 times a second for nothing.
    if (stopped_ || !last_tf_estimate_ || last_tf_estimate_->stamp == last_tf_)
    {
      tf_waiting_.store(false, std::memory_order_relaxed);
      return std::numeric_limits<double>::infinity();
    }
    const auto now = std::chrono::steady_clock::now();
    const double since = std::chrono::duration<double>(now - last_tf_sent_).count();
    if (since < kTfPeriod)
      return kTfPeriod - since;
    last_tf_sent_ = now;
    e = last_tf_estimate_;
    last_tf_ = e->stamp;
    tf_waiting_.store(false, std::memory_order_relaxed);
  }
  sendTfOf(*e);
  return std::numeric_limits<double>::infinity();
}

void EstimatorOutputs::predictTimer()
{
  const EstimatorNodeConfig& c = *config_;
  StepEstimatePtr step;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    step = last_step_;
  }
  const ros::Time now = ros::Time::now();
  if (!step || now == last_predicted_ || now < step->stamp)
    return;  // no step yet, a stopped clock, or time went back (the stream restarts)
  auto e = std::make_shared<StepEstimate>(*step);
  try
  {
    e->stamp = step->stamp + ros::Duration(predictAhead(c.model, c.period, step->x, step->P,
                                                        (now - step->stamp).toSec(), e->x, e->P));
  }
  catch (const InputError& err)
  {
    ROS_WARN_THROTTLE_NAMED(10.0, name_, "Estimator: predict_to_current_time: not predicted from step %lu: %s",
                            static_cast<unsigned long>(step->step), err.what());
    return;
  }
  last_predicted_ = now;
  e->trace = e->P.trace();
  if (odom_pub_.getNumSubscribers() > 0)
    publishOdometry(*e);
  if (c.publish_tf)
    offerTf(e);
}

geometry_msgs::TransformStamped EstimatorOutputs::positionTransform(const StepEstimate& e) const
{
  const EstimatorNodeConfig& c = *config_;
  geometry_msgs::TransformStamped t;
  t.header.stamp = e.stamp;
  t.header.frame_id = c.frame_id;
  t.child_frame_id = c.child_frame_id;
  double* xyz[3] = {&t.transform.translation.x, &t.transform.translation.y, &t.transform.translation.z};
  for (std::size_t i = 0; i < c.position_indices.size() && i < 3; ++i)
    *xyz[i] = e.x(c.position_indices[i]);
  t.transform.rotation.w = 1.0;
  return t;
}

void EstimatorOutputs::sendTfOf(const StepEstimate& e)
{
  const EstimatorNodeConfig& c = *config_;
  geometry_msgs::TransformStamped t = positionTransform(e);
  if (c.child_frame_id != c.base_link_frame)
  {
    sendTf(t);  // the estimate's own frame: its position entries, no rotation
    return;
  }
  // Driving base_link: its pose from ~state_mapping, and never a second parent.
  std::string parent, publisher;
  {
    std::lock_guard<std::mutex> lock(tf_mutex_);
    parent = foreign_parent_.at(ros::WallTime::now().toSec());
    publisher = foreign_parent_.publisher;
  }
  const TfPlan plan = planTf(c.world_frame, c.odom_frame, c.base_link_frame, c.child_frame_id, parent, publisher,
                             ros::this_node::getName());
  if (plan.kind == TfPlan::Kind::NONE)
  {
    ROS_WARN_THROTTLE_NAMED(10.0, name_, "Estimator: no tf: %s", plan.reason.c_str());
    return;
  }
  const geometry_msgs::Pose p = poseOf(e.x, c.state_map);
  tf2::Transform world_base(tf2::Quaternion(p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w),
                            tf2::Vector3(p.position.x, p.position.y, p.position.z));
  t.header.frame_id = c.world_frame;
  if (plan.kind == TfPlan::Kind::MAP_TO_ODOM)
  {
    tf2::Transform odom_base;
    std::string why;
    if (!frames_().lookup(c.odom_frame, c.base_link_frame, ros::Time(0), odom_base, why))
    {
      ROS_WARN_THROTTLE_NAMED(10.0, name_, "Estimator: no %s -> %s tf: %s", c.world_frame.c_str(), c.odom_frame.c_str(),
                              why.c_str());
      return;
    }
    world_base = mapToOdom(world_base, odom_base);
    t.child_frame_id = c.odom_frame;
  }
  const tf2::Vector3& v = world_base.getOrigin();
  const tf2::Quaternion q = world_base.getRotation();
  t.transform.translation.x = v.x();
  t.transform.translation.y = v.y();
  t.transform.translation.z = v.z();
  t.transform.rotation.x = q.x();
  t.transform.rotation.y = q.y();
  t.transform.rotation.z = q.z();
  t.transform.rotation.w = q.w();
  {
    std::lock_guard<std::mutex> lock(tf_mutex_);
    own_tf_.sent(t);  // before it can come back on /tf
  }
  sendTf(t);
}

void EstimatorOutputs::sendTf(const geometry_msgs::TransformStamped& t)
{
  tf2_msgs::TFMessage::Ptr m = boost::make_shared<tf2_msgs::TFMessage>();
  m->transforms.push_back(t);
  tf_pub_.publish(m);
}

void EstimatorOutputs::onTf(const ros::MessageEvent<tf2_msgs::TFMessage const>& e, bool static_tf)
{
  const double now = ros::WallTime::now().toSec();
  std::lock_guard<std::mutex> lock(tf_mutex_);
  for (const geometry_msgs::TransformStamped& t : e.getConstMessage()->transforms)
    foreign_parent_.saw(t, config_->base_link_frame, own_tf_, e.getPublisherName(), now, static_tf);
}

}  // namespace networked_estimation
