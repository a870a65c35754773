// The verdict of a set of sensors for given links (set_verdict.hpp; docs/stability.md 2.1).
#include "set_verdict.hpp"

#include <cmath>
#include <complex>
#include <memory>
#include <sstream>
#include <stdexcept>

#include "stability_internal.hpp"

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

using stability_internal::nullSpaceReal;

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

namespace
{

/// Orthonormal basis of the largest A-invariant subspace inside span(B) (orthonormal columns):
/// with B = ker H this is the unobservable subspace of (A, H).
Eigen::MatrixXd invariantInside(Eigen::MatrixXd B, const Eigen::MatrixXd& A)
{
  const Eigen::Index n = A.rows();
  while (B.cols() > 0)
  {
    const Eigen::MatrixXd off = (Eigen::MatrixXd::Identity(n, n) - B * B.transpose()) * A * B;
    const Eigen::MatrixXd z = nullSpaceReal(off, 1e-9 * std::max(1.0, A.norm()));
    if (z.cols() == B.cols())
      break;
    B = B * z;
  }
  return B;
}

/// The states span(V) involves (diagonal of its projection above 1 %; V orthonormal), by name: "x, y",
/// or "states 0, 2" / "state 0" for a model that names none.
std::string statesOf(const Model& model, const Eigen::MatrixXd& V)
{
  std::vector<int> idx;
  const Eigen::VectorXd weight = V.rowwise().squaredNorm();
  for (Eigen::Index i = 0; i < weight.size(); ++i)
    if (weight[i] > 0.01)
      idx.push_back(static_cast<int>(i));
  const bool named = static_cast<int>(model.states.size()) == model.n();
  std::string out = named ? "" : idx.size() == 1 ? "state " : "states ";
  for (std::size_t j = 0; j < idx.size(); ++j)
    out += (j ? ", " : "") + (named ? model.states[static_cast<std::size_t>(idx[j])] : std::to_string(idx[j]));
  return out;
}

/// Orthonormal basis of the generalised eigenspace of the eigenvalues `growing` (those with
/// |lambda| >= 1, conjugate pairs both listed) of An: the kernel of the real polynomial in An with
/// those roots and multiplicities. Its dimension is the number of those eigenvalues, so the kernel
/// is read off the smallest singular values and needs no rank tolerance.
Eigen::MatrixXd growingSubspace(const Eigen::MatrixXd& An, const std::vector<std::complex<double>>& growing)
{
  const Eigen::Index k = An.rows();
  const Eigen::Index g = static_cast<Eigen::Index>(growing.size());
  if (g == k)
    return Eigen::MatrixXd::Identity(k, k);
  const Eigen::MatrixXd I = Eigen::MatrixXd::Identity(k, k);
  Eigen::MatrixXd P = I;
  for (const std::complex<double>& l : growing)
  {
    if (l.imag() < 0.0)
      continue;  // its conjugate's quadratic factor covers it
    if (l.imag() > 0.0)
      P = P * (An * An - 2.0 * l.real() * An + std::norm(l) * I);
    else
      P = P * (An - l.real() * I);
    P /= std::max(P.norm(), 1e-300);  // scale only: the kernel is unchanged
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(P, Eigen::ComputeFullV);
  return svd.matrixV().rightCols(g);
}

}  // namespace

SetData makeSet(const Context& ctx, const std::vector<int>& set)
{
  const Model& model = *ctx.model;
  SetData d;
  d.set = set;
  d.A = model.A;
  d.Qn = ctx.Qn;
  d.rho = ctx.rho;
  d.excited = ctx.excited;
  int rows = 0;
  for (int i : set)
  {
    d.H.push_back(ctx.H[i]);
    rows += static_cast<int>(ctx.H[i].rows());
  }
  d.Hs.resize(rows, model.n());
  int r0 = 0;
  for (const auto& h : d.H)
  {
    d.Hs.middleRows(r0, h.rows()) = h;
    r0 += static_cast<int>(h.rows());
  }
  d.detectable = modesObservable(model.A, d.Hs, 1.0, 1e-9);
  if (!d.detectable)
  {
    // Modes with |lambda| >= 1 that the set does not observe even when every message arrives grow
    // whatever the links do (dead reckoning): they are reported apart, and the verdict concerns the
    // rest, the quotient of the state by the unobservable subspace N (docs/stability.md 2.2). N is
    // A-invariant, so in an orthonormal basis [U_o U_n] with U_n spanning N the observed coordinates
    // z = U_o' x evolve on their own: z' = (U_o' A U_o) z + U_o' B w, y_i = H_i U_o z + v_i.
    const Eigen::MatrixXd Un = invariantInside(nullSpaceReal(d.Hs, 1e-9), model.A);
    Eigen::MatrixXd basis(model.n(), model.n());
    basis << Un, nullSpaceReal(Un.transpose(), 1e-9);
    const Eigen::MatrixXd Uo = basis.rightCols(model.n() - Un.cols());
    const Eigen::MatrixXd An = Un.transpose() * model.A * Un;
    const Eigen::VectorXcd ev = eigenvalues(An);
    std::vector<std::complex<double>> growing;
    std::ostringstream os;
    double largest = 0.0;
    for (Eigen::Index i = 0; i < ev.size(); ++i)
      if (std::abs(ev[i]) >= 1.0 - ctx.options->tol.modulus)
      {
        os << (growing.empty() ? "" : ", ") << num(ev[i].real());
        if (ev[i].imag() != 0.0)
          os << (ev[i].imag() > 0 ? "+" : "-") << num(std::abs(ev[i].imag())) << "i";
        growing.push_back(ev[i]);
        largest = std::max(largest, std::abs(ev[i]));
      }
    d.dead_states = statesOf(model, Un * growingSubspace(An, growing));
    d.dead_modes = std::to_string(growing.size()) + " mode(s) with |lambda| >= 1 (" + os.str() + ")";
    d.dead_reckoned = d.dead_modes + " of " + d.dead_states +
                      " that no sensor observes even when every message arrives: grow regardless of the links";
    // |lambda| > 1 grows from any initial covariance; on the unit circle the noise must drive it
    // (else NOT_APPLICABLE, as for an observed mode the noise does not excite).
    d.dead_grow = largest > 1.0 + ctx.options->tol.modulus || ctx.excited;
    d.unobserved = static_cast<int>(Un.cols());
    d.observed_basis = Uo;
    d.A = Uo.transpose() * model.A * Uo;
    d.Qn = Uo.transpose() * ctx.Qn * Uo;
    d.Qn = 0.5 * (d.Qn + d.Qn.transpose());
    for (auto& h : d.H)
      h = h * Uo;
    d.Hs = d.Hs * Uo;
    d.rho = spectralRadius(d.A);
    d.excited = modesControllable(d.A, Uo.transpose() * ctx.G, 1.0, 1e-9);
    d.detectable = true;
  }
  d.stable_A = d.rho < 1.0;
  d.blocks = d.unobserved > 0 ? analyseBlocks(d.A, d.H, ctx.options->tol, ctx.options->lattice_cap)
                              : analyseBlocks(d.A, ctx.fmo, d.H, ctx.options->tol, ctx.options->lattice_cap);
  if (model.schedule.active())
    d.schedule = restrictSchedule(model.schedule, set);
  return d;
}

/// The verdict of docs/stability.md 2.1 for the set with these links (one per member).
Verdict setVerdict(const Context& ctx, const SetData& d, const std::vector<LinkModel>& links)
{
  return setVerdictFrom(d, linkVerdict(ctx, d, links));
}

Verdict setVerdictFrom(const SetData& d, const Verdict& links_verdict)
{
  if (d.dead_reckoned.empty())
    return links_verdict;
  // Step 2: modes with |lambda| >= 1 that no sensor observes even when every message arrives.
  Verdict v;
  v.numbers = links_verdict.numbers;
  v.numbers["dead-reckoned dimension"] = d.unobserved;
  const std::string links = "; the links' verdict on the observed modes: " + describe(links_verdict);
  if (d.dead_grow)
  {
    v.kind = Verdict::Kind::UNSTABLE;
    v.reason = growRegardless(d.dead_states) + ": " + d.dead_modes +
               " that no sensor observes even when every message arrives" + links;
  }
  else
  {
    v.kind = Verdict::Kind::NOT_APPLICABLE;
    v.reason = "(A, B Q^1/2) has an uncontrollable mode with |lambda| >= 1, and no sensor observes " + d.dead_states +
               " (" + d.dead_modes +
               ") even when every message arrives; the critical-rate "
               "results assume (A, Q^1/2) controllable" +
               links;
  }
  return v;
}

Verdict linkVerdict(const Context& ctx, const SetData& d, const std::vector<LinkModel>& links)
{
  const AnalysisOptions& opt = *ctx.options;
  Verdict v;
  v.numbers["rho(A)"] = d.rho;
  const std::string observed = d.dead_reckoned.empty() ? "A" : "A on the observed modes";
  if (d.A.rows() == 0)
  {
    v.kind = Verdict::Kind::STABLE;
    v.reason = "the sensors observe no mode: the links have nothing to lose";
    return v;
  }
  if (d.stable_A)
  {
    v.kind = Verdict::Kind::STABLE;
    v.reason = observed + " is stable (rho(A) = " + num(d.rho) + " < 1): the expected error covariance" +
               (d.dead_reckoned.empty() ? "" : " of the observed modes") + " is bounded at every rate";
    return v;
  }
  if (!d.excited)
  {
    v.kind = Verdict::Kind::NOT_APPLICABLE;
    v.reason =
        "(A, B Q^1/2) has an uncontrollable mode with |lambda| >= 1; the critical-rate results assume "
        "(A, Q^1/2) controllable";
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
  const double necessary = d.rho * d.rho * persistence;
  v.numbers["rho^2 prod persistence"] = necessary;
  if (markov ? necessary > 1.0 + opt.tol.decision : necessary >= 1.0 - opt.tol.decision)
  {
    v.kind = Verdict::Kind::UNSTABLE;
    v.reason = "necessary condition fails: rho(A)^2 times the probability growth rate of losing every sensor = " +
               num(necessary) + (markov ? " > 1 (Theorem 14, all-lost event)" : " >= 1 (Yang et al. Theorem 1)") +
               "; " + exact.reason;
    return v;
  }
  if (all_iid && !opt.use_mare)
  {
    v.kind = Verdict::Kind::UNDECIDED;
    v.reason =
        "above the necessary lower bound; the MARE upper bound is not tried here (analyze tries it); " + exact.reason;
    return v;
  }
  if (all_iid)
  {
    std::vector<double> rates;
    for (const LinkModel& l : links)
      rates.push_back(l.arrival);
    const Mare mare(d.A, d.Qn, d.H, rates);
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
  ctx.G = model.B * Eigen::LLT<Eigen::MatrixXd>(model.Q).matrixL().toDenseMatrix();
  ctx.excited = modesControllable(model.A, ctx.G, 1.0, 1e-9);
  ctx.fmo = fmoBlocks(model.A, 1.0, options.tol);
  return ctx;
}

}  // namespace stability_internal

using namespace stability_internal;

struct SetVerdicts::Impl
{
  Model model;
  AnalysisOptions options;
  Context ctx;
  SetData data;
};

SetVerdicts::SetVerdicts(const Model& model, const std::vector<int>& set, const AnalysisOptions& options)
{
  for (int i : set)
    if (i < 0 || i >= static_cast<int>(model.sensors.size()))
      throw std::invalid_argument("SetVerdicts: sensor index " + std::to_string(i) + " out of range (" +
                                  std::to_string(model.sensors.size()) + " sensors)");
  auto impl = std::make_shared<Impl>();
  impl->model = model;
  impl->options = options;
  impl->ctx = modelContext(impl->model, impl->options);
  impl->data = makeSet(impl->ctx, set);
  impl_ = impl;
}

Verdict SetVerdicts::verdict(const std::vector<LinkModel>& links) const
{
  if (links.size() != impl_->data.set.size())
    throw std::invalid_argument("SetVerdicts: " + std::to_string(links.size()) + " links for a set of " +
                                std::to_string(impl_->data.set.size()) + " sensors");
  return verdicts(links).first;
}

Verdict SetVerdicts::linksVerdict(const std::vector<LinkModel>& links) const
{
  if (links.size() != impl_->data.set.size())
    throw std::invalid_argument("SetVerdicts: " + std::to_string(links.size()) + " links for a set of " +
                                std::to_string(impl_->data.set.size()) + " sensors");
  return linkVerdict(impl_->ctx, impl_->data, links);
}

std::pair<Verdict, Verdict> SetVerdicts::verdicts(const std::vector<LinkModel>& links) const
{
  Verdict lv = linksVerdict(links);
  Verdict v = setVerdictFrom(impl_->data, lv);
  return {std::move(v), std::move(lv)};
}

Verdict SetVerdicts::verdictGiven(const Verdict& links_verdict) const
{
  return setVerdictFrom(impl_->data, links_verdict);
}

std::vector<SensorMargin> SetVerdicts::margins(const std::vector<LinkModel>& links, bool links_only) const
{
  const std::size_t S = impl_->model.sensors.size();
  if (impl_->data.set.size() != S)
    throw std::invalid_argument("SetVerdicts::margins: the set must be every sensor of the model");
  if (links.size() != S)
    throw std::invalid_argument("sensorMargins: " + std::to_string(links.size()) + " links for " + std::to_string(S) +
                                " sensors");
  std::vector<SensorMargin> out;
  for (std::size_t i = 0; i < S; ++i)
    out.push_back(sensorMargin(impl_->ctx, impl_->data, links, static_cast<int>(i), links_only));
  return out;
}

const std::string& SetVerdicts::deadReckoned() const
{
  return impl_->data.dead_reckoned;
}

const std::string& SetVerdicts::deadStates() const
{
  return impl_->data.dead_states;
}

bool SetVerdicts::exact() const
{
  return exactAvailable(impl_->data);
}

const std::vector<BlockStructure>& SetVerdicts::blocks() const
{
  return impl_->data.blocks;
}

std::string growRegardless(const std::string& states)
{
  const bool one = states.find(',') == std::string::npos;
  return states + (one ? " grows" : " grow") + " regardless of the links";
}

Verdict stabilityVerdict(const Model& model, const std::vector<int>& set, const std::vector<LinkModel>& links,
                         const AnalysisOptions& options)
{
  return SetVerdicts(model, set, options).verdict(links);
}

}  // namespace networked_estimation
