// Quantiles of heavy-tailed Monte Carlo values without keeping every run's value: a histogram over
// logarithmic bins (the idea of DDSketch, Masson et al. 2019). A positive value v falls in bin
// i = ceil(log(v) / log(g)), g = (1 + a) / (1 - a), a = kRelativeError, the interval (g^(i-1), g^i];
// the bin's representative 2 g^i / (g + 1) is within a of every value in it. Negative values go to
// bins of |v|; zeros, infinities and NaN are counted apart.
//
// The counts are integers, so adding two sketches is exact and does not depend on the order: the
// sketch of a Monte Carlo call is the same however its runs were split over threads, blocks or
// shards (montecarlo_shards.hpp merges them by adding).
//
// At most kMaxBins bins per sign: when the values of one sign span more (about 18 decades), the
// bins of the smallest magnitudes are folded into the lowest bin kept, whose quantiles are then
// reported as NaN (not estimable) rather than wrong; the folding depends only on the values added.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace networked_estimation
{

class QuantileSketch
{
public:
  static constexpr double kRelativeError = 0.01;
  static constexpr int kMaxBins = 2048;

  void add(double v);
  /// Adds every value of `other` (exact).
  void merge(const QuantileSketch& other);

  /// Values added, NaN included.
  std::uint64_t count() const;
  std::uint64_t nanCount() const { return nan_; }

  /// The q-quantile, 0 <= q <= 1, of the values other than NaN: the value of rank floor(q (n - 1))
  /// (0-based) in increasing order, within kRelativeError of it (exactly for 0 and +-inf). NaN when
  /// there are no such values or the rank falls in a folded bin.
  double quantile(double q) const;

  /// The sketch as integers (shard files): zero, nan, +inf, -inf counts, then per sign (positive,
  /// negative) the folded flag, the lowest bin's index, the number of bins and their counts.
  std::vector<std::int64_t> encode() const;
  /// Inverse of encode(). Throws InputError naming `where` for a malformed list.
  static QuantileSketch decode(const std::vector<std::int64_t>& v, const std::string& where);

  bool operator==(const QuantileSketch& o) const;

private:
  /// Bins of one sign, indexed by the bin of |v|.
  class Store
  {
  public:
    void add(int key, std::uint64_t n);
    void merge(const Store& o);
    std::uint64_t total() const;
    bool empty() const { return max_ < min_; }
    bool folded() const { return folded_; }
    int minKey() const { return min_; }
    int maxKey() const { return max_; }
    std::uint64_t at(int key) const;
    void encode(std::vector<std::int64_t>& out) const;
    void decode(const std::vector<std::int64_t>& v, std::size_t& i, const std::string& where);
    bool operator==(const Store& o) const;

  private:
    void reserve(int lo, int hi);
    int lo_ = 0;                         ///< bin of counts_[0]
    std::vector<std::uint32_t> counts_;  ///< allocated bins (some empty)
    int min_ = 1, max_ = 0;              ///< the occupied bins (none while max_ < min_)
    bool folded_ = false;
  };

  Store pos_, neg_;
  std::uint64_t zero_ = 0, nan_ = 0, pinf_ = 0, ninf_ = 0;
};

}  // namespace networked_estimation
