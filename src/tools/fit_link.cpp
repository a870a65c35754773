// fit_link: the loss and delay models of a recorded link (link/link_fit.hpp), from a ROS bag's
// topics, a trace CSV or a LossyChannel's ~events; writes the fitted channel file.
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <string>

#include "cli.hpp"
#include "networked_estimation/common/error.hpp"
#include "networked_estimation/io/atomic_file.hpp"
#include "networked_estimation/link/link_fit.hpp"
#include "networked_estimation/link/link_report.hpp"
#include "networked_estimation/link/link_trace.hpp"

using namespace networked_estimation;

int main(int argc, char** argv)
{
  cli::CommandLine cl(
      "fit_link",
      "Fits loss and delay models to a recorded link: from the messages' header stamps, header.seq (where\n"
      "the publisher sets it) and receipt times it finds the expected messages, the lost ones, reordering\n"
      "and duplicates, then fits a Bernoulli, a two-state Gilbert (maximum likelihood, 95 % intervals) and a\n"
      "four-parameter Gilbert-Elliott link (Baum-Welch), chooses one by BIC, and measures the delays\n"
      "(quantiles, RFC 3550 jitter, lag-1 correlation, the clock offset). --output writes the channel file\n"
      "that LossyChannel, simulate, montecarlo and analyze read.",
      {
          {"bag", "FILE", "a ROS bag (format 2.0; chunks uncompressed, bz2 or lz4): receipt = record time", false,
           false},
          {"topic", "T", "--bag: the topic to fit (repeatable: one link each, the bag read once)", false, true},
          {"csv", "FILE", "a trace CSV instead: columns stamp, receipt (s) and optionally seq", false, false},
          {"events", "FILE", "a LossyChannel's ~events instead (`rostopic echo -p`): one slot per message", false,
           false},
          {"rate", "HZ", "the expected message rate (default: learnt from the stamps; refused when they contradict it)",
           false, false},
          {"clock", "MODE",
           "auto (default: the clocks differ when a message is received before its stamp), same, or different "
           "(delays relative to the smallest)",
           false, false},
          {"output", "FILE", "write the fitted channel file (one link only)", false, false},
          {"write-csv", "FILE", "write the link's record as a trace CSV (stamp,receipt,seq; one link, not --events)",
           false, false},
          {"starts", "N", "Baum-Welch starts of the Gilbert-Elliott fit (default 5)", false, false},
          {"seed", "S", "seed of the Baum-Welch starts (default 1)", false, false},
          {"json", "", "print JSON", false, false},
          {"series", "", "--json: add each link's slots (arrived, delay) for plots (scripts/plot_link.py)", false,
           false},
      });
  return cli::runTool(
      cl, argc, argv,
      [&]() -> int
      {
        const int sources = (cl.has("bag") ? 1 : 0) + (cl.has("csv") ? 1 : 0) + (cl.has("events") ? 1 : 0);
        if (sources != 1)
          throw cli::UsageError("give exactly one of --bag, --csv and --events (found " + std::to_string(sources) +
                                ")");
        if (cl.has("bag") != cl.has("topic"))
          throw cli::UsageError(cl.has("bag") ? "--bag needs --topic (the topic to fit)"
                                              : "--topic is for --bag (a CSV or events file holds one link)");
        if (cl.has("series") && !cl.has("json"))
          throw cli::UsageError("--series is for --json");
        TraceOptions options;
        if (cl.has("rate"))
        {
          const std::string text = cl.get("rate");
          char* end = nullptr;
          options.rate = std::strtod(text.c_str(), &end);
          if (text.empty() || *end != '\0' || !(options.rate > 0.0) || !std::isfinite(options.rate))
            throw cli::UsageError("--rate: expected a positive number of Hz, found '" + text + "'");
          if (cl.has("events"))
            throw cli::UsageError("--rate is not for --events (one slot per event)");
        }
        if (cl.has("clock"))
        {
          try
          {
            options.clock = clockModeOf(cl.get("clock"), "--clock");
          }
          catch (const InputError& e)
          {
            throw cli::UsageError(e.what());
          }
          if (cl.has("events"))
            throw cli::UsageError("--clock is not for --events (the channel recorded its own delays)");
        }
        FitOptions fit_options;
        fit_options.ge_starts = static_cast<int>(cl.getLong("starts", 5, 1, 1000));
        fit_options.seed = cl.getUint64("seed", 1);

        std::vector<LinkRecord> records;
        std::vector<SlotTrace> traces;
        if (cl.has("bag"))
          records = readBagLinks(cl.get("bag"), cl.getAll("topic"));
        else if (cl.has("csv"))
          records.push_back(readLinkCsv(cl.get("csv")));
        else
          traces.push_back(readEventSlots(cl.get("events")));
        for (const LinkRecord& r : records)
          traces.push_back(analyseLink(r, options));
        if ((cl.has("output") || cl.has("write-csv")) && traces.size() != 1)
          throw cli::UsageError(std::string("--") + (cl.has("output") ? "output" : "write-csv") +
                                " writes one link: give one --topic");
        if (cl.has("write-csv") && records.empty())
          throw cli::UsageError("--write-csv is not for --events");

        std::vector<LinkFit> fits;
        for (const SlotTrace& t : traces)
          fits.push_back(fitLink(t, fit_options));
        if (cl.has("output"))
        {
          AtomicFile out(cl.get("output"));
          out.stream() << fittedChannelYaml(fits.front());
          out.commit();
        }
        if (cl.has("write-csv"))
          writeLinkCsv(records.front(), cl.get("write-csv"));
        if (cl.has("json"))
        {
          std::cout << linkFitsJson(fits, cl.has("series"));
          return 0;
        }
        for (std::size_t i = 0; i < fits.size(); ++i)
          std::cout << (i ? "\n" : "") << linkFitText(fits[i]);
        if (cl.has("output"))
          std::cout << "channel file: " << cl.get("output") << " (model " << fits.front().loss.chosen << ")\n";
        return 0;
      });
}
