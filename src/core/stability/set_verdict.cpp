// The verdict of a set of sensors for given links (set_verdict.hpp; docs/stability.md 2.1).
#include "set_verdict.hpp"

#include <cmath>
#include <sstream>

namespace networked_estimation
{
namespace
{

std::vector<Eigen::MatrixXd> whitenedSensors(const Model& model)
{
  std::vector<Eigen::MatrixXd> H;
  for (const Sensor& s : model.sensors)
  {
    const Eigen::MatrixXd Ri = model.R.block(s.offset, s.offset, s.size, s.size);
    const Eigen::MatrixXd Ci = model.C.middleRows(s.offset, s.size);
    H.push_back(Eigen::LLT<Eigen::MatrixXd>(Ri).matrixL().solve(Ci));
  }
  return H;
}

}  // namespace

namespace stability_internal
{

std::string num(double v)
{
  std::ostringstream os;
  os.precision(6);
  os << v;
  return os.str();
}

bool sameLink(const LinkModel& a, const LinkModel& b)
{
  if (a.kind != b.kind)
    return false;
  if (a.kind == LinkModel::Kind::IID)
    return a.arrival == b.arrival;
  return a.p == b.p && a.r == b.r && a.loss_bad == b.loss_bad && a.loss_good == b.loss_good;
}

SetData makeSet(const Context& ctx, const std::vector<int>& set)
{
  SetData d;
  d.set = set;
  int rows = 0;
  for (int i : set)
  {
    d.H.push_back(ctx.H[i]);
    rows += static_cast<int>(ctx.H[i].rows());
  }
  d.Hs.resize(rows, ctx.model->n());
  int r0 = 0;
  for (const auto& h : d.H)
  {
    d.Hs.middleRows(r0, h.rows()) = h;
    r0 += static_cast<int>(h.rows());
  }
  d.stable_A = ctx.rho < 1.0;
  d.detectable = modesObservable(ctx.model->A, d.Hs, 1.0, 1e-9);
  d.blocks = analyseBlocks(ctx.model->A, d.H, ctx.options->tol);
  if (ctx.model->schedule.active())
    d.schedule = restrictSchedule(ctx.model->schedule, set);
  return d;
}

/// The verdict of docs/stability.md 2.1 (steps 2-8) for the set with these links (one per member).
Verdict setVerdict(const Context& ctx, const SetData& d, const std::vector<LinkModel>& links)
{
  const AnalysisOptions& opt = *ctx.options;
  Verdict v;
  v.numbers["rho(A)"] = ctx.rho;
  if (d.stable_A)
  {
    v.kind = Verdict::Kind::STABLE;
    v.reason = "A is stable (rho(A) = " + num(ctx.rho) + " < 1): the expected error covariance is bounded at every rate";
    return v;
  }
  if (!ctx.excited)
  {
    v.kind = Verdict::Kind::NOT_APPLICABLE;
    v.reason = "(A, B Q^1/2) has an uncontrollable mode with |lambda| >= 1; the critical-rate results assume "
               "(A, Q^1/2) controllable";
    return v;
  }
  if (!d.detectable)
  {
    v.kind = Verdict::Kind::UNSTABLE;
    v.reason = "a mode with |lambda| >= 1 is not observable from the sensors: unbounded at every rate";
    return v;
  }
  const Verdict exact = marelliTest(d.blocks, links, opt.tol, &d.schedule);
  if (exact.kind != Verdict::Kind::NOT_APPLICABLE || d.schedule.active())
  {
    // With a schedule only Theorem 14 (cyclostationary) applies: the bounds below assume every
    // sensor transmits at every step.
    v.kind = exact.kind;
    v.reason = exact.reason;
    for (const auto& kv : exact.numbers)
      v.numbers[kv.first] = kv.second;
    return v;
  }
  // Necessary condition: all sensors lost in a window (Yang Theorem 1 for i.i.d. links:
  // prod (1 - lambda_i) rho^2 >= 1; for Markov links the all-lost event of Theorem 14).
  bool markov = false, all_iid = true;
  double persistence = 1.0;
  for (const LinkModel& l : links)
  {
    persistence *= l.lossPersistence();
    if (l.kind == LinkModel::Kind::GILBERT_ELLIOTT)
      markov = true, all_iid = false;
  }
  const double necessary = ctx.rho * ctx.rho * persistence;
  v.numbers["rho^2 prod persistence"] = necessary;
  if (markov ? necessary > 1.0 + opt.tol.decision : necessary >= 1.0 - opt.tol.decision)
  {
    v.kind = Verdict::Kind::UNSTABLE;
    v.reason = "necessary condition fails: rho(A)^2 times the probability growth rate of losing every sensor = " +
               num(necessary) + (markov ? " > 1 (Theorem 14, all-lost event)" : " >= 1 (Yang et al. Theorem 1)") +
               "; " + exact.reason;
    return v;
  }
  if (all_iid)
  {
    std::vector<double> rates;
    for (const LinkModel& l : links)
      rates.push_back(l.arrival);
    const Mare mare(ctx.model->A, ctx.Qn, d.H, rates);
    const MareResult mr = solveMare(mare, opt.mare, true);
    v.numbers["MARE iterations"] = mr.iterations;
    v.numbers["MARE certificate rho(T)"] = mr.certificate;
    if (mr.status == MareResult::Status::CONVERGED)
    {
      v.kind = Verdict::Kind::STABLE;
      v.reason = "the MARE upper bound converges (certificate rho(T) = " + num(mr.certificate) +
                 " < 1, Yang et al. Theorem 4); " + exact.reason;
      return v;
    }
    v.kind = Verdict::Kind::UNDECIDED;
    v.reason = std::string("above the necessary lower bound but the MARE upper bound ") +
               (mr.status == MareResult::Status::DIVERGED ? "diverges" : "is undecided") +
               " (a diverging upper bound does not prove instability); " + exact.reason;
    return v;
  }
  v.kind = Verdict::Kind::UNDECIDED;
  v.reason = "above the necessary condition, no exact test available; " + exact.reason;
  return v;
}

bool exactAvailable(const SetData& d)
{
  for (const BlockStructure& b : d.blocks)
    if (b.method == BlockStructure::Method::UNAVAILABLE)
      return false;
  return true;
}

/// Some lattice block of order > 1 is seen by member j of the set (j < 0: by any member): along a
/// Markov recovery rate the stable set need not be a half-line.
bool latticeOrderAboveOne(const SetData& d, int j)
{
  for (const BlockStructure& b : d.blocks)
    if (b.method == BlockStructure::Method::LATTICE && b.block.order > 1)
      for (std::size_t k = 0; k < b.relevant.size(); ++k)
        if (b.relevant[k] && (j < 0 || static_cast<int>(k) == j))
          return true;
  return false;
}

Context modelContext(const Model& model, const AnalysisOptions& options)
{
  Context ctx;
  ctx.model = &model;
  ctx.options = &options;
  ctx.Qn = model.B * model.Q * model.B.transpose();
  ctx.Qn = 0.5 * (ctx.Qn + ctx.Qn.transpose());
  ctx.H = whitenedSensors(model);
  ctx.rho = spectralRadius(model.A);
  const Eigen::MatrixXd G = model.B * Eigen::LLT<Eigen::MatrixXd>(model.Q).matrixL().toDenseMatrix();
  ctx.excited = modesControllable(model.A, G, 1.0, 1e-9);
  return ctx;
}

}  // namespace stability_internal

using namespace stability_internal;

Verdict stabilityVerdict(const Model& model, const std::vector<int>& set, const std::vector<LinkModel>& links,
                         const AnalysisOptions& options)
{
  const Context ctx = modelContext(model, options);
  return setVerdict(ctx, makeSet(ctx, set), links);
}

}  // namespace networked_estimation
