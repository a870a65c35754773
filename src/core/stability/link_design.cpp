// Link design by vertex enumeration of the stable polyhedron (link_design.hpp).
#include "networked_estimation/stability/link_design.hpp"

#include <cmath>
#include <functional>
#include <limits>

namespace networked_estimation
{

namespace
{

/// Rows w (one per lattice element of each unstable block) and right-hand sides b of W u >= b.
struct Polyhedron
{
  std::vector<Eigen::VectorXd> w;
  std::vector<double> b;
};

}  // namespace

LinkDesign designLinks(const Model& model, DesignCost cost, double growth_cap)
{
  LinkDesign out;
  out.cost = cost;
  out.growth_cap = growth_cap;
  const std::size_t S = model.sensors.size();
  const double inf = std::numeric_limits<double>::infinity();
  if (model.schedule.active())
  {
    out.note = "not applicable: a sensor schedule (the design assumes every sensor transmits at every step)";
    return out;
  }
  if (!(growth_cap > 0.0 && growth_cap < 1.0))
  {
    out.note = "not applicable: the growth cap must be in (0, 1)";
    return out;
  }
  if (S > 12)
  {
    out.note = "not applicable: more than 12 sensors (the vertex enumeration is exponential)";
    return out;
  }
  // Modes that no sensor observes grow whatever the links do: no design keeps E[P] bounded.
  std::vector<int> all;
  for (std::size_t j = 0; j < S; ++j)
    all.push_back(static_cast<int>(j));
  const SetVerdicts verdicts(model, all);
  if (!verdicts.deadReckoned().empty())
  {
    out.note = "not applicable: " + growRegardless(verdicts.deadStates()) +
               ": no sensor observes them even when every message arrives, so no "
               "rates keep E[P] bounded";
    return out;
  }
  const std::vector<BlockStructure>& blocks = verdicts.blocks();
  Polyhedron poly;
  for (const BlockStructure& b : blocks)
  {
    if (b.method == BlockStructure::Method::UNAVAILABLE)
    {
      out.note = "not applicable: Theorem 14 cannot decide a block: " + b.reason;
      return out;
    }
    const double rhs = 2.0 * std::log(b.block.modulus) - std::log(growth_cap);
    for (std::size_t e = 0; e < b.seen.size(); ++e)
    {
      Eigen::VectorXd w = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(S));
      for (std::size_t j = 0; j < S; ++j)
      {
        int n = 0;
        for (int s = 0; s < b.block.order; ++s)
          n += b.seen[e][j][static_cast<std::size_t>(s)] ? 1 : 0;
        w[static_cast<Eigen::Index>(j)] = static_cast<double>(n) / b.block.order;
      }
      poly.w.push_back(w);
      poly.b.push_back(rhs);
    }
  }
  const auto costOf = [&](const Eigen::VectorXd& u)
  {
    double c = 0.0;
    for (Eigen::Index j = 0; j < u.size(); ++j)
      c += cost == DesignCost::CAPACITY ? u[j] : 1.0 - std::exp(-u[j]);
    return c;
  };
  const auto feasible = [&](const Eigen::VectorXd& u)
  {
    if ((u.array() < -1e-12).any())
      return false;
    for (std::size_t r = 0; r < poly.w.size(); ++r)
      if (poly.w[r].dot(u) < poly.b[r] - 1e-9 * std::max(1.0, std::abs(poly.b[r])))
        return false;
    return true;
  };
  Eigen::VectorXd best_u;
  double best = inf;
  if (poly.w.empty())
  {
    best_u = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(S));
    best = 0.0;
  }
  else
  {
    // Every vertex: S active constraints among the rows and the bounds u_j = 0.
    const std::size_t R = poly.w.size(), total = R + S;
    std::vector<std::size_t> pick;
    std::function<void(std::size_t)> rec = [&](std::size_t from)
    {
      if (pick.size() == S)
      {
        Eigen::MatrixXd M(static_cast<Eigen::Index>(S), static_cast<Eigen::Index>(S));
        Eigen::VectorXd rhs(static_cast<Eigen::Index>(S));
        for (std::size_t i = 0; i < S; ++i)
        {
          const std::size_t c = pick[i];
          if (c < R)
          {
            M.row(static_cast<Eigen::Index>(i)) = poly.w[c].transpose();
            rhs[static_cast<Eigen::Index>(i)] = poly.b[c];
          }
          else
          {
            M.row(static_cast<Eigen::Index>(i)).setZero();
            M(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(c - R)) = 1.0;
            rhs[static_cast<Eigen::Index>(i)] = 0.0;
          }
        }
        const Eigen::FullPivLU<Eigen::MatrixXd> lu(M);
        if (!lu.isInvertible())
          return;
        ++out.vertices;
        const Eigen::VectorXd u = lu.solve(rhs);
        if (!feasible(u))
          return;
        const double c = costOf(u.cwiseMax(0.0));
        if (c < best)
        {
          best = c;
          best_u = u.cwiseMax(0.0);
        }
        return;
      }
      for (std::size_t c = from; c + (S - pick.size()) <= total; ++c)
      {
        pick.push_back(c);
        rec(c + 1);
        pick.pop_back();
      }
    };
    rec(0);
  }
  if (!std::isfinite(best))
  {
    out.note = "not applicable: no vertex of the stable set found";
    return out;
  }
  out.applicable = true;
  out.rates.resize(S);
  std::vector<LinkModel> links;
  for (std::size_t j = 0; j < S; ++j)
  {
    out.rates[j] = 1.0 - std::exp(-best_u[static_cast<Eigen::Index>(j)]);
    links.push_back(LinkModel::iid(out.rates[j]));
  }
  out.cost_value = best;
  out.check = verdicts.verdict(links);
  // Each sensor alone (the others lossless): the least u_j with the others at u = inf, i.e. the
  // rows that this sensor must satisfy by itself are those no other sensor enters.
  out.alone.assign(S, 0.0);
  for (std::size_t j = 0; j < S; ++j)
  {
    double need_u = 0.0;
    for (std::size_t r = 0; r < poly.w.size(); ++r)
    {
      bool others = false;
      for (std::size_t i = 0; i < S; ++i)
        others = others || (i != j && poly.w[r][static_cast<Eigen::Index>(i)] > 0.0);
      if (others)
        continue;
      need_u = std::max(need_u, poly.b[r] / poly.w[r][static_cast<Eigen::Index>(j)]);
    }
    out.alone[j] = 1.0 - std::exp(-need_u);
  }
  out.note = "exact: vertex enumeration of the stable set of Theorem 14 (" + std::to_string(out.vertices) +
             " vertices), i.i.d. links, |alpha_k|^2 Phi_k <= " + std::to_string(growth_cap).substr(0, 4);
  return out;
}

}  // namespace networked_estimation
