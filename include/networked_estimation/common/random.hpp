// A small, portable, seedable random number generator (xoshiro256++ seeded through splitmix64).
// Unlike std:: distributions, its output is identical on every platform and standard library,
// which is what makes simulations and channel drop sequences reproducible from a seed.
#pragma once

#include <cmath>
#include <cstdint>

namespace networked_estimation
{

/// splitmix64 finaliser: a good 64-bit mix; used to derive seeds.
inline std::uint64_t splitmix64(std::uint64_t& state)
{
  std::uint64_t z = (state += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

/// Seed of independent stream `stream` derived from a user seed.
inline std::uint64_t deriveSeed(std::uint64_t seed, std::uint64_t stream)
{
  std::uint64_t s = seed ^ (0xD1B54A32D192ED03ULL * (stream + 1));
  splitmix64(s);
  return splitmix64(s);
}

class Rng
{
public:
  explicit Rng(std::uint64_t seed = 0) { reseed(seed); }

  void reseed(std::uint64_t seed)
  {
    std::uint64_t sm = seed;
    for (auto& w : s_)
      w = splitmix64(sm);
    has_spare_ = false;
  }

  std::uint64_t next()
  {
    const std::uint64_t result = rotl(s_[0] + s_[3], 23) + s_[0];
    const std::uint64_t t = s_[1] << 17;
    s_[2] ^= s_[0];
    s_[3] ^= s_[1];
    s_[1] ^= s_[2];
    s_[0] ^= s_[3];
    s_[2] ^= t;
    s_[3] = rotl(s_[3], 45);
    return result;
  }

  /// Uniform in [0, 1) with 53 random bits.
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }

  /// Uniform in [a, b).
  double uniform(double a, double b) { return a + (b - a) * uniform(); }

  /// true with probability p (p <= 0: never, p >= 1: always).
  bool bernoulli(double p) { return uniform() < p; }

  /// Standard normal (Marsaglia polar method).
  double normal()
  {
    if (has_spare_)
    {
      has_spare_ = false;
      return spare_;
    }
    double u, v, s;
    do
    {
      u = 2.0 * uniform() - 1.0;
      v = 2.0 * uniform() - 1.0;
      s = u * u + v * v;
    } while (s >= 1.0 || s == 0.0);
    const double f = std::sqrt(-2.0 * std::log(s) / s);
    spare_ = v * f;
    has_spare_ = true;
    return u * f;
  }

private:
  static std::uint64_t rotl(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  std::uint64_t s_[4];
  double spare_ = 0.0;
  bool has_spare_ = false;
};

}  // namespace networked_estimation
