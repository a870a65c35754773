// Stability analysis of Kalman filtering over lossy links (docs/stability.md; Lin et al., Theorem 5;
// Zhou, Theorem 5): critical arrival rates, the MARE upper bound with its certificate, the
// exact test of Marelli et al. (Theorem 14 with Proposition 24 / Corollary 26) where it is
// computable, the Markov (Gilbert-Elliott) threshold on the recovery rate, and the RSEIO
// convergence checklist. ROS-free.
//
// Every test returns a Verdict (stable / unstable / undecided / not applicable) with the reason and
// the numbers behind it; an input that violates an assumption of a test gives "not applicable".
//
// Conventions: the process noise covariance is B Q B' (n x n); a sensor i is whitened as
// H_i = L_i^{-1} C_i with R_i = L_i L_i' (so H_i' H_i = C_i' R_i^{-1} C_i). Each sensor has its own
// link: analyzeStability takes one (optional) channel per sensor, a sensor without one being
// lossless; the single-channel form gives every sensor an independent copy of the one channel (as
// the simulate tool and the nodelets do).
//
// The pieces have headers of their own (verdict, eigen_structure, link_model, exact_test, bounds,
// estimator_theorems); this header includes them all and declares the report (analyzeStability).
#pragma once

#include <Eigen/Dense>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "networked_estimation/config/channel_settings.hpp"
#include "networked_estimation/config/estimator_settings.hpp"
#include "networked_estimation/config/model.hpp"
#include "networked_estimation/config/schedule.hpp"
#include "networked_estimation/stability/bounds.hpp"
#include "networked_estimation/stability/eigen_structure.hpp"
#include "networked_estimation/stability/estimator_theorems.hpp"
#include "networked_estimation/stability/exact_test.hpp"
#include "networked_estimation/stability/link_model.hpp"
#include "networked_estimation/stability/verdict.hpp"

namespace networked_estimation
{

// ---------------------------------------------------------------------------------------------
// Top level

/// An interval of a rate on which the verdict is stable (docs/stability.md 4.3). An edge inside
/// (0, 1) was located by bisection to the tolerance and lies on the stable side of the change; an
/// edge at 0 or 1 is the end of the range.
struct RateInterval
{
  double lower = std::numeric_limits<double>::quiet_NaN();
  double upper = std::numeric_limits<double>::quiet_NaN();
};

/// Results for a set of sensors, each with its own link of the given kind: the whole model, or
/// one sensor alone.
struct RateAnalysis
{
  std::string name;
  std::vector<int> sensors;  ///< indices into Model::sensors
  /// Modes with |lambda| >= 1 that this set does not observe even when every message arrives: they
  /// grow whatever the links do (docs/stability.md 2.2). Empty when there are none. With such modes
  /// no rate keeps E[P] bounded: the thresholds below are +infinity (none), the verdict unstable,
  /// and `observed` holds the same analysis of the observed modes (what the links can change).
  std::string dead_reckoned;
  std::string dead_states;  ///< the states of those modes by name ("x, y"), empty when none
  // i.i.d. arrivals at a common rate lambda on every sensor of the set
  double lower_bound = 0.0;  ///< necessary: 1 - rho^{-2/N} (Yang Theorem 1 / Sinopoli)
  double closed_form_upper =
      std::numeric_limits<double>::quiet_NaN();  ///< N = 1: 1 - 1/M^2; N > 1: Yang Thm 5 common rate
  CriticalBand mare;                             ///< MARE threshold by bisection (NaN fields when A is stable)
  std::string mare_note;                         ///< why the MARE threshold was not computed (empty when it was)
  double exact_rate = std::numeric_limits<double>::quiet_NaN();  ///< Theorem 14, NaN when unavailable
  std::string exact_method;  ///< how exact_rate was obtained, or why it is unavailable
  // on/off Gilbert-Elliott links at a common recovery rate r with the links' failure rate p. When
  // the threshold depends on p and the set has no common Gilbert-Elliott p, none is assumed:
  // recovery_exact is NaN and recovery_note says why.
  double recovery_lower_bound = 0.0;                                 ///< necessary: rho^2 (1 - r)^N < 1
  double recovery_exact = std::numeric_limits<double>::quiet_NaN();  ///< NaN when not a half-line
  std::string recovery_note;  ///< the p used, "independent of p", or why not applicable
  /// The stable set of the common r when it is not a half-line (lattice blocks of order > 1):
  /// intervals found by a scan with bisection at each change (recovery_exact is then NaN).
  std::vector<RateInterval> recovery_stable;
  Verdict aoe_theorem5;  ///< Lin et al.'s Theorem 5 test (one packet = this set of sensors)
  std::vector<BlockStructure> blocks;
  // the given channel
  Verdict verdict;              ///< E[P] bounded? (unstable whenever a mode grows regardless of the links)
  Verdict links_verdict;        ///< the same on the modes the set observes: what the links can change
  std::string margin_quantity;  ///< "arrival rate" or "recovery rate"
  double channel_value = std::numeric_limits<double>::quiet_NaN();         ///< the link's arrival or recovery rate
  double necessary_threshold = std::numeric_limits<double>::quiet_NaN();   ///< below: unbounded
  double sufficient_threshold = std::numeric_limits<double>::quiet_NaN();  ///< above: bounded
  double margin = std::numeric_limits<double>::quiet_NaN();  ///< channel_value - critical (exact, else sufficient)
  /// The stable set of channel_value when it is not a half-line (then the thresholds are NaN and
  /// the margin is the distance to the nearest edge, positive inside).
  std::vector<RateInterval> stable_intervals;
  /// With dead-reckoned modes: this analysis for the observed modes alone (one element), else empty.
  std::vector<RateAnalysis> observed;
};

/// The rate one sensor needs, the other sensors' links fixed (docs/stability.md 4.3): the verdict
/// of the whole set (the same function as the report's verdict) along this sensor's arrival rate
/// (i.i.d. or lossless link) or recovery rate (on/off Gilbert-Elliott link with its own p).
struct SensorMargin
{
  std::string quantity;  ///< "arrival rate" or "recovery rate"; empty when not applicable
  std::string note;      ///< how the rate was found, or why there is none ("not applicable: ...")
  double value = std::numeric_limits<double>::quiet_NaN();  ///< this sensor's rate now
  /// The stable set along the rate is an upper half-line [converges_at, 1] (i.i.d. links; on/off
  /// links unless a lattice block of order > 1 is seen by this sensor). Otherwise it was found by a
  /// scan and is given as `stable` intervals, never as one threshold.
  bool half_line = true;
  /// half_line: unstable at and below diverges_at (NaN: no rate found unstable), stable at and above
  /// converges_at (NaN: not stable even at rate 1); undecided_band when undecided rates lie between.
  CriticalBand band;
  std::vector<RateInterval> stable;  ///< the stable set found (half_line: [converges_at, 1] or empty)
  int scan_points = 0;               ///< not half_line: grid points of the scan on [0, 1]
  /// half_line: value - converges_at. Otherwise the distance from value to the nearest edge of the
  /// stable set: positive inside a stable interval, negative outside.
  double margin = std::numeric_limits<double>::quiet_NaN();
  /// Stable at every positive rate and unstable at 0 (a mode on the unit circle that only this link
  /// covers): "needs > 0". The band is then [0, 0] and the margin the rate itself.
  bool any_positive = false;
  /// Modes that no sensor observes grow whatever the links do (docs/stability.md 2.2): the states
  /// they involve ("x, y"), empty when there are none. Then no rate keeps E[P] bounded (the band is
  /// "unstable at 1", converges_at NaN) and what the observed modes alone need is
  /// converges_at_observed (NaN when their stable set is not a half-line or there is none).
  std::string grows_regardless;
  double converges_at_observed = std::numeric_limits<double>::quiet_NaN();
};

/// One sensor's link and what it needs.
struct SensorLinkReport
{
  std::string sensor;
  bool lossless = false;  ///< no channel: an i.i.d. link with arrival 1
  LinkModel link;
  double arrival_rate = 1.0;
  double recovery_rate = std::numeric_limits<double>::quiet_NaN();
  double capacity = std::numeric_limits<double>::infinity();  ///< c_i = -1/2 ln(1 - arrival rate)
  SensorMargin margin;  ///< in the set of all sensors, the others' links fixed (only with per_sensor)
  /// The Markov (recovery-rate) threshold for this sensor: its margin when it has an on/off
  /// Gilbert-Elliott link; "not applicable: ..." otherwise (no failure rate p is assumed).
  std::string markov_note;
};

struct StabilityReport
{
  std::string model_name;
  Eigen::VectorXcd eigenvalues;
  double spectral_radius = 0.0, mahler_measure = 1.0, entropy = 0.0, log_abs_det = 0.0;
  bool diagonalizable = true;
  Verdict strong_observability;              ///< of (A, C) (all sensors stacked)
  bool noise_excites_unstable_modes = true;  ///< PBH: (A, B Q^1/2) controllable on every |lambda| >= 1
  bool detectable = true;                    ///< PBH: (C, A) observable on every |lambda| >= 1
  /// The modes with |lambda| >= 1 that no sensor observes even when every message arrives (not
  /// detectable): they grow whatever the links do, and the link verdicts, thresholds, capacities and
  /// MARE concern the observed modes (docs/stability.md 2.2). Empty when there are none.
  std::string dead_reckoned;
  std::string dead_states;    ///< the states of those modes by name ("x, y"), empty when none
  bool has_channel = false;   ///< some sensor has a channel
  bool uniform_links = true;  ///< every sensor has the same link (then `link` is that link)
  LinkModel link;             ///< the channel of every sensor (uniform_links), else of sensor 0
  double arrival_rate = std::numeric_limits<double>::quiet_NaN();
  double recovery_rate = std::numeric_limits<double>::quiet_NaN();
  Capacity capacity;  ///< for each sensor's stationary arrival rate (lossless: 1, c_i = inf)
  /// What the capacity implies for this rate vector (Yang et al., Theorems 2 and 6).
  std::string capacity_note;
  /// Yang et al.'s MARE upper bound at this rate vector (every sensor at its own i.i.d. rate):
  /// "converges" (E[P] bounded, Theorem 4, with the fixed point's trace as a bound on the limit of
  /// E[P_k|k-1]), "diverges" or "undecided" (which prove nothing), or "not applicable: ...".
  std::string mare_at_rates = "not applicable: no channel given";
  double mare_at_rates_trace = std::numeric_limits<double>::quiet_NaN();
  double mare_at_rates_certificate = std::numeric_limits<double>::quiet_NaN();
  std::vector<SensorLinkReport> links;  ///< per sensor (empty without any channel)
  EntropySplit entropy_split;           ///< of the observed modes (not computed, default, when they are stable)
  RateAnalysis model;                   ///< all sensors
  std::vector<RateAnalysis> sensors;    ///< each sensor alone (empty when options.per_sensor is false)
  Verdict rseio;                        ///< Zhou's Theorem 5 (NOT_APPLICABLE unless the estimator is rseio)
  std::string estimator;                ///< the estimator analysed (kfio without settings)
  std::string estimator_note;           ///< how the verdicts relate to that estimator
};

struct AnalysisOptions
{
  bool per_sensor = true;  ///< each sensor alone (StabilityReport::sensors) and each sensor's margin
  /// Fall back on the MARE upper bound when Theorem 14 cannot decide (off: such a verdict is
  /// undecided at once; the live diagnostic, which evaluates every second, turns it off).
  bool use_mare = true;
  double bisection_tolerance = 1e-4;  ///< MARE bisections (and margins decided by the MARE)
  double exact_tolerance = 1e-7;      ///< margins and intervals decided by Theorem 14
  int scan_points = 200;              ///< scan of a rate whose stable set is not a half-line
  std::size_t lattice_cap = 512;      ///< kernel lattices larger than this are not computed (UNAVAILABLE)
  /// The MARE's bisections and its bound at the rates are computed for sets of up to this many
  /// (observed) states: each MARE solve costs up to max_iterations steps of O(n^3), seconds beyond
  /// it. Larger sets report "not computed" there; a verdict that needs the MARE (Theorem 14 cannot
  /// decide) still computes it.
  int mare_max_states = 30;
  MareOptions mare;
  StabilityTolerances tol;
};

/// Analyses the model with one link per sensor (links[i] for model.sensors[i]; none = lossless, an
/// i.i.d. link with arrival 1) and the estimator (nullable: kfio). When no sensor has a link the
/// report holds the thresholds only (verdicts "not applicable: no channel given").
StabilityReport analyzeStability(const Model& model, const std::vector<std::optional<ChannelSettings>>& links,
                                 const EstimatorSettings* estimator = nullptr, const AnalysisOptions& options = {});

/// The same with an independent copy of one channel on every sensor (nullable: thresholds only).
StabilityReport analyzeStability(const Model& model, const ChannelSettings* sensor_link,
                                 const EstimatorSettings* estimator = nullptr, const AnalysisOptions& options = {});

/// The verdict of all the model's sensors and the rate each sensor needs, without the rest of the
/// report (analyze --verdict-only, Python verdict()): the same numbers as analyzeStability's
/// model.verdict, model.links_verdict and links[i].margin, at a fraction of its cost.
struct VerdictReport
{
  Verdict verdict;                         ///< E[P] bounded? (docs/stability.md 2.1)
  Verdict links_verdict;                   ///< on the modes the sensors observe: what the links can change
  std::string dead_reckoned, dead_states;  ///< as StabilityReport's (empty when none)
  bool has_channel = false;                ///< some sensor has a channel (else margins are empty)
  std::vector<SensorLinkReport> links;     ///< per sensor: its link and the rate it needs (margin)
};

/// One link per sensor (links[i] for model.sensors[i]; none = lossless), as analyzeStability.
VerdictReport verdictOnly(const Model& model, const std::vector<std::optional<ChannelSettings>>& links,
                          const AnalysisOptions& options = {});

/// For every sensor of the model with these links (one per sensor): the rate it needs, the other
/// sensors' links fixed (the report's per-sensor margins, computed the same way).
std::vector<SensorMargin> sensorMargins(const Model& model, const std::vector<LinkModel>& links,
                                        const AnalysisOptions& options = {});

/// The verdicts of one set of the model's sensors (indices into Model::sensors) for any links, with
/// what depends on the model alone (its observed part, the blocks and their kernel lattices)
/// computed once at construction: the live diagnostic evaluates it for new link estimates every
/// second. Copies share that state.
class SetVerdicts
{
public:
  SetVerdicts(const Model& model, const std::vector<int>& set, const AnalysisOptions& options = {});
  /// stabilityVerdict(model, set, links, options), links one per member of the set.
  Verdict verdict(const std::vector<LinkModel>& links) const;
  /// The links' verdict: the same on the modes the set observes (what the links can change).
  Verdict linksVerdict(const std::vector<LinkModel>& links) const;
  /// The verdict given the links' verdict (e.g. "not applicable: no channel given").
  Verdict verdictGiven(const Verdict& links_verdict) const;
  /// Both at once (the links' verdict is computed once): {verdict, links verdict}.
  std::pair<Verdict, Verdict> verdicts(const std::vector<LinkModel>& links) const;
  /// sensorMargins(model, links, options); the set must be every sensor of the model. links_only:
  /// what the links' verdict needs (the observed modes), also with dead-reckoned modes.
  std::vector<SensorMargin> margins(const std::vector<LinkModel>& links, bool links_only = false) const;
  /// The modes with |lambda| >= 1 that the set does not observe even when every message arrives
  /// (they grow whatever the links do; docs/stability.md 2.2), described; empty when there are none.
  const std::string& deadReckoned() const;
  /// The states of those modes by name ("x, y"; "states 0, 1" without names), empty when none.
  const std::string& deadStates() const;
  /// Theorem 14 decides every block (no fallback on the bounds is needed).
  bool exact() const;
  /// The FMO blocks with |alpha| >= 1 of the observed modes, with their kernel lattices (for the
  /// whitened sensors of the set).
  const std::vector<BlockStructure>& blocks() const;

private:
  struct Impl;
  std::shared_ptr<const Impl> impl_;
};

/// The verdict of docs/stability.md 2.1 for the model's sensors `set` with links (one per sensor of
/// the set): the function that analyzeStability and the per-sensor margins use.
Verdict stabilityVerdict(const Model& model, const std::vector<int>& set, const std::vector<LinkModel>& links,
                         const AnalysisOptions& options = {});

}  // namespace networked_estimation
