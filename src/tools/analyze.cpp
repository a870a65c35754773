// analyze: stability analysis of a model over a lossy sensor link (stability.hpp).
#include <cmath>
#include <iostream>
#include <sstream>

#include "cli.hpp"
#include "networked_estimation/io/json_writer.hpp"
#include "networked_estimation/config/model.hpp"
#include "networked_estimation/config/channel_settings.hpp"
#include "networked_estimation/config/estimator_settings.hpp"
#include "networked_estimation/stability/stability.hpp"

using namespace networked_estimation;

namespace
{

std::string jnum(double v)
{
  if (!std::isfinite(v))
    return "null";
  std::ostringstream os;
  os.precision(17);
  os << v;
  return os.str();
}

std::string jverdict(const Verdict& v)
{
  std::string out =
      "{\"kind\": " + jsonString(toString(v.kind)) + ", \"reason\": " + jsonString(v.reason) + ", \"numbers\": {";
  bool first = true;
  for (const auto& kv : v.numbers)
  {
    out += (first ? "" : ", ") + jsonString(kv.first) + ": " + jnum(kv.second);
    first = false;
  }
  return out + "}}";
}

std::string jset(const RateAnalysis& r)
{
  std::ostringstream os;
  os << "{\"name\": " << jsonString(r.name) << ", \"sensors\": [";
  for (std::size_t i = 0; i < r.sensors.size(); ++i)
    os << (i ? ", " : "") << r.sensors[i];
  os << "], \"lower_bound\": " << jnum(r.lower_bound) << ", \"closed_form_upper\": " << jnum(r.closed_form_upper)
     << ", \"mare_diverges_at\": " << jnum(r.mare.diverges_at) << ", \"mare_converges_at\": " << jnum(r.mare.converges_at)
     << ", \"mare_undecided_band\": " << (r.mare.undecided_band ? "true" : "false")
     << ", \"exact_rate\": " << jnum(r.exact_rate) << ", \"exact_method\": " << jsonString(r.exact_method)
     << ", \"recovery_lower_bound\": " << jnum(r.recovery_lower_bound) << ", \"recovery_exact\": " << jnum(r.recovery_exact)
     << ", \"aoe_theorem5\": " << jverdict(r.aoe_theorem5) << ", \"verdict\": " << jverdict(r.verdict)
     << ", \"margin_quantity\": " << jsonString(r.margin_quantity) << ", \"channel_value\": " << jnum(r.channel_value)
     << ", \"necessary_threshold\": " << jnum(r.necessary_threshold)
     << ", \"sufficient_threshold\": " << jnum(r.sufficient_threshold) << ", \"margin\": " << jnum(r.margin) << "}";
  return os.str();
}

std::string json(const StabilityReport& rep)
{
  std::ostringstream os;
  os << "{\n  \"model\": " << jsonString(rep.model_name) << ",\n  \"eigenvalues\": [";
  for (int i = 0; i < rep.eigenvalues.size(); ++i)
    os << (i ? ", " : "") << "{\"re\": " << jnum(rep.eigenvalues[i].real()) << ", \"im\": " << jnum(rep.eigenvalues[i].imag())
       << "}";
  os << "],\n  \"spectral_radius\": " << jnum(rep.spectral_radius) << ",\n  \"mahler_measure\": " << jnum(rep.mahler_measure)
     << ",\n  \"entropy\": " << jnum(rep.entropy) << ",\n  \"diagonalizable\": " << (rep.diagonalizable ? "true" : "false")
     << ",\n  \"strong_observability\": " << jverdict(rep.strong_observability)
     << ",\n  \"noise_excites_unstable_modes\": " << (rep.noise_excites_unstable_modes ? "true" : "false")
     << ",\n  \"detectable\": " << (rep.detectable ? "true" : "false") << ",\n  \"channel\": ";
  if (rep.has_channel)
    os << "{\"kind\": " << jsonString(rep.link.kind == LinkModel::Kind::IID ? "bernoulli" : "gilbert_elliott")
       << ", \"arrival_rate\": " << jnum(rep.arrival_rate) << ", \"recovery_rate\": " << jnum(rep.recovery_rate)
       << ", \"on_off\": " << (rep.link.onOff() ? "true" : "false") << ", \"capacity\": " << jnum(rep.capacity.total)
       << ", \"capacity_lower\": " << jnum(rep.capacity.lower) << ", \"capacity_upper\": " << jnum(rep.capacity.upper)
       << "}";
  else
    os << "null";
  os << ",\n  \"estimator\": " << jsonString(rep.estimator)
     << ",\n  \"estimator_note\": " << jsonString(rep.estimator_note)
     << ",\n  \"rseio\": " << jverdict(rep.rseio) << ",\n  \"all_sensors\": " << jset(rep.model) << ",\n  \"sensors\": [";
  for (std::size_t i = 0; i < rep.sensors.size(); ++i)
    os << (i ? ",\n    " : "\n    ") << jset(rep.sensors[i]);
  os << "\n  ]\n}\n";
  return os.str();
}

std::string txt(double v)
{
  if (std::isnan(v))
    return "n/a";
  std::ostringstream os;
  os.precision(6);
  os << v;
  return os.str();
}

void printSet(std::ostream& os, const RateAnalysis& r)
{
  os << "[" << r.name << "]\n";
  os << "  lower bound (necessary)         " << txt(r.lower_bound) << "\n";
  os << "  MARE upper bound                diverges at " << txt(r.mare.diverges_at) << ", converges at "
     << txt(r.mare.converges_at) << (r.mare.undecided_band ? " (undecided band between)" : "") << "\n";
  os << "  closed-form upper bound         " << txt(r.closed_form_upper) << "\n";
  os << "  exact critical arrival rate     " << txt(r.exact_rate) << "  (" << r.exact_method << ")\n";
  os << "  Markov: critical recovery rate  " << txt(r.recovery_exact) << " (necessary " << txt(r.recovery_lower_bound)
     << ")\n";
  os << "  Lin et al.'s Theorem 5          " << describe(r.aoe_theorem5) << "\n";
  os << "  verdict                         " << describe(r.verdict) << "\n";
  os << "  margin                          " << r.margin_quantity << " " << txt(r.channel_value) << " - critical "
     << txt(r.sufficient_threshold) << " = " << txt(r.margin) << "\n";
}

}  // namespace

int main(int argc, char** argv)
{
  cli::CommandLine cl("analyze",
                      "Stability analysis of a model over a lossy sensor link: eigenvalues and rho(A), the\n"
                      "necessary lower bound, the MARE upper bound, the exact critical rate when available, the\n"
                      "Markov threshold on the recovery rate, the verdict for the channel and the margin, for the\n"
                      "model and for each sensor alone. Every sensor gets its own link with the channel's settings.",
                      {
                          {"model", "FILE", "model (YAML)", true, false},
                          {"channel", "FILE", "sensor-to-estimator channel settings (YAML)", false, false},
                          {"estimator", "FILE", "estimator settings (YAML; default kfio)", false, false},
                          {"json", "", "print JSON", false, false},
                      });
  return cli::runTool(cl, argc, argv, [&]() -> int {
    const Model model = loadModel(cl.get("model"));
    ChannelSettings channel;
    const bool has_channel = cl.has("channel");
    if (has_channel)
      channel = loadChannelSettings(cl.get("channel"));
    EstimatorSettings est;
    const bool has_est = cl.has("estimator");
    if (has_est)
      est = loadEstimatorSettings(cl.get("estimator"));
    const StabilityReport rep =
        analyzeStability(model, has_channel ? &channel : nullptr, has_est ? &est : nullptr);
    if (cl.has("json"))
    {
      std::cout << json(rep);
      return 0;
    }
    std::cout << "model " << rep.model_name << ": n = " << model.n() << ", " << model.sensors.size() << " sensor(s)\n";
    std::cout << "eigenvalues:";
    for (int i = 0; i < rep.eigenvalues.size(); ++i)
    {
      const auto& e = rep.eigenvalues[i];
      std::cout << " " << txt(e.real());
      if (e.imag() != 0.0)
        std::cout << (e.imag() > 0 ? "+" : "-") << txt(std::abs(e.imag())) << "i";
    }
    std::cout << "\nrho(A) = " << txt(rep.spectral_radius) << ", M(A) = " << txt(rep.mahler_measure)
              << ", diagonalizable: " << (rep.diagonalizable ? "yes" : "no") << "\n";
    std::cout << "strong observability: " << describe(rep.strong_observability) << "\n";
    if (rep.has_channel)
      std::cout << "channel: arrival rate " << txt(rep.arrival_rate) << ", recovery rate " << txt(rep.recovery_rate)
                << "\n";
    std::cout << "estimator " << rep.estimator << ": " << rep.estimator_note << "\n";
    if (rep.estimator == "rseio")
      std::cout << "rseio: " << describe(rep.rseio) << "\n";
    printSet(std::cout, rep.model);
    if (model.sensors.size() > 1)
      for (const RateAnalysis& r : rep.sensors)
        printSet(std::cout, r);
    return 0;
  });
}
