// Compile-time sizes of an estimator's matrices.
//
// Each algorithm is written once, as a class template on a Sizes type, and compiled for the general
// case (every size Eigen::Dynamic: heap storage, sizes known at run time) and for a few small models
// (fixed-size Eigen types: no heap, no size dispatch, products unrolled by the compiler; at n = 2 or
// 4 the dynamic types spend more time on size checks and dispatch than on the arithmetic).
// makeEstimator picks the fixed-size instantiation whose sizes match the model and falls back to
// the dynamic one for any other model.
//
// Quantities whose size varies from step to step (the rows of the sensors that arrived, the rank
// rho of rseio's sensitivity Gram matrices) keep the full compile-time size on the fixed path,
// padded with rows that contribute exact zeros (estimator_common.hpp, rseio.cpp); the dynamic path
// stores them compacted.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <string>
#include <utility>

#include "networked_estimation/config/model.hpp"

namespace networked_estimation
{
namespace detail
{

constexpr int kDynamic = Eigen::Dynamic;

/// A Rows x Cols double matrix (column major except for row vectors, as Eigen requires).
template <int Rows, int Cols>
using Mat = Eigen::Matrix<double, Rows, Cols, (Rows == 1 && Cols != 1) ? Eigen::RowMajor : Eigen::ColMajor>;

/// The sizes of one instantiation: n states (N), m measurement rows of all sensors together (M),
/// nw noise inputs (NW; only rseio's step uses them, the others leave it dynamic). Each is a number
/// or kDynamic. The number of control inputs p is always dynamic (it only enters through Bu u).
template <int N_, int M_, int NW_ = kDynamic>
struct Sizes
{
  static constexpr int N = N_;
  static constexpr int M = M_;
  static constexpr int NW = NW_;
  static constexpr bool kFixed = N_ != kDynamic;
  static_assert(kFixed == (M_ != kDynamic), "a fixed-size instantiation fixes n and m");

  using VecN = Mat<N, 1>;
  using MatN = Mat<N, N>;
  using MatNP = Mat<N, kDynamic>;  ///< Bu (p columns)
  using MatMN = Mat<M, N>;         ///< C
  using MatM = Mat<M, M>;          ///< R
  using VecM = Mat<M, 1>;

  /// Whether a model has these sizes (NW only when `with_nw`).
  static bool fits(const Model& model, bool with_nw)
  {
    if (!kFixed)
      return true;
    return model.n() == N && model.m() == M && (!with_nw || NW == kDynamic || model.nw() == NW);
  }

  /// "dynamic", or "fixed n=2 m=1" (with " nw=2" when NW is fixed).
  static std::string name()
  {
    if (!kFixed)
      return "dynamic";
    std::string s = "fixed n=" + std::to_string(N) + " m=" + std::to_string(M);
    if (NW != kDynamic)
      s += " nw=" + std::to_string(NW);
    return s;
  }
};

using DynamicSizes = Sizes<kDynamic, kDynamic, kDynamic>;

/// A list of instantiated sizes.
template <class... S>
struct SizeList
{
};

/// The fixed-size instantiations of kf, kfio, ack_kf, aoe and oe: the sizes of the shipped models
/// and of the measurements (n = 1 with m = 1 or 2, n = 2 with m = 1 or 2, n = 4 with m = 2 or 4).
/// Each size adds about 8 s of compile time (kalman.cpp and aoe.cpp together; an rseio size about
/// 7 s), so the lists stay short; every other size runs the dynamic form.
// clang-format off
using KalmanSizes = SizeList<
    Sizes<1, 1>, Sizes<1, 2>,
    Sizes<2, 1>, Sizes<2, 2>,
    Sizes<4, 2>, Sizes<4, 4>>;
// clang-format on

/// The fixed-size instantiations of rseio (nw enters its step): n = 1 and 2 with m = 1, n = 2 with
/// m = 2 and n = 4 with m = 2, each with nw = n (a model file's default B = I).
// clang-format off
using RseioSizes = SizeList<
    Sizes<1, 1, 1>,
    Sizes<2, 1, 2>, Sizes<2, 2, 2>,
    Sizes<4, 2, 4>>;
// clang-format on

/// Which form a factory builds: the fixed-size one when the model's sizes are instantiated
/// (makeEstimator's choice), or always the dynamic one (tests and measurements compare the two).
enum class SizeChoice
{
  AUTOMATIC,
  DYNAMIC
};

/// Builds Impl<S> for the first S of the list that fits the model (Impl<DynamicSizes> when none
/// does, or for SizeChoice::DYNAMIC) from the arguments (model first).
template <template <class> class Impl, class Base, class... Args>
std::unique_ptr<Base> makeSized(SizeList<>, SizeChoice /*choice*/, bool /*with_nw*/, const Model& model, Args&&... args)
{
  return std::make_unique<Impl<DynamicSizes>>(model, std::forward<Args>(args)...);
}

template <template <class> class Impl, class Base, class S, class... Rest, class... Args>
std::unique_ptr<Base> makeSized(SizeList<S, Rest...>, SizeChoice choice, bool with_nw, const Model& model,
                                Args&&... args)
{
  if (choice == SizeChoice::AUTOMATIC && S::fits(model, with_nw))
    return std::make_unique<Impl<S>>(model, std::forward<Args>(args)...);
  return makeSized<Impl, Base>(SizeList<Rest...>(), choice, with_nw, model, std::forward<Args>(args)...);
}

}  // namespace detail
}  // namespace networked_estimation
