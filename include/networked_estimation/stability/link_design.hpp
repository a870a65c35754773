// Link design: "what links do I need for this model?" (docs/stability.md 4.5). For i.i.d. links
// on a model whose unstable blocks Theorem 14 decides, the stable set of arrival rates is exactly a
// polyhedron in u_j = -ln(1 - lambda_j): block k's lattice element K keeps E[P] bounded iff
//
//   sum_j (n_Kj / N_k) u_j > 2 ln |alpha_k|,    n_Kj = the shifts s < N_k at which sensor j sees K
//
// (a single-eigenvalue block: one element, n_Kj / N_k = 1 for every sensor that sees it). With a
// growth cap g < 1 (|alpha_k|^2 Phi_k <= g, a margin) the right-hand side is 2 ln |alpha_k| - ln g.
// Minimising the capacity sum_j u_j (Yang et al.'s, up to the factor 1/2) is a linear programme,
// minimising the total arrival rate sum_j (1 - e^{-u_j}) a concave one: both attain their minimum
// at a vertex of the polyhedron, and every vertex is enumerated (n_sensors <= 12), so the answer is
// exact, not a bound.
#pragma once

#include <string>
#include <vector>

#include "networked_estimation/config/model.hpp"
#include "networked_estimation/stability/stability.hpp"

namespace networked_estimation
{

enum class DesignCost
{
  TOTAL_RATE,  ///< sum of the arrival rates
  CAPACITY     ///< sum of -ln(1 - lambda_j) (twice Yang et al.'s transmission capacity)
};

struct LinkDesign
{
  bool applicable = false;
  std::string note;  ///< how it was found, or "not applicable: ..."
  DesignCost cost = DesignCost::TOTAL_RATE;
  double growth_cap = 0.9;    ///< |alpha_k|^2 Phi_k <= growth_cap at the design
  std::vector<double> rates;  ///< per sensor: the least-cost arrival rates
  double cost_value = 0.0;
  /// Per sensor: the least arrival rate it needs when every other sensor is lossless (with the
  /// same growth cap): 0 when the others suffice.
  std::vector<double> alone;
  Verdict check;      ///< the verdict at `rates` (stabilityVerdict)
  long vertices = 0;  ///< vertices of the feasible polyhedron examined
};

/// Designs i.i.d. links for every sensor of the model. Not applicable (with the reason) for a
/// sensor schedule, a block Theorem 14 cannot decide, an unstable mode no sensor sees, or more
/// than 12 sensors.
LinkDesign designLinks(const Model& model, DesignCost cost, double growth_cap = 0.9);

}  // namespace networked_estimation
