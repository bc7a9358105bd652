#pragma once
// FFTW3 (double) wrappers. Plans are created once per size, through one process-wide mutex
// (FFTW's planner is not thread-safe), and executed with the new-array interface on buffers the
// caller owns, so one plan serves any number of records without allocating.
#include <complex>
#include <cstddef>
#include <map>
#include <memory>
#include <mutex>
#include <span>
#include <utility>
#include <vector>

namespace gearwatch::dsp {

using Complex = std::complex<double>;

/// The lock every fftw_plan_* / fftw_destroy_plan call in the process must hold.
std::mutex& fftw_planner_mutex();

/// Allocator returning fftw_malloc'd (SIMD-aligned) memory: buffers made with it may be given
/// to any plan below.
template <class T>
struct FftwAllocator {
  using value_type = T;
  FftwAllocator() = default;
  template <class U>
  FftwAllocator(const FftwAllocator<U>&) noexcept {}
  T* allocate(std::size_t n);
  void deallocate(T* p, std::size_t) noexcept;
  template <class U>
  bool operator==(const FftwAllocator<U>&) const noexcept { return true; }
};

void* fftw_aligned_alloc(std::size_t bytes);
void fftw_aligned_free(void* p) noexcept;

template <class T>
T* FftwAllocator<T>::allocate(std::size_t n) {
  return static_cast<T*>(fftw_aligned_alloc(n * sizeof(T)));
}
template <class T>
void FftwAllocator<T>::deallocate(T* p, std::size_t) noexcept {
  fftw_aligned_free(p);
}

using RealBuffer = std::vector<double, FftwAllocator<double>>;
using ComplexBuffer = std::vector<Complex, FftwAllocator<Complex>>;

/// Owns one FFTW plan of a transform size (an fftw_plan, kept as void* so that FFTW's header stays
/// out of this one): destroyed under fftw_planner_mutex(), movable (the moved-from handle holds no
/// plan and size 0), not copyable. Every FFT class holds its plans through it, so none writes its
/// own destructor or moves.
class FftwPlan {
 public:
  FftwPlan() = default;
  FftwPlan(void* plan, std::size_t n) noexcept : plan_(plan), n_(n) {}
  ~FftwPlan();
  FftwPlan(FftwPlan&& other) noexcept
      : plan_(std::exchange(other.plan_, nullptr)), n_(std::exchange(other.n_, 0)) {}
  FftwPlan& operator=(FftwPlan&& other) noexcept;
  FftwPlan(const FftwPlan&) = delete;
  FftwPlan& operator=(const FftwPlan&) = delete;

  void* get() const noexcept { return plan_; }
  std::size_t size() const noexcept { return n_; }
  explicit operator bool() const noexcept { return plan_ != nullptr; }

 private:
  void* plan_ = nullptr;
  std::size_t n_ = 0;
};

/// Real-to-complex forward and complex-to-real inverse transform of one size (unnormalised, as
/// FFTW: inverse(forward(x)) = n·x). Movable, not copyable.
class RealFft {
 public:
  explicit RealFft(std::size_t n);

  std::size_t size() const noexcept { return forward_plan_.size(); }
  std::size_t spectrum_size() const noexcept { return size() / 2 + 1; }
  /// in: size() samples; out: spectrum_size() bins. Both SIMD-aligned (RealBuffer/ComplexBuffer
  /// or an offset that keeps the alignment), else std::invalid_argument. Input is preserved.
  void forward(std::span<const double> in, std::span<Complex> out) const;
  /// in: spectrum_size() bins (destroyed: FFTW's c2r overwrites its input); out: size() samples.
  void inverse(std::span<Complex> in, std::span<double> out) const;

 private:
  FftwPlan forward_plan_;
  FftwPlan inverse_plan_;
};

/// Complex-to-complex transform of one size, out-of-place; sign -1 forward, +1 backward.
class ComplexFft {
 public:
  explicit ComplexFft(std::size_t n);

  std::size_t size() const noexcept { return forward_plan_.size(); }
  /// in and out must not overlap (out-of-place plans) and be aligned.
  void forward(std::span<const Complex> in, std::span<Complex> out) const;
  void backward(std::span<const Complex> in, std::span<Complex> out) const;

 private:
  FftwPlan forward_plan_;
  FftwPlan backward_plan_;
};

/// Plans keyed by size, created on first use and kept: after the first record of a given length
/// no plan is created and nothing is allocated. Not thread-safe itself (one per analyzer).
class FftPlanCache {
 public:
  const RealFft& real(std::size_t n);
  const ComplexFft& complex(std::size_t n);
  /// Sizes planned (real and complex).
  std::size_t size() const noexcept { return real_.size() + complex_.size(); }
  /// Drops every plan (references handed out before are left dangling).
  void clear() noexcept {
    real_.clear();
    complex_.clear();
  }

 private:
  std::map<std::size_t, std::unique_ptr<RealFft>> real_;
  std::map<std::size_t, std::unique_ptr<ComplexFft>> complex_;
};

/// Smallest power of two >= n (n >= 1).
std::size_t next_power_of_two(std::size_t n);
/// Smallest 2^a 3^b 5^c 7^d >= n (n >= 1): sizes FFTW transforms fast (FFTW falls back to slow
/// generic algorithms for large prime factors).
std::size_t next_smooth_size(std::size_t n);
/// Largest 2^a 3^b 5^c 7^d <= n (n >= 1).
std::size_t previous_smooth_size(std::size_t n);
bool is_smooth_size(std::size_t n);

}  // namespace gearwatch::dsp
