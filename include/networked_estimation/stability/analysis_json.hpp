// What `analyze --json` and `analyze --design --json` print, as text, for the tool and the Python
// module alike (docs/formats.md, "analyze --json"): one writer, so both say the same.
#pragma once

#include <Eigen/Dense>
#include <string>
#include <vector>

#include "networked_estimation/config/model.hpp"
#include "networked_estimation/stability/excitation.hpp"
#include "networked_estimation/stability/link_design.hpp"
#include "networked_estimation/stability/stability.hpp"

namespace networked_estimation
{

/// A critical rate of +infinity: no rate keeps E[P] bounded (JSON has no number for it: null, and
/// the set says unbounded_at_every_rate).
bool unboundedAtEveryRate(double rate);

/// The model the verdicts concern: a linear model itself; a built-in motion's linearisation at `at`
/// (nullptr: its x0) over its period, with `local_note` saying so (a local verdict; `at_label` names
/// where the state came from, e.g. "--at"). `local_note` is empty for a linear model. Throws
/// ConfigError when `at` is given for a linear model, or (linearisedModel's) is not a finite state.
Model analysedModel(const Model& loaded, const Eigen::VectorXd* at, const std::string& at_label,
                    std::string& local_note);

/// Gan and Liu's evidence for one sensor's recorded arrivals (a scalar output only).
struct TraceEvidence
{
  std::string sensor;
  std::size_t samples = 0;
  bool applicable = false;
  std::string reason;  ///< why not applicable
  ExcitationReport report;
};

/// The evidence of recorded arrival patterns, one per sensor that has arrivals in `traces` (each
/// `labels[i]` names traces[i] in messages), blocks of h. Throws InputError when two traces give
/// the same sensor.
std::vector<TraceEvidence> traceEvidence(const Model& model, const std::vector<std::vector<std::vector<bool>>>& traces,
                                         const std::vector<std::string>& labels, int h);

/// analyze --json: the report, each sensor's link origin (`origins`, one per sensor, may be
/// empty) and the trace evidence.
std::string analysisJson(const StabilityReport& report, const std::vector<std::string>& origins,
                         const std::vector<TraceEvidence>& traces);

/// analyze --verdict-only --json: the verdict of all sensors, the links' verdict, the dead-reckoned
/// states and per sensor its link and the rate it needs (each sensor's link origin in `origins`).
std::string verdictJson(const std::string& model_name, const VerdictReport& report,
                        const std::vector<std::string>& origins);

/// analyze --design --json: the model, the cost ("total_rate" or "capacity") and cap, and per
/// sensor its least-cost rate and its least rate alone.
std::string designJson(const Model& model, const LinkDesign& design, const std::string& cost);

}  // namespace networked_estimation
