// A recorded link and its expected messages (link_trace.hpp).
#include "networked_estimation/link/link_trace.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <numeric>
#include <sstream>

#include "io/csv_cells.hpp"
#include "networked_estimation/common/error.hpp"
#include "networked_estimation/io/atomic_file.hpp"
#include "networked_estimation/io/ros_bag.hpp"

namespace networked_estimation
{
namespace link_trace_detail
{

std::string seconds(double v)
{
  std::ostringstream os;
  os.precision(4);
  os << v;
  return os.str();
}

/// The column of `name` in a header, or npos.
std::size_t column(const std::vector<std::string>& header, const std::string& name)
{
  const auto it = std::find(header.begin(), header.end(), name);
  return it == header.end() ? std::string::npos : static_cast<std::size_t>(it - header.begin());
}

/// The period of stamps that step by whole multiples of it: first the median of the short steps
/// (those between half and 1.5 times the 10th percentile step), then refined as the sum of the
/// steps of 1 to 4 periods over their number of periods until it settles, and last over all the
/// steps (the span of the stamps over the slots it holds).
double learnPeriod(const std::vector<double>& steps)
{
  if (steps.empty())
    return 0.0;
  std::vector<double> s = steps;
  const std::size_t q = s.size() / 10;
  std::nth_element(s.begin(), s.begin() + static_cast<std::ptrdiff_t>(q), s.end());
  const double low = s[q];
  std::vector<double> near;
  for (double d : steps)
    if (d >= 0.5 * low && d <= 1.5 * low)
      near.push_back(d);
  std::nth_element(near.begin(), near.begin() + static_cast<std::ptrdiff_t>(near.size() / 2), near.end());
  double t = near[near.size() / 2];
  for (int iteration = 0; iteration < 20; ++iteration)
  {
    double sum = 0.0, periods = 0.0;
    for (double d : steps)
    {
      const double k = std::round(d / t);
      if (k >= 1.0 && k <= 4.0)
      {
        sum += d;
        periods += k;
      }
    }
    const double next = periods > 0.0 ? sum / periods : t;
    const bool settled = std::abs(next - t) <= 1e-12 * t;
    t = next;
    if (settled)
      break;
  }
  double sum = 0.0, periods = 0.0;
  for (double d : steps)
  {
    sum += d;
    periods += std::max(1.0, std::round(d / t));
  }
  return sum / periods;
}

/// Fraction of steps that are not within 0.4 periods of a whole, positive number of periods.
double irregularFraction(const std::vector<double>& steps, double period)
{
  if (steps.empty())
    return 0.0;
  std::size_t bad = 0;
  for (double d : steps)
  {
    const double k = d / period;
    if (k < 0.5 || std::abs(k - std::round(k)) > 0.4)
      ++bad;
  }
  return static_cast<double>(bad) / static_cast<double>(steps.size());
}

std::string hz(double period)
{
  return seconds(1.0 / period) + " Hz";
}

}  // namespace link_trace_detail

using link_trace_detail::seconds;

std::size_t SlotTrace::received() const
{
  return static_cast<std::size_t>(std::count(arrived.begin(), arrived.end(), std::uint8_t(1)));
}

LinkRecord readLinkCsv(const std::string& path)
{
  std::ifstream file;
  csv::openInput(file, path);
  csv::LineReader reader(file, path);
  const std::vector<std::string> header = csv::readHeader(reader, path, "stamp,receipt[,seq]");
  const std::size_t cs = link_trace_detail::column(header, "stamp"), cr = link_trace_detail::column(header, "receipt"),
                    cq = link_trace_detail::column(header, "seq");
  if (cs == std::string::npos || cr == std::string::npos)
    csv::failRaw(path, 1, cs == std::string::npos ? "stamp" : "receipt", "missing column",
                 "a header naming the columns stamp and receipt (and optionally seq)", csv::joinNames(header));
  LinkRecord r;
  r.source = path;
  std::vector<std::string> cells;
  long line = 0;
  while (reader.next(cells, line))
  {
    csv::checkCount(path, line, cells, header);
    r.stamp.push_back(csv::parseNumber(path, line, "stamp", cells[cs]));
    r.receipt.push_back(csv::parseNumber(path, line, "receipt", cells[cr]));
    if (cq != std::string::npos)
    {
      long v = 0;
      if (!csv::parseLong(cells[cq], v) || v < 0 || v > static_cast<long>(std::numeric_limits<std::uint32_t>::max()))
        csv::fail(path, line, "seq", "not a sequence number", "an integer in [0, 2^32)", cells[cq]);
      r.seq.push_back(static_cast<std::uint32_t>(v));
    }
  }
  return r;
}

void writeLinkCsv(const LinkRecord& record, const std::string& path)
{
  AtomicFile out(path);
  std::ostream& os = out.stream();
  os << std::setprecision(17);
  const bool seq = !record.seq.empty();
  os << (seq ? "stamp,receipt,seq\n" : "stamp,receipt\n");
  for (std::size_t i = 0; i < record.stamp.size(); ++i)
  {
    os << record.stamp[i] << ',' << record.receipt[i];
    if (seq)
      os << ',' << record.seq[i];
    os << '\n';
  }
  out.commit();
}

std::vector<LinkRecord> readBagLinks(const std::string& path, const std::vector<std::string>& topics)
{
  const RosBag bag(path);
  std::vector<BagTopicHeaders> headers = bag.headers(topics);
  std::vector<LinkRecord> out;
  for (BagTopicHeaders& h : headers)
  {
    if (!h.has_header)
      throw InputError(path + ": topic " + h.topic + " (" + h.type +
                       ") has no header stamps: its type does not start with a std_msgs/Header, so the expected "
                       "messages and their delays cannot be found");
    LinkRecord r;
    r.source = path + ", topic " + h.topic;
    r.stamp = std::move(h.stamp);
    r.receipt = std::move(h.receipt);
    r.seq = std::move(h.seq);
    out.push_back(std::move(r));
  }
  return out;
}

ClockMode clockModeOf(const std::string& text, const std::string& what)
{
  if (text == "auto")
    return ClockMode::AUTO;
  if (text == "same")
    return ClockMode::SAME;
  if (text == "different")
    return ClockMode::DIFFERENT;
  throw InputError(what + ": expected auto, same or different, found '" + text + "'");
}

SlotTrace analyseLink(const LinkRecord& rec, const TraceOptions& o)
{
  using namespace link_trace_detail;
  const std::string& src = rec.source;
  const std::size_t n = rec.stamp.size();
  if (rec.receipt.size() != n || (!rec.seq.empty() && rec.seq.size() != n))
    throw InputError(src + ": " + std::to_string(n) + " stamps but " + std::to_string(rec.receipt.size()) +
                     " receipt times");
  if (n < o.min_messages)
    throw InputError(src + ": " + std::to_string(n) + " messages, fewer than the " + std::to_string(o.min_messages) +
                     " a fit needs: record longer");
  if (!(o.rate >= 0.0) || !std::isfinite(o.rate))
    throw InputError(src + ": rate: expected a positive number of Hz, found " + seconds(o.rate));
  std::size_t zero = 0;
  for (std::size_t i = 0; i < n; ++i)
  {
    if (!std::isfinite(rec.stamp[i]) || !std::isfinite(rec.receipt[i]))
      throw InputError(src + ": message " + std::to_string(i) + ": stamp or receipt time is not finite");
    zero += rec.stamp[i] == 0.0 ? 1 : 0;
  }
  if (zero > 0)
    throw InputError(src + ": " + std::to_string(zero) + " of " + std::to_string(n) +
                     " messages have header.stamp 0: the publisher does not stamp them, so their expected times and "
                     "delays are unknown");

  // The messages in stamp order (receipt order among equal stamps).
  std::vector<std::size_t> by_stamp(n);
  std::iota(by_stamp.begin(), by_stamp.end(), 0);
  std::stable_sort(by_stamp.begin(), by_stamp.end(),
                   [&](std::size_t a, std::size_t b) { return rec.stamp[a] < rec.stamp[b]; });
  std::vector<double> steps;  // between consecutive distinct stamps
  for (std::size_t i = 1; i < n; ++i)
  {
    const double d = rec.stamp[by_stamp[i]] - rec.stamp[by_stamp[i - 1]];
    if (d > 0.0)
      steps.push_back(d);
  }
  if (steps.size() + 1 < o.min_messages)
    throw InputError(src + ": " + std::to_string(steps.size() + 1) + " distinct stamps, fewer than the " +
                     std::to_string(o.min_messages) + " a fit needs");
  const double learnt = learnPeriod(steps);

  SlotTrace t;
  t.source = src;
  t.messages = n;
  std::vector<long long> slot(n, 0);
  bool by_seq = false;
  if (o.use_seq && !rec.seq.empty())
  {
    // header.seq: used when it increases with the stamps (a copy keeps both) in 99 % of the steps,
    // from the first stamp's number (the smallest) to the last's (the largest), and the numbers
    // count the stamps' periods: over the whole record, one number per period of the typical step
    // (the median of stamp step / number step) within 1 %. How far single steps go is not asked: a
    // sender late by a few periods (a loaded machine) that then catches up still numbers its
    // messages one by one. A restart (the numbers go back) or several publishers (interleaved
    // numbers) break the order; a relay that numbers what it forwards (every roscpp publisher writes
    // its own count into header.seq) hides the losses before it: its numbers then count fewer
    // periods than the stamps (by the loss rate before it).
    std::size_t agree = 0, pairs = 0;
    const std::uint32_t lo = *std::min_element(rec.seq.begin(), rec.seq.end());
    const std::uint32_t hi = *std::max_element(rec.seq.begin(), rec.seq.end());
    const bool first_to_last = rec.seq[by_stamp[0]] == lo && rec.seq[by_stamp[n - 1]] == hi;
    std::vector<double> per_number;  // stamp step / number step
    for (std::size_t i = 1; i < n && lo != hi; ++i)
    {
      const std::size_t a = by_stamp[i - 1], b = by_stamp[i];
      const double ds = rec.stamp[b] - rec.stamp[a];
      const double dq = static_cast<double>(rec.seq[b]) - static_cast<double>(rec.seq[a]);
      ++pairs;
      if (ds == 0.0 ? dq == 0.0 : dq >= 1.0)
        ++agree;
      if (ds > 0.0 && dq >= 1.0)
        per_number.push_back(ds / dq);
    }
    const double seq_period =
        lo != hi ? (rec.stamp[by_stamp[n - 1]] - rec.stamp[by_stamp[0]]) / (static_cast<double>(hi) - lo) : 0.0;
    // The typical step: the median of those within half a period of the numbers' period (a late
    // message's long step and the short steps of catching up left out).
    double typical = 0.0;
    std::vector<double> near;
    for (double d : per_number)
      if (std::abs(d / seq_period - 1.0) <= 0.5)
        near.push_back(d);
    if (!near.empty())
    {
      const auto mid = near.begin() + static_cast<std::ptrdiff_t>(near.size() / 2);
      std::nth_element(near.begin(), mid, near.end());
      typical = *mid;
    }
    const bool counts_periods = seq_period > 0.0 && typical > 0.0 && std::abs(typical / seq_period - 1.0) <= 0.01;
    if (lo == hi)
      t.note = "header.seq not used: it does not change (the publisher does not number its messages)";
    else if (!first_to_last || static_cast<double>(agree) < 0.99 * static_cast<double>(pairs))
    {
      std::ostringstream os;
      os << "header.seq not used: it increases with the stamps in " << agree << " of " << pairs << " steps";
      if (!first_to_last)
        os << " and does not run from the first stamp's number to the last's";
      os << " (a publisher restarted, or several publishers)";
      t.note = os.str();
    }
    else if (!counts_periods)
    {
      std::ostringstream os;
      os << "header.seq not used: it numbers " << std::setprecision(4) << 100.0 * typical / seq_period
         << " % of the stamps' periods (a relay that numbers what it forwards, as every roscpp publisher does, "
            "hides the losses before it)";
      t.note = os.str();
    }
    else
    {
      by_seq = true;
      const std::uint32_t first = rec.seq[by_stamp[0]];
      for (std::size_t i = 0; i < n; ++i)
        slot[i] = static_cast<long long>(rec.seq[i]) - static_cast<long long>(first);
      t.period = seq_period;
      t.slots_from = "header.seq";
    }
  }
  if (o.rate > 0.0)
  {
    const double given = 1.0 / o.rate;
    const double found = by_seq ? t.period : learnt;
    if (std::abs(found / given - 1.0) > 0.1)
      throw InputError(src + ": --rate " + seconds(o.rate) + " Hz contradicts the " +
                       (by_seq ? "header.seq numbers and stamps" : "stamps") + ": they step by " + seconds(found) +
                       " s (" + hz(found) + ")");
    if (!by_seq)
    {
      t.period = given;
      t.slots_from = "the stamps (--rate)";
    }
  }
  else if (!by_seq)
  {
    t.period = learnt;
    t.slots_from = "the stamps (rate learnt from them)";
  }
  if (!by_seq)
  {
    const double irregular = irregularFraction(steps, t.period);
    if (irregular > 0.05)
    {
      std::ostringstream os;
      os << src << ": the stamps are not periodic: " << std::setprecision(3) << 100.0 * irregular
         << " % of their steps are not a whole number of periods of " << seconds(t.period) << " s (" << hz(t.period)
         << ")";
      if (o.rate > 0.0)
        os << " (--rate)";
      os << "; without header.seq the expected messages cannot be found";
      throw InputError(os.str());
    }
    long long k = 0;
    slot[by_stamp[0]] = 0;
    for (std::size_t i = 1; i < n; ++i)
    {
      const double d = rec.stamp[by_stamp[i]] - rec.stamp[by_stamp[i - 1]];
      if (d > 0.0)
        k += std::max(1LL, static_cast<long long>(std::llround(d / t.period)));
      slot[by_stamp[i]] = k;
    }
  }
  const long long first_slot = slot[by_stamp[0]];
  long long last_slot = first_slot;
  for (std::size_t i = 0; i < n; ++i)
    last_slot = std::max(last_slot, slot[i]);
  const long long span = last_slot - first_slot + 1;
  if (span > 100 * static_cast<long long>(n) + 1000)
    throw InputError(src + ": the stamps span " + std::to_string(span) + " expected messages at " + hz(t.period) +
                     " for " + std::to_string(n) +
                     " received (over 99 % lost): a wrong rate, or a publisher that "
                     "paused");
  t.first_stamp = rec.stamp[by_stamp[0]];
  const std::size_t slots = static_cast<std::size_t>(span);
  t.arrived.assign(slots, 0);
  t.delay.assign(slots, 0.0);
  t.copies.assign(slots, 0);

  // In receipt order: first copies, duplicates, reordering; the raw delays receipt - stamp.
  std::vector<std::size_t> by_receipt(n);
  std::iota(by_receipt.begin(), by_receipt.end(), 0);
  std::stable_sort(by_receipt.begin(), by_receipt.end(),
                   [&](std::size_t a, std::size_t b) { return rec.receipt[a] < rec.receipt[b]; });
  long long highest = -1;
  double smallest = std::numeric_limits<double>::infinity();
  for (std::size_t i : by_receipt)
  {
    const std::size_t s = static_cast<std::size_t>(slot[i] - first_slot);
    if (t.copies[s] < 255)
      ++t.copies[s];
    if (t.arrived[s])
    {
      ++t.duplicates;
      continue;
    }
    t.arrived[s] = 1;
    t.delay[s] = rec.receipt[i] - rec.stamp[i];
    smallest = std::min(smallest, t.delay[s]);
    t.receipt_order.push_back(s);
    if (static_cast<long long>(s) < highest)
      ++t.reordered;
    highest = std::max(highest, static_cast<long long>(s));
  }

  // The clocks.
  const bool negative = smallest < 0.0;
  if (o.clock == ClockMode::SAME && negative)
    throw InputError(src + ": a message was received " + seconds(-smallest) +
                     " s before its stamp: the sender's and the recorder's clocks differ (use the clock mode "
                     "'different': only the delays relative to the smallest are then known)");
  if (o.clock == ClockMode::DIFFERENT || (o.clock == ClockMode::AUTO && negative))
  {
    t.relative_delay = true;
    t.clock_offset = smallest;
    t.clock_note = std::string(o.clock == ClockMode::AUTO ? "some messages were received before their stamps, so "
                                                            "the clocks differ"
                                                          : "the clocks differ (as told)") +
                   ": receipt - stamp includes their unknown offset, and only the delay relative to the smallest "
                   "one is identifiable; the delays are relative to it (offset taken as " +
                   seconds(smallest) + " s)";
    for (std::size_t s : t.receipt_order)
      t.delay[s] -= smallest;
  }
  else
  {
    t.clock_note = o.clock == ClockMode::SAME ? "one clock (as told): the delays are receipt - stamp"
                                              : "one clock assumed (no message was received before its stamp): the "
                                                "delays are receipt - stamp";
    if (smallest > 1.0)
      t.clock_note += "; the smallest delay is " + seconds(smallest) +
                      " s: if the sender's clock is behind the recorder's, use the clock mode 'different'";
  }
  return t;
}

bool isEventsCsv(const std::string& path)
{
  std::ifstream file(path);
  std::string line;
  if (!file || !std::getline(file, line))
    return false;
  return line.find("field.outcome") != std::string::npos;
}

SlotTrace readEventSlots(const std::string& path, std::size_t min_messages)
{
  using link_trace_detail::column;
  std::ifstream file;
  csv::openInput(file, path);
  csv::LineReader reader(file, path);
  const std::vector<std::string> header =
      csv::readHeader(reader, path, "`rostopic echo -p` of a LossyChannel's ~events");
  const std::size_t c_seq = column(header, "field.seq"), c_out = column(header, "field.outcome"),
                    c_dup = column(header, "field.duplicated"), c_delay = column(header, "field.delay"),
                    c_time = column(header, "field.header.stamp");
  for (const auto& need : {std::make_pair("field.seq", c_seq), std::make_pair("field.outcome", c_out),
                           std::make_pair("field.duplicated", c_dup), std::make_pair("field.delay", c_delay),
                           std::make_pair("field.header.stamp", c_time)})
    if (need.second == std::string::npos)
      csv::failRaw(path, 1, need.first, "missing column",
                   "`rostopic echo -p` of a LossyChannel's ~events (networked_estimation/ChannelEvent)",
                   csv::joinNames(header));
  SlotTrace t;
  t.source = path;
  t.slots_from = "the channel's events";
  t.clock_note = "the channel's own record of the delays it gave";
  std::vector<std::string> cells;
  long line = 0;
  long long expected_seq = -1;
  double first_time = 0.0, last_time = 0.0;
  while (reader.next(cells, line))
  {
    csv::checkCount(path, line, cells, header);
    long seq = 0;
    if (!csv::parseLong(cells[c_seq], seq) || seq < 0)
      csv::fail(path, line, "field.seq", "not a sequence number", "a non-negative integer", cells[c_seq]);
    if (expected_seq >= 0 && seq != expected_seq)
      csv::fail(path, line, "field.seq", "events missing or out of order",
                "the next sequence number " + std::to_string(expected_seq), cells[c_seq]);
    expected_seq = seq + 1;
    const std::string& o = cells[c_out];
    if (o != "0" && o != "1" && o != "2")
      csv::fail(path, line, "field.outcome", "unknown outcome", "0 (delivered), 1 or 2 (dropped)", o);
    const std::string& d = cells[c_dup];
    const bool dup = d == "True" || d == "1" || d == "true";
    if (!dup && d != "False" && d != "0" && d != "false")
      csv::fail(path, line, "field.duplicated", "not a boolean", "True or False", d);
    const double delay = csv::parseNumber(path, line, "field.delay", cells[c_delay]);
    const double time = 1e-9 * csv::parseNumber(path, line, "field.header.stamp", cells[c_time]);
    if (t.arrived.empty())
      first_time = time;
    last_time = time;
    const bool arrived = o == "0";
    t.arrived.push_back(arrived ? 1 : 0);
    t.delay.push_back(arrived ? delay : 0.0);
    t.copies.push_back(arrived ? (dup ? 2 : 1) : 0);
    t.duplicates += arrived && dup ? 1 : 0;
    if (arrived)
      t.receipt_order.push_back(t.arrived.size() - 1);
  }
  t.messages = t.received() + t.duplicates;
  if (t.arrived.size() < min_messages)
    throw InputError(path + ": " + std::to_string(t.arrived.size()) + " events, fewer than the " +
                     std::to_string(min_messages) + " a fit needs: record longer");
  t.period = t.arrived.size() > 1 ? (last_time - first_time) / static_cast<double>(t.arrived.size() - 1) : 0.0;
  t.first_stamp = first_time;
  // In the channel's own delivery order (due = offer + delay).
  std::stable_sort(
      t.receipt_order.begin(), t.receipt_order.end(),
      [&](std::size_t a, std::size_t b)
      { return static_cast<double>(a) * t.period + t.delay[a] < static_cast<double>(b) * t.period + t.delay[b]; });
  long long highest = -1;
  for (std::size_t s : t.receipt_order)
  {
    t.reordered += static_cast<long long>(s) < highest ? 1 : 0;
    highest = std::max(highest, static_cast<long long>(s));
  }
  return t;
}

}  // namespace networked_estimation
