// Phi_k under a sensor schedule (exact_test.hpp; docs/stability.md 3.5b): periodic schedules and
// random ones over a joint Markov chain.
#include "networked_estimation/stability/exact_test.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "stability_internal.hpp"

namespace networked_estimation
{

using stability_internal::linkGrowth;

namespace
{

long gcdLong(long a, long b)
{
  while (b != 0)
  {
    const long t = a % b;
    a = b;
    b = t;
  }
  return a;
}

/// seen(e, j, s): does sensor j give information on lattice element e at shift s (any s >= 0)?
bool seenAt(const BlockStructure& block, std::size_t e, std::size_t j, int s)
{
  return block.seen[e][j][static_cast<std::size_t>(s % block.block.order)];
}

}  // namespace

double blockPhiScheduled(const BlockStructure& block, const std::vector<LinkModel>& links, const Schedule& schedule,
                         std::string* why, std::size_t max_states)
{
  return blockGrowth(block, links, &schedule, why, max_states).phi;
}

BlockGrowth blockGrowth(const BlockStructure& block, const std::vector<LinkModel>& links, const Schedule* schedule,
                        std::string* why, std::size_t max_states)
{
  if (!schedule || !schedule->active())
    return blockGrowth(block, links);
  BlockGrowth best;
  if (block.method == BlockStructure::Method::UNAVAILABLE)
    return best;
  best.phi = 0.0;
  const int N = block.block.order;
  const std::size_t elements = block.seen.size();
  const std::size_t S = links.size();
  if (schedule->kind == Schedule::Kind::PERIODIC)
  {
    const long tau = static_cast<long>(schedule->pattern.size());
    const long M = N / gcdLong(N, tau) * tau;
    for (long t0 = 0; t0 < tau; ++t0)
      for (std::size_t e = 0; e < elements; ++e)
      {
        BlockGrowth element;
        element.phi = 1.0;
        element.one = true;
        for (std::size_t j = 0; j < S; ++j)
        {
          const Eigen::MatrixXd P = links[j].transition();
          const Eigen::VectorXd loss = links[j].stateLoss();
          const Eigen::VectorXd ones = Eigen::VectorXd::Ones(loss.size());
          Eigen::MatrixXd prod = Eigen::MatrixXd::Identity(P.rows(), P.cols());
          for (long s = 0; s < M; ++s)
          {
            const bool on = schedule->pattern[static_cast<std::size_t>((t0 + s) % tau)][j];
            const Eigen::VectorXd& d = on && seenAt(block, e, j, static_cast<int>(s % N)) ? loss : ones;
            prod = prod * d.asDiagonal() * P;
          }
          const BlockGrowth g = linkGrowth(prod, 1.0 / static_cast<double>(M));
          element.phi *= g.phi;
          element.one = element.one && g.one;
        }
        best.phi = std::max(best.phi, element.phi);
        best.one = best.one || element.one;
      }
    return best;
  }
  // RANDOM: the joint chain (schedule state, link states), states enumerated with the schedule
  // state slowest and link j's state at stride prod_{i > j} |states_i|.
  const Eigen::Index K = schedule->transition.rows();
  std::vector<Eigen::Index> sizes(S);
  std::size_t total = static_cast<std::size_t>(K);
  for (std::size_t j = 0; j < S; ++j)
  {
    sizes[j] = links[j].transition().rows();
    total *= static_cast<std::size_t>(sizes[j]);
  }
  if (total > max_states)
  {
    if (why)
      *why = "the random schedule's joint chain (schedule state x link states) has " + std::to_string(total) +
             " states, more than " + std::to_string(max_states);
    best.phi = std::numeric_limits<double>::quiet_NaN();
    return best;
  }
  Eigen::MatrixXd T = schedule->transition;
  for (std::size_t j = 0; j < S; ++j)
  {
    const Eigen::MatrixXd P = links[j].transition();
    Eigen::MatrixXd next(T.rows() * P.rows(), T.cols() * P.cols());
    for (Eigen::Index a = 0; a < T.rows(); ++a)
      for (Eigen::Index b = 0; b < T.cols(); ++b)
        next.block(a * P.rows(), b * P.cols(), P.rows(), P.cols()) = T(a, b) * P;
    T = next;
  }
  const Eigen::Index n = T.rows();
  for (std::size_t e = 0; e < elements; ++e)
  {
    Eigen::MatrixXd prod = Eigen::MatrixXd::Identity(n, n);
    for (int s = 0; s < N; ++s)
    {
      Eigen::VectorXd d(n);
      for (Eigen::Index x = 0; x < n; ++x)
      {
        // decode x -> (schedule state, link states)
        Eigen::Index rest = x;
        std::vector<Eigen::Index> state(S);
        for (std::size_t j = S; j-- > 0;)
        {
          state[j] = rest % sizes[j];
          rest /= sizes[j];
        }
        const std::vector<bool>& on = schedule->subsets[static_cast<std::size_t>(rest)];
        double p_none = 1.0;
        for (std::size_t j = 0; j < S; ++j)
          if (on[j] && seenAt(block, e, j, s))
            p_none *= links[j].stateLoss()[state[j]];
        d[x] = p_none;
      }
      prod = prod * d.asDiagonal() * T;
    }
    const BlockGrowth g = linkGrowth(prod, 1.0 / N);
    best.phi = std::max(best.phi, g.phi);
    best.one = best.one || g.one;
  }
  return best;
}

Schedule restrictSchedule(const Schedule& schedule, const std::vector<int>& set)
{
  Schedule out = schedule;
  auto restrict = [&](std::vector<std::vector<bool>>& masks)
  {
    for (std::vector<bool>& m : masks)
    {
      std::vector<bool> r;
      for (int i : set)
        r.push_back(m[static_cast<std::size_t>(i)]);
      m = r;
    }
  };
  restrict(out.pattern);
  restrict(out.subsets);
  return out;
}

}  // namespace networked_estimation
