// analyze's text report (the tool prints it without --json): the same report as analysisJson and
// verdictJson (analysis_json.hpp) in words, one writer for the tool and whoever else prints it.
#pragma once

#include <string>
#include <vector>

#include "networked_estimation/config/model.hpp"
#include "networked_estimation/config/sensor_links.hpp"
#include "networked_estimation/stability/analysis_json.hpp"
#include "networked_estimation/stability/link_design.hpp"
#include "networked_estimation/stability/stability.hpp"

namespace networked_estimation
{

/// analyze: the model (n, sensors, eigenvalues, rho(A), schedule), the links (`links`' own
/// description, rates, capacity), the estimator, the verdicts of all sensors and of each alone with
/// their bounds and margins, each sensor's needed rate, and Gan and Liu's evidence of `traces`.
std::string analysisText(const Model& model, const StabilityReport& report, const SensorLinks& links,
                         const std::vector<TraceEvidence>& traces);

/// analyze --verdict-only: the model's name (and `local_note`: a built-in motion's linearisation),
/// the dead-reckoned states, the verdict, the links' verdict and the rate each sensor needs.
std::string verdictText(const std::string& model_name, const std::string& local_note, const VerdictReport& report);

/// analyze --design: the least-cost i.i.d. rates of `design` for the cost ("total_rate" or
/// "capacity"), each sensor's least rate alone, or why no design applies.
std::string designText(const Model& model, const LinkDesign& design, const std::string& cost);

}  // namespace networked_estimation
