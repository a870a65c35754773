// The verdict of a set of sensors for given links (docs/stability.md 2.1), shared by the report
// (stability_report.cpp), the per-sensor margins (sensor_margins.cpp) and stabilityVerdict. Private
// to the core.
#pragma once

#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "networked_estimation/stability/stability.hpp"

namespace networked_estimation
{
namespace stability_internal
{

/// A number with 6 significant digits.
std::string num(double v);

struct Context
{
  const Model* model = nullptr;
  Eigen::MatrixXd Qn;              ///< B Q B'
  Eigen::MatrixXd G;               ///< B Q^1/2
  std::vector<Eigen::MatrixXd> H;  ///< whitened, all sensors
  double rho = 0.0;
  bool excited = true;           ///< unstable modes controllable from the noise
  bool has_channel = false;      ///< some sensor has a channel
  std::vector<FmoBlock> fmo;     ///< fmoBlocks(A) of the model, shared by its sets
  std::vector<LinkModel> links;  ///< per sensor (lossless: i.i.d. with arrival 1)
  std::vector<bool> lossless;
  const AnalysisOptions* options = nullptr;
};

bool sameLink(const LinkModel& a, const LinkModel& b);

/// What the verdict of a set needs besides the links.
struct SetData
{
  std::vector<int> set;
  /// The part of the model the set observes: the model itself when every mode with |lambda| >= 1
  /// is observed (detectable), else its quotient by the unobservable subspace (docs/stability.md
  /// 2.2), in the coordinates z = observed_basis' x.
  Eigen::MatrixXd A, Qn;
  std::vector<Eigen::MatrixXd> H;
  Eigen::MatrixXd Hs;
  double rho = 0.0;
  bool excited = true;  ///< the noise excites every mode of A with |lambda| >= 1
  bool stable_A = false;
  bool detectable = true;          ///< of the model itself (false: the quotient above is used)
  int unobserved = 0;              ///< dimension of the unobservable subspace removed
  Eigen::MatrixXd observed_basis;  ///< n x n_o, empty when nothing was removed
  /// The modes with |lambda| >= 1 that no sensor of the set observes, described ("" when none).
  std::string dead_reckoned;
  /// "2 mode(s) with |lambda| >= 1 (1, 1)": those modes alone.
  std::string dead_modes;
  /// The states those modes involve, by name ("x, y"; "states 0, 1" for a model without names).
  std::string dead_states;
  /// Some of those modes has |lambda| > 1, or the noise excites them: E[P] is unbounded whatever the
  /// links do (false with dead-reckoned modes: every one is on the unit circle and not excited).
  bool dead_grow = false;
  std::vector<BlockStructure> blocks;
  Schedule schedule;  ///< the model's schedule restricted to the set (kind NONE: none)
};

SetData makeSet(const Context& ctx, const std::vector<int>& set);

/// The verdict of docs/stability.md 2.1 for the set with these links (one per member): whether E[P]
/// stays bounded. Dead-reckoned modes make it unstable whatever the links (step 2).
Verdict setVerdict(const Context& ctx, const SetData& d, const std::vector<LinkModel>& links);
/// The links' verdict: steps 3-8 on the modes the set observes, what the links can change.
Verdict linkVerdict(const Context& ctx, const SetData& d, const std::vector<LinkModel>& links);
/// setVerdict given the links' verdict `links_verdict` (already computed for the same links).
Verdict setVerdictFrom(const SetData& d, const Verdict& links_verdict);

/// Every block of the set has Theorem 14's Phi.
bool exactAvailable(const SetData& d);

/// Some lattice block of order > 1 is seen by member j of the set (j < 0: by any member): along a
/// Markov recovery rate the stable set need not be a half-line.
bool latticeOrderAboveOne(const SetData& d, int j);

/// The model's quantities every verdict uses (links are filled in by the caller).
Context modelContext(const Model& model, const AnalysisOptions& options);

// Searches along one rate in [0, 1] (sensor_margins.cpp).
using KindAt = std::function<Verdict::Kind(double)>;
/// The stable set along a rate in [0, 1] known to be an upper half-line.
void halfLine(const KindAt& kind, double tol, SensorMargin& out);
/// The stable set along a rate in [0, 1] by a scan of `points` + 1 grid points and bisection at
/// each change of verdict.
std::vector<RateInterval> scanStable(const KindAt& kind, int points, double tol);
/// Distance from value to the nearest edge of the stable set (edges at 0 or 1 where the set
/// reaches the end of [0, 1] do not count): positive inside an interval, negative outside.
double intervalMargin(const std::vector<RateInterval>& stable, double value);
/// "[a, b], [c, d]" or "none".
std::string intervals(const std::vector<RateInterval>& stable);
/// The rate sensor i needs in the set of all sensors, the others' links (links, one per sensor)
/// fixed: to keep E[P] bounded ("none" with dead-reckoned modes, what the observed modes need then
/// in converges_at_observed), or with links_only what the links' verdict needs (the observed modes).
SensorMargin sensorMargin(const Context& ctx, const SetData& all, const std::vector<LinkModel>& links, int i,
                          bool links_only = false);

}  // namespace stability_internal
}  // namespace networked_estimation
