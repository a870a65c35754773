// Draws a sensor schedule step by step (schedule_sampler.hpp).
#include "networked_estimation/simulation/schedule_sampler.hpp"

namespace networked_estimation
{

namespace
{

/// Index drawn from the probabilities `p` (a row or column), by inversion of one uniform.
int draw(Rng& rng, const Eigen::Ref<const Eigen::RowVectorXd>& p)
{
  const double u = rng.uniform();
  double acc = 0.0;
  for (Eigen::Index i = 0; i < p.size(); ++i)
  {
    acc += p[i];
    if (u < acc)
      return static_cast<int>(i);
  }
  // u within rounding of 1: the last subset with positive probability
  for (Eigen::Index i = p.size() - 1; i > 0; --i)
    if (p[i] > 0.0)
      return static_cast<int>(i);
  return 0;
}

}  // namespace

ScheduleSampler::ScheduleSampler(const Schedule& schedule, std::size_t sensors, std::uint64_t seed)
  : schedule_(&schedule), rng_(seed), mask_(sensors, true)
{
}

void ScheduleSampler::restart(std::uint64_t seed)
{
  rng_.reseed(seed);
  mask_.assign(mask_.size(), true);
  state_ = -1;
  k_ = 0;
}

const std::vector<bool>& ScheduleSampler::next()
{
  ++k_;
  switch (schedule_->kind)
  {
    case Schedule::Kind::NONE:
      break;
    case Schedule::Kind::PERIODIC:
      state_ = static_cast<int>((k_ - 1) % static_cast<long>(schedule_->pattern.size()));
      mask_ = schedule_->pattern[static_cast<std::size_t>(state_)];
      break;
    case Schedule::Kind::RANDOM:
      state_ = state_ < 0 ? draw(rng_, schedule_->initial.transpose()) : draw(rng_, schedule_->transition.row(state_));
      mask_ = schedule_->subsets[static_cast<std::size_t>(state_)];
      break;
  }
  return mask_;
}

}  // namespace networked_estimation
