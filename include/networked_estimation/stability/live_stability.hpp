// Everything the Estimator's live `link stability` diagnostic knows, ROS-free: one arrival window
// per sensor and the joint verdict (JointLinkMonitor), the critical rates of a single i.i.d.
// sensor, Gan and Liu's excitation evidence per scalar sensor, and their Theorem 1 checked along
// the filter's own covariances (kfio on one scalar sensor with late data dropped). The nodelet
// feeds it after every filter step and copies it (cheap) to evaluate outside its lock.
#pragma once

#include <Eigen/Dense>

#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "networked_estimation/config/estimator_settings.hpp"
#include "networked_estimation/config/model.hpp"
#include "networked_estimation/stability/excitation.hpp"
#include "networked_estimation/stability/joint_link_monitor.hpp"
#include "networked_estimation/stability/link_monitor.hpp"

namespace networked_estimation
{

struct LiveStabilityOptions
{
  std::size_t window = 1000;
  bool markov = false;  ///< estimate on/off Gilbert-Elliott links (p, r) instead of i.i.d. rates
  std::size_t min_samples = 100;
  bool late_data_dropped = true;  ///< Theorem 1 is checked only on the sequence the filter ran
  /// Reuse the last evaluation while nothing it depends on changed: the whole report when no step was
  /// added since, the verdicts and margins when the estimated links are the same (off: every
  /// evaluation from scratch, for benchmarks).
  bool cache = true;
};

/// One sensor's link as numbers: the values the diagnostic's strings are written from (the
/// Estimator's ~link_status message carries them, networked_estimation/LinkStatus).
struct SensorLinkFigures
{
  std::string sensor;
  RateEstimate arrival;   ///< P(arrived) over the sensor's window
  RateEstimate failure;   ///< Gilbert-Elliott p: P(lost | arrived before)
  RateEstimate recovery;  ///< Gilbert-Elliott r: P(arrived | lost before)
  /// What the sensor's rate needs ("<sensor> needs" in the diagnostic) and its margin (the rate
  /// minus what it needs; SensorMargin::margin): empty and NaN until every sensor has samples.
  std::string needs;
  double margin = std::numeric_limits<double>::quiet_NaN();
};

struct LiveStabilityReport
{
  LinkCondition status;
  std::vector<std::pair<std::string, std::string>> values;  ///< the diagnostic's key-value pairs
  std::vector<SensorLinkFigures> sensors;                   ///< per sensor of the model, in its order
};

class LiveStability
{
public:
  /// Keeps its own copy of the model (shared with its copies).
  LiveStability(const Model& model, const EstimatorSettings& settings, const LiveStabilityOptions& options);

  /// After a filter step: which sensors arrived, gamma, the filtered covariance P_{k|k}, and
  /// whether the filter restarted from its prior at this step (a covariance overflow).
  void add(const std::vector<bool>& arrived, bool gamma, const Eigen::MatrixXd& P, bool restarted);
  /// The same for a model with a sensor schedule: due[s] = sensor s was scheduled at this step.
  /// A sensor that was not due enters no window (it is not a loss).
  void add(const std::vector<bool>& arrived, const std::vector<bool>& due, bool gamma, const Eigen::MatrixXd& P,
           bool restarted);
  /// Time went back: start over.
  void clear();
  /// The status and its key-values (three joint stability tests and the Gan-Liu evidence). What
  /// depends on the model alone was computed at construction; with options.cache, an evaluation
  /// with nothing new since the last one (of this object or a copy) costs a copy of the report.
  LiveStabilityReport evaluate() const;

  /// A built-in motion's verdicts along the estimate (docs/stability.md 5): this object's windows
  /// and counts with everything that depends on the model computed for `local`, the motion
  /// linearised at the current estimate (the same sensors), and a cache of its own. Costs what the
  /// constructor costs (about a millisecond at n = 15, 4 sensors): call it off the filter's thread.
  LiveStability relinearised(const Model& local) const;
  /// The windows and counts of `from` (of a model with the same sensors and the same options, e.g.
  /// the object the filter feeds) in place of this one's; what depends on the model stays this
  /// one's. Cheap: a copy of the windows. Throws std::invalid_argument when the sensors differ.
  void takeWindows(const LiveStability& from);
  /// The model the verdicts are for.
  const Model& model() const { return *model_; }

private:
  struct Cache;
  Eigen::MatrixXd predictedFromPrior() const;
  void addTheorem1(bool gamma, const Eigen::MatrixXd& P, bool restarted);

  std::shared_ptr<const Model> model_;  ///< (joint_ refers to it: declared first)
  EstimatorSettings settings_;
  LiveStabilityOptions options_;
  JointLinkMonitor joint_;
  Eigen::MatrixXd Qn_;                        ///< B Q B'
  std::optional<LinkThresholds> thresholds_;  ///< a single i.i.d. sensor: its critical rates
  std::optional<Theorem1Monitor> theorem1_;
  std::string theorem1_note_;
  std::uint64_t generation_ = 0;        ///< steps added and clears so far: the windows' version
  std::uint64_t epoch_ = 0;             ///< clears so far (sample counts restart)
  std::vector<std::uint64_t> samples_;  ///< per sensor: samples entered in its window since the last clear
  /// Per scalar sensor: Gan and Liu's blocks (null for other sensors).
  std::vector<std::shared_ptr<const GanLiuBlocks>> gan_liu_;
  std::shared_ptr<Cache> cache_;  ///< the last evaluation, shared with copies
};

}  // namespace networked_estimation
