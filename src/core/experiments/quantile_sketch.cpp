// Quantile sketch of heavy-tailed values (quantile_sketch.hpp).
#include "networked_estimation/experiments/quantile_sketch.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "networked_estimation/common/error.hpp"

namespace networked_estimation
{

namespace
{

const double kGamma = (1.0 + QuantileSketch::kRelativeError) / (1.0 - QuantileSketch::kRelativeError);
const double kInvLogGamma = 1.0 / std::log(kGamma);

/// The bin of a positive finite magnitude (the log of a double lies within +-745, so the bin fits an int).
int binOf(double magnitude)
{
  return static_cast<int>(std::ceil(std::log(magnitude) * kInvLogGamma));
}

/// The value that stands for bin i: 2 g^i / (g + 1), within the relative error of (g^(i-1), g^i].
double representative(int i)
{
  return 2.0 * std::pow(kGamma, static_cast<double>(i)) / (kGamma + 1.0);
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Store

void QuantileSketch::Store::reserve(int lo, int hi)
{
  // [lo, hi] holds every occupied bin (the caller's promise): the new allocation covers it, with
  // room on the side that grew (a value a little further out then costs no copy), at most kMaxBins
  // beyond it
  const int old_hi = lo_ + static_cast<int>(counts_.size()) - 1;
  if (!counts_.empty() && lo >= lo_ && hi <= old_hi)
    return;
  const int slack = std::min(kMaxBins, 16 + static_cast<int>(counts_.size()) / 2);
  const int new_lo = std::max(counts_.empty() || lo < lo_ ? lo - slack : lo_, lo - kMaxBins);
  const int new_hi = std::min(counts_.empty() || hi > old_hi ? hi + slack : old_hi, hi + kMaxBins);
  std::vector<std::uint32_t> c(static_cast<std::size_t>(new_hi - new_lo + 1), 0u);
  for (std::size_t i = 0; i < counts_.size(); ++i)
  {
    const int key = lo_ + static_cast<int>(i);
    if (counts_[i] != 0 && key >= new_lo && key <= new_hi)  // (an occupied bin always is)
      c[static_cast<std::size_t>(key - new_lo)] = counts_[i];
  }
  counts_.swap(c);
  lo_ = new_lo;
}

void QuantileSketch::Store::add(int key, std::uint64_t n)
{
  if (n == 0)
    return;
  // the usual case: a bin between the lowest kept and the highest so far, allocated
  if (key <= max_ && key >= max_ - kMaxBins + 1 && key >= lo_ && key >= min_)
  {
    counts_[static_cast<std::size_t>(key - lo_)] += static_cast<std::uint32_t>(n);
    return;
  }
  if (empty())
    min_ = max_ = key;
  const int new_max = std::max(max_, key);
  const int cut = new_max - kMaxBins + 1;  // the lowest bin kept
  std::uint64_t moved = 0;
  if (min_ < cut)
  {
    // the bins below the cut fold into it (taken out before the bins are moved)
    for (int k = min_; k < cut && k <= max_; ++k)
      if (k >= lo_ && k < lo_ + static_cast<int>(counts_.size()))
      {
        moved += counts_[static_cast<std::size_t>(k - lo_)];
        counts_[static_cast<std::size_t>(k - lo_)] = 0;
      }
    min_ = cut;
    folded_ = true;
  }
  if (key < cut)
  {
    key = cut;
    folded_ = true;
  }
  reserve(std::min(min_, key), new_max);
  max_ = new_max;
  if (moved > 0)
    counts_[static_cast<std::size_t>(cut - lo_)] += static_cast<std::uint32_t>(moved);
  counts_[static_cast<std::size_t>(key - lo_)] += static_cast<std::uint32_t>(n);
  min_ = std::min(min_, key);
}

void QuantileSketch::Store::merge(const Store& o)
{
  if (o.empty())
    return;
  for (int k = o.min_; k <= o.max_; ++k)
    add(k, o.at(k));
  folded_ = folded_ || o.folded_;
}

std::uint64_t QuantileSketch::Store::at(int key) const
{
  if (key < lo_ || key >= lo_ + static_cast<int>(counts_.size()))
    return 0;
  return counts_[static_cast<std::size_t>(key - lo_)];
}

std::uint64_t QuantileSketch::Store::total() const
{
  std::uint64_t t = 0;
  for (std::uint32_t c : counts_)
    t += c;
  return t;
}

void QuantileSketch::Store::encode(std::vector<std::int64_t>& out) const
{
  out.push_back(folded_ ? 1 : 0);
  if (empty())
  {
    out.push_back(0);
    out.push_back(0);
    return;
  }
  out.push_back(min_);
  out.push_back(max_ - min_ + 1);
  for (int k = min_; k <= max_; ++k)
    out.push_back(static_cast<std::int64_t>(at(k)));
}

void QuantileSketch::Store::decode(const std::vector<std::int64_t>& v, std::size_t& i, const std::string& where)
{
  auto next = [&]() -> std::int64_t
  {
    if (i >= v.size())
      throw InputError(where + ": the quantile sketch ends early");
    return v[i++];
  };
  const std::int64_t folded = next(), lo = next(), count = next();
  if ((folded != 0 && folded != 1) || count < 0 || count > kMaxBins || lo < -100000 || lo > 100000)
    throw InputError(where + ": malformed quantile sketch (folded " + std::to_string(folded) + ", lowest bin " +
                     std::to_string(lo) + ", " + std::to_string(count) + " bins)");
  *this = Store();
  for (std::int64_t k = 0; k < count; ++k)
  {
    const std::int64_t c = next();
    if (c < 0 || c > std::numeric_limits<std::uint32_t>::max())
      throw InputError(where + ": malformed quantile sketch (a count of " + std::to_string(c) + ")");
    add(static_cast<int>(lo + k), static_cast<std::uint64_t>(c));
  }
  folded_ = folded == 1;
}

bool QuantileSketch::Store::operator==(const Store& o) const
{
  if (empty() != o.empty() || folded_ != o.folded_)
    return false;
  if (empty())
    return true;
  if (min_ != o.min_ || max_ != o.max_)
    return false;
  for (int k = min_; k <= max_; ++k)
    if (at(k) != o.at(k))
      return false;
  return true;
}

// ---------------------------------------------------------------------------------------------
// Sketch

void QuantileSketch::add(double v)
{
  if (std::isnan(v))
    ++nan_;
  else if (v == 0.0)
    ++zero_;
  else if (std::isinf(v))
    ++(v > 0 ? pinf_ : ninf_);
  else if (v > 0)
    pos_.add(binOf(v), 1);
  else
    neg_.add(binOf(-v), 1);
}

void QuantileSketch::merge(const QuantileSketch& o)
{
  pos_.merge(o.pos_);
  neg_.merge(o.neg_);
  zero_ += o.zero_;
  nan_ += o.nan_;
  pinf_ += o.pinf_;
  ninf_ += o.ninf_;
}

std::uint64_t QuantileSketch::count() const
{
  return zero_ + nan_ + pinf_ + ninf_ + pos_.total() + neg_.total();
}

double QuantileSketch::quantile(double q) const
{
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::uint64_t n = count() - nan_;
  if (n == 0 || !(q >= 0.0 && q <= 1.0))
    return nan;
  std::uint64_t rank = static_cast<std::uint64_t>(std::floor(q * static_cast<double>(n - 1)));
  // increasing order: -inf, negatives from the largest magnitude down, zeros, positives, +inf
  if (rank < ninf_)
    return -std::numeric_limits<double>::infinity();
  rank -= ninf_;
  if (!neg_.empty())
    for (int k = neg_.maxKey(); k >= neg_.minKey(); --k)
    {
      const std::uint64_t c = neg_.at(k);
      if (rank < c)
        return neg_.folded() && k == neg_.minKey() ? nan : -representative(k);
      rank -= c;
    }
  if (rank < zero_)
    return 0.0;
  rank -= zero_;
  if (!pos_.empty())
    for (int k = pos_.minKey(); k <= pos_.maxKey(); ++k)
    {
      const std::uint64_t c = pos_.at(k);
      if (rank < c)
        return pos_.folded() && k == pos_.minKey() ? nan : representative(k);
      rank -= c;
    }
  return std::numeric_limits<double>::infinity();
}

std::vector<std::int64_t> QuantileSketch::encode() const
{
  std::vector<std::int64_t> out = {static_cast<std::int64_t>(zero_), static_cast<std::int64_t>(nan_),
                                   static_cast<std::int64_t>(pinf_), static_cast<std::int64_t>(ninf_)};
  pos_.encode(out);
  neg_.encode(out);
  return out;
}

QuantileSketch QuantileSketch::decode(const std::vector<std::int64_t>& v, const std::string& where)
{
  QuantileSketch s;
  if (v.size() < 4)
    throw InputError(where + ": the quantile sketch ends early");
  for (std::size_t i = 0; i < 4; ++i)
    if (v[i] < 0)
      throw InputError(where + ": malformed quantile sketch (a count of " + std::to_string(v[i]) + ")");
  s.zero_ = static_cast<std::uint64_t>(v[0]);
  s.nan_ = static_cast<std::uint64_t>(v[1]);
  s.pinf_ = static_cast<std::uint64_t>(v[2]);
  s.ninf_ = static_cast<std::uint64_t>(v[3]);
  std::size_t i = 4;
  s.pos_.decode(v, i, where);
  s.neg_.decode(v, i, where);
  if (i != v.size())
    throw InputError(where + ": " + std::to_string(v.size() - i) + " numbers after the quantile sketch");
  return s;
}

bool QuantileSketch::operator==(const QuantileSketch& o) const
{
  return zero_ == o.zero_ && nan_ == o.nan_ && pinf_ == o.pinf_ && ninf_ == o.ninf_ && pos_ == o.pos_ && neg_ == o.neg_;
}

}  // namespace networked_estimation
