// The summary tables of bench_estimators (bench_estimators_report.hpp).
#include "bench_estimators_report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace networked_estimation
{
namespace bench
{

namespace
{

struct Stat
{
  bool ok = false;
  double median = 0.0;
  double min = 0.0;
};

Stat summarise(const Timing& t, double divisor)
{
  Stat s;
  if (!t.error.empty())
  {
    return s;
  }
  if (!t.reps.empty())
  {
    std::vector<double> v = t.reps;
    std::sort(v.begin(), v.end());
    const std::size_t k = v.size();
    s.median = k % 2 == 1 ? v[k / 2] : 0.5 * (v[k / 2 - 1] + v[k / 2]);
    s.min = v.front();
    s.ok = true;
  }
  else if (t.agg_median >= 0.0)
  {
    s.median = t.agg_median;
    s.min = t.agg_min >= 0.0 ? t.agg_min : t.agg_median;
    s.ok = true;
  }
  s.median /= divisor;
  s.min /= divisor;
  return s;
}

struct Row
{
  std::string label;   ///< printed name
  std::string bench;   ///< benchmark name it is computed from
  bool per_component;  ///< divide by the number of components held
  double target;       ///< ratio target for the sizes of the table (0: none)
};

/// A summary table: the rows, the benchmark the ratios refer to, and the sizes the targets apply to.
struct Table
{
  std::vector<Row> rows;
  std::string reference;      ///< benchmark name of the denominator
  bool (*targeted)(int n);    ///< whether the targets apply at n
  const char* targeted_text;  ///< e.g. "n >= 4"
};

std::string formatCell(const Stat& s, const Stat& base, bool use_min, double target, bool targeted)
{
  if (!s.ok)
  {
    return "-";
  }
  const double value = use_min ? s.min : s.median;
  char buf[96];
  if (!base.ok)
  {
    std::snprintf(buf, sizeof(buf), "%.1f", value);
    return buf;
  }
  const double ratio = value / (use_min ? base.min : base.median);
  const char* verdict = "";
  if (target > 0.0 && targeted)
  {
    verdict = ratio <= target ? " PASS" : " MISS";
  }
  std::snprintf(buf, sizeof(buf), "%.1f (%.2fx)%s", value, ratio, verdict);
  return buf;
}

void printTable(const std::map<Key, Timing>& timings, const Table& table, const std::vector<int>& sizes, bool use_min)
{
  const int label_width = 18;
  const int cell_width = 24;
  std::printf("\n%s ns per step (ratio to %s at the same n, %s/%s)\n", use_min ? "Minimum" : "Median",
              table.reference.c_str(), use_min ? "min" : "median", use_min ? "min" : "median");
  std::printf("%-*s", label_width, "algorithm");
  for (int n : sizes)
  {
    std::printf(" | %-*s", cell_width, ("n = " + std::to_string(n)).c_str());
  }
  std::printf(" | target (%s)\n", table.targeted_text);
  std::printf("%s\n", std::string(label_width + sizes.size() * (cell_width + 3) + 19, '-').c_str());
  for (const Row& row : table.rows)
  {
    bool any = false;
    std::string line;
    char buf[128];
    std::snprintf(buf, sizeof(buf), "%-*s", label_width, row.label.c_str());
    line += buf;
    for (int n : sizes)
    {
      const auto it = timings.find(Key(row.bench, n));
      const auto base_it = timings.find(Key(table.reference, n));
      std::string cell = "-";
      if (it != timings.end())
      {
        any = true;
        if (!it->second.error.empty())
        {
          cell = "error";
        }
        else
        {
          const Stat s = summarise(it->second, row.per_component ? std::max(1.0, it->second.components) : 1.0);
          const Stat base = base_it != timings.end() ? summarise(base_it->second, 1.0) : Stat();
          cell = formatCell(s, base, use_min, row.target, table.targeted(n));
        }
      }
      std::snprintf(buf, sizeof(buf), " | %-*s", cell_width, cell.c_str());
      line += buf;
    }
    if (!any)
    {
      continue;
    }
    if (row.target > 0.0)
    {
      std::snprintf(buf, sizeof(buf), " | <= %.1fx", row.target);
      line += buf;
    }
    else
    {
      line += " |";
    }
    std::printf("%s\n", line.c_str());
  }
}

}  // namespace

void printSummary(const std::map<Key, Timing>& timings, bool cpu_time, std::size_t oe_components)
{
  Table dynamic_table;
  dynamic_table.reference = "baseline_kf";
  dynamic_table.targeted = [](int n) { return n >= 4; };
  dynamic_table.targeted_text = "n >= 4";
  dynamic_table.rows = {
      {"baseline_kf", "baseline_kf", false, 0.0},
      {"fixed_kf", "fixed_kf", false, 0.0},
      {"kf", "kf", false, 0.0},
      {"kfio", "kfio", false, 1.2},
      {"kfio_drop", "kfio_drop", false, 0.0},
      {"rseio_arrival", "rseio_arrival", false, 3.0},
      {"rseio_drop", "rseio_drop", false, 0.0},
      {"aoe", "aoe", false, 2.5},
      {"oe (per step)", "oe", false, 0.0},
      {"oe per component", "oe", true, 1.5},
  };
  // the fixed-size forms against the hand-written fixed-size filter (which exists for n = 2, 4, 8)
  Table fixed_table;
  fixed_table.reference = "fixed_kf";
  fixed_table.targeted = [](int n) { return n == 2 || n == 4; };
  fixed_table.targeted_text = "n = 2, 4";
  fixed_table.rows = {
      {"fixed_kf", "fixed_kf", false, 0.0},
      {"kf", "kf", false, 0.0},
      {"kf_dynamic", "kf_dynamic", false, 0.0},
      {"kfio", "kfio", false, 1.3},
      {"kfio_dynamic", "kfio_dynamic", false, 0.0},
      {"rseio_arrival", "rseio_arrival", false, 3.0},
      {"rseio_arrival_dyn", "rseio_arrival_dynamic", false, 0.0},
      {"aoe", "aoe", false, 2.0},
      {"aoe_dynamic", "aoe_dynamic", false, 0.0},
      {"fixed_riccati", "fixed_riccati", false, 0.0},
      {"kfio_cov_only", "kfio_covariance_only", false, 0.0},
  };
  std::vector<int> sizes;
  std::size_t reps = 0;
  for (const auto& kv : timings)
  {
    if (std::find(sizes.begin(), sizes.end(), kv.first.second) == sizes.end())
    {
      sizes.push_back(kv.first.second);
    }
    reps = std::max(reps, kv.second.reps.size());
  }
  std::sort(sizes.begin(), sizes.end());
  std::printf("\n==== Summary: one estimator step, m = n/2 (1 for n = 2), nw = n, p = 1, n_e = 1 ====\n");
  std::printf(
      "%zu repetition(s) per benchmark, %s time per step. Baseline: hand-written dynamic-size Eigen "
      "Kalman filter.\n",
      reps, cpu_time ? "CPU" : "real");
  const auto oe = std::find_if(timings.begin(), timings.end(), [](const auto& kv) { return kv.first.first == "oe"; });
  if (oe != timings.end())
  {
    std::printf("oe holds %.0f components in steady state (max_components = %zu).\n", oe->second.components,
                oe_components);
  }
  printTable(timings, dynamic_table, sizes, false);
  printTable(timings, dynamic_table, sizes, true);
  std::vector<int> fixed_sizes;
  for (int n : sizes)
  {
    if (timings.count(Key("fixed_kf", n)) != 0)
    {
      fixed_sizes.push_back(n);
    }
  }
  if (!fixed_sizes.empty())
  {
    std::printf(
        "\nEstimators in their fixed-size form at n = 2, 4 (dynamic at n = 8) against the hand-written "
        "fixed-size Kalman filter:\n");
    printTable(timings, fixed_table, fixed_sizes, false);
    printTable(timings, fixed_table, fixed_sizes, true);
  }
  Table omni_table;
  omni_table.reference = "kfio_omni";
  omni_table.targeted = [](int n) { return n == 8 || n == 15; };
  omni_table.targeted_text = "n = 8, 15";
  omni_table.rows = {
      {"kfio_omni", "kfio_omni", false, 0.0},
      {"ekfio_omni", "ekfio_omni", false, 2.0},
  };
  std::vector<int> omni_sizes;
  for (int n : sizes)
  {
    if (timings.count(Key("ekfio_omni", n)) != 0 || timings.count(Key("kfio_omni", n)) != 0)
    {
      omni_sizes.push_back(n);
    }
  }
  if (!omni_sizes.empty())
  {
    std::printf(
        "\nRobot motions (n = 8: omni_2d, m = 7; n = 15: omni_3d, m = 13): ekfio against kfio on the "
        "motion's linearisation, the same data:\n");
    printTable(timings, omni_table, omni_sizes, false);
    printTable(timings, omni_table, omni_sizes, true);
  }
  std::printf("\nPASS/MISS compares the ratio with the target; timing is informative only (exit code 0).\n");
}

}  // namespace bench
}  // namespace networked_estimation
