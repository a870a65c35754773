// Private: the example models of the papers the experiments reproduce.
#pragma once

#include <string>
#include <vector>

#include "networked_estimation/config/model.hpp"

namespace networked_estimation
{
namespace mc
{

/// The model of config/models/<name>.yaml as it was when the core was built (the files of
/// NE_EMBEDDED_MODELS, cmake/embedded_models.cmake). Throws std::logic_error for another NAME.
Model builtInModel(const std::string& name);
/// Zhou's example (Section IV of the paper) with eps ~ U[-delta, delta]: config/models/zhou_example.yaml
/// with its uncertainty's range set to delta.
Model zhouExampleModel(double delta);
/// Lin et al.'s example (their Section 7) with C = [[1, -1], [0, 1]], xbar_0 = 0, P_0 = I:
/// config/models/aoe_example.yaml with A(0, 0) = rhoA.
Model aoeExampleModel(double rhoA);
/// Yang et al.'s Example 1: 8 sensors, R_i = I, x_0 ~ N(0, I).
Model yangExampleModel();
/// The arrival rates of Yang et al.'s Example 1.
const std::vector<double>& yangRates();

}  // namespace mc
}  // namespace networked_estimation
