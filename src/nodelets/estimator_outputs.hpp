// What the Estimator publishes, an owned part of the nodelet: `estimate` (Estimate),
// `covariance_trace`, `pose`, `odometry/filtered`, `gps/filtered` (navsat_transform) and the tf,
// each built by a pure function from one step's estimate as the filter left it (StepEstimate: x
// and P in Eigen, no message in between), and only when someone listens (tf: always).
//
// Threads: the thread that takes a step (roscpp's receive thread for a message from another
// process, the input thread for a deadline or an in-process publisher's message) only queues its
// estimate (queueStep, the filter's lock held). The queue is published in step order (flush, no
// lock held) by the thread that queued it, once out of the lock: roscpp's receive thread at the
// end of its loop's turn (onPollTurn, a roscpp poll-thread listener, outside every subscription's
// lock), the input thread after its work; the same threads send the tf (tfWork). No publish
// happens under the filter's lock: the receive thread takes that lock inside roscpp's delivery
// (ReceiveThreadQueue). The predict_to_current_time timer runs on the nodelet's queue and shares
// only the latest estimate, under this part's own lock.
#pragma once

#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <ros/ros.h>
#include <tf2_msgs/TFMessage.h>

#include <Eigen/Core>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "dispatch_thread.hpp"
#include "frame_transforms.hpp"
#include "gnss_alignment.hpp"
#include "networked_estimation/Estimate.h"
#include "networked_estimation/config/model.hpp"
#include "networked_estimation/online/estimator_node_config.hpp"
#include "tf_output.hpp"

namespace networked_estimation
{

/// One step's estimate, as the filter left it: what every output is built from.
struct StepEstimate
{
  ros::Time stamp;
  std::uint64_t step = 0;
  bool gamma = false;
  Eigen::VectorXd x;  ///< x_{k|k}
  Eigen::MatrixXd P;  ///< P_{k|k} (rseio: its pseudo-covariance)
  double trace = 0.0;
  double command_arrival_probability = -1.0;  ///< -1: the algorithm has none
};
using StepEstimatePtr = std::shared_ptr<const StepEstimate>;

/// The Estimate message of a step (covariance row-major, REP-103).
Estimate::Ptr estimateMessage(const StepEstimate& e, const std::string& frame_id, Algorithm algorithm);
/// The pose of ~position_indices with their block of P; the orientation is identity and the axes
/// not estimated get kUnmappedVariance.
geometry_msgs::PoseWithCovarianceStamped::Ptr poseMessage(const StepEstimate& e, const std::vector<int>& positions,
                                                          const std::string& frame_id);

class EstimatorOutputs
{
public:
  /// `name`: the nodelet's, for the logs; `frames`: base_link's tf lookups (map -> odom, made on
  /// first use); `gnss`: the GNSS alignment or null; `wake`: makes the nodelet's input thread call
  /// tfWork() soon (for an estimate made in another thread). Advertises the topics and starts the
  /// timers.
  void start(ros::NodeHandle& nh, const EstimatorNodeConfig& config, const std::string& name,
             std::function<const Frames&()> frames, GnssAligner* gnss, std::function<void()> wake);
  /// No more tf and no more wake() (before the input thread goes); unsubscribes from /tf (before
  /// the tf buffer goes).
  void stop();

  /// The tf, at most kTfPeriod of wall time apart: sends the latest estimate when it is newer than
  /// the last one sent and that send is kTfPeriod old. The input thread calls it after each batch
  /// of messages; returns the wall seconds until it has something to send (infinity: nothing
  /// waits). No timer: while the inputs flow, the thread is awake anyway.
  double tfWork();
  static constexpr double kTfPeriod = 0.05;

  /// One step's outputs, queued for flush() in step order (the filter's lock held; any thread).
  /// Publishes nothing: wakes the input thread when the queue was empty.
  void queueStep(StepEstimatePtr e);
  /// Publishes the queued steps' outputs in step order (no lock held): the input thread, or
  /// roscpp's receive thread at the end of its turn (onPollTurn).
  void flush();

private:
  /// One step's outputs.
  void publishStep(const StepEstimatePtr& e);
  /// roscpp's receive thread, at every turn of its loop, after the messages it delivered and
  /// outside every subscription's lock (as roscpp's own queued publications): publishes the steps
  /// they completed and sends a tf that is due. Costs two atomic loads when nothing waits.
  void onPollTurn();
  void publishOdometry(const StepEstimate& e);
  void publishFilteredGps(const StepEstimate& e);
  /// The latest estimate for tfWork() (woken when it comes from another thread).
  void offerTf(const StepEstimatePtr& e);
  /// predict_to_current_time: at ~frequency, the last step predicted to ROS time now (predictAhead;
  /// not fed back into the filter) on odometry/filtered and as the tf.
  void predictTimer();
  /// An estimate as the tf (from tfWork()).
  void sendTfOf(const StepEstimate& e);
  geometry_msgs::TransformStamped positionTransform(const StepEstimate& e) const;
  void sendTf(const geometry_msgs::TransformStamped& t);
  /// /tf and /tf_static: base_link's parent from other publishers than ourselves.
  void onTf(const ros::MessageEvent<tf2_msgs::TFMessage const>& e, bool static_tf);

  const EstimatorNodeConfig* config_ = nullptr;
  std::string name_;
  std::function<const Frames&()> frames_;
  GnssAligner* gnss_ = nullptr;
  ros::Publisher estimate_pub_, trace_pub_, pose_pub_, odom_pub_;
  /// /tf, published as a shared message: our own /tf readers (in this process) get it without
  /// serialization, and roscpp's receive thread is not woken unless another process listens
  /// (tf2_ros's broadcaster publishes by reference: serialized every time).
  ros::Publisher tf_pub_;
  /// /tf and /tf_static are read where they arrive (onTf only takes tf_mutex_, under which nothing
  /// is published): our own tf, 20 times a second, costs no hand-off to the manager's threads.
  InlineQueue tf_queue_;
  ros::Subscriber tf_sub_, tf_static_sub_;
  ros::WallTimer predict_timer_;
  std::function<void()> wake_;

  std::mutex flush_mutex_;               ///< held by flush(), the one publisher of the steps at a time
  std::mutex mutex_;                     ///< the six below
  std::vector<StepEstimatePtr> queued_;  ///< steps not yet published (flushing_: flush()'s own)
  std::atomic<bool> queued_any_{false}, tf_waiting_{false};  ///< onPollTurn()'s quick looks
  boost::signals2::connection poll_turn_;
  StepEstimatePtr last_tf_estimate_, last_step_;
  ros::Time last_tf_;  ///< the stamp of the last tf sent
  std::chrono::steady_clock::time_point last_tf_sent_;
  bool stopped_ = false;  ///< stop(): no tf and no wake() any more

  std::vector<StepEstimatePtr> flushing_;
  ros::Time last_predicted_;  ///< predictTimer()'s own
  /// child_frame_id = base_link_frame: the transforms we sent, and base_link's parent from others.
  std::mutex tf_mutex_;
  OwnTransforms own_tf_;
  ForeignParent foreign_parent_;
};

}  // namespace networked_estimation
