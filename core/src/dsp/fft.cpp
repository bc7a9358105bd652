#include "gearwatch/dsp/fft.hpp"

#include <fftw3.h>

#include <new>
#include <stdexcept>
#include <string>
#include <utility>

namespace gearwatch::dsp {

std::mutex& fftw_planner_mutex() {
  static std::mutex mutex;
  return mutex;
}

void* fftw_aligned_alloc(std::size_t bytes) {
  void* p = fftw_malloc(bytes == 0 ? 1 : bytes);
  if (p == nullptr) throw std::bad_alloc();
  return p;
}

void fftw_aligned_free(void* p) noexcept { fftw_free(p); }

namespace {

void require(bool ok, const char* what) {
  if (!ok) throw std::invalid_argument(what);
}

// FFTW's new-array execute requires the same alignment as the planning arrays, which come from
// fftw_malloc (alignment class 0).
void require_aligned(const void* p, const char* what) {
  require(fftw_alignment_of(const_cast<double*>(static_cast<const double*>(p))) == 0, what);
}

void destroy(void* plan) {
  if (plan != nullptr) {
    std::lock_guard lock(fftw_planner_mutex());
    fftw_destroy_plan(static_cast<fftw_plan>(plan));
  }
}

}  // namespace

FftwPlan::~FftwPlan() { destroy(plan_); }

FftwPlan& FftwPlan::operator=(FftwPlan&& other) noexcept {
  if (this != &other) {
    destroy(plan_);
    plan_ = std::exchange(other.plan_, nullptr);
    n_ = std::exchange(other.n_, 0);
  }
  return *this;
}

RealFft::RealFft(std::size_t n) {
  require(n >= 2, "RealFft: size must be at least 2");
  RealBuffer real(n);
  ComplexBuffer spectrum(n / 2 + 1);
  std::lock_guard lock(fftw_planner_mutex());
  const int size = static_cast<int>(n);
  forward_plan_ = FftwPlan(fftw_plan_dft_r2c_1d(size, real.data(), reinterpret_cast<fftw_complex*>(spectrum.data()),
                                                FFTW_ESTIMATE),
                           n);
  inverse_plan_ = FftwPlan(fftw_plan_dft_c2r_1d(size, reinterpret_cast<fftw_complex*>(spectrum.data()), real.data(),
                                                FFTW_ESTIMATE),
                           n);
  if (!forward_plan_ || !inverse_plan_) throw std::runtime_error("FFTW planning failed");
}

void RealFft::forward(std::span<const double> in, std::span<Complex> out) const {
  require(in.size() == size() && out.size() >= spectrum_size(), "RealFft::forward: buffer size mismatch");
  require_aligned(in.data(), "RealFft::forward: input not SIMD-aligned");
  require_aligned(out.data(), "RealFft::forward: output not SIMD-aligned");
  fftw_execute_dft_r2c(static_cast<fftw_plan>(forward_plan_.get()), const_cast<double*>(in.data()),
                       reinterpret_cast<fftw_complex*>(out.data()));
}

void RealFft::inverse(std::span<Complex> in, std::span<double> out) const {
  require(in.size() >= spectrum_size() && out.size() == size(), "RealFft::inverse: buffer size mismatch");
  require_aligned(in.data(), "RealFft::inverse: input not SIMD-aligned");
  require_aligned(out.data(), "RealFft::inverse: output not SIMD-aligned");
  fftw_execute_dft_c2r(static_cast<fftw_plan>(inverse_plan_.get()), reinterpret_cast<fftw_complex*>(in.data()),
                       out.data());
}

ComplexFft::ComplexFft(std::size_t n) {
  require(n >= 1, "ComplexFft: size must be at least 1");
  ComplexBuffer a(n), b(n);
  std::lock_guard lock(fftw_planner_mutex());
  const int size = static_cast<int>(n);
  auto* pa = reinterpret_cast<fftw_complex*>(a.data());
  auto* pb = reinterpret_cast<fftw_complex*>(b.data());
  forward_plan_ = FftwPlan(fftw_plan_dft_1d(size, pa, pb, FFTW_FORWARD, FFTW_ESTIMATE), n);
  backward_plan_ = FftwPlan(fftw_plan_dft_1d(size, pa, pb, FFTW_BACKWARD, FFTW_ESTIMATE), n);
  if (!forward_plan_ || !backward_plan_) throw std::runtime_error("FFTW planning failed");
}

namespace {
void execute_c2c(const FftwPlan& plan, std::span<const Complex> in, std::span<Complex> out) {
  require(in.size() == plan.size() && out.size() == plan.size(), "ComplexFft: buffer size mismatch");
  require(in.data() != out.data(), "ComplexFft: plans are out-of-place; input and output must differ");
  require_aligned(in.data(), "ComplexFft: input not SIMD-aligned");
  require_aligned(out.data(), "ComplexFft: output not SIMD-aligned");
  fftw_execute_dft(static_cast<fftw_plan>(plan.get()),
                   reinterpret_cast<fftw_complex*>(const_cast<Complex*>(in.data())),
                   reinterpret_cast<fftw_complex*>(out.data()));
}
}  // namespace

void ComplexFft::forward(std::span<const Complex> in, std::span<Complex> out) const {
  execute_c2c(forward_plan_, in, out);
}
void ComplexFft::backward(std::span<const Complex> in, std::span<Complex> out) const {
  execute_c2c(backward_plan_, in, out);
}

const RealFft& FftPlanCache::real(std::size_t n) {
  auto it = real_.find(n);
  if (it == real_.end()) it = real_.emplace(n, std::make_unique<RealFft>(n)).first;
  return *it->second;
}

const ComplexFft& FftPlanCache::complex(std::size_t n) {
  auto it = complex_.find(n);
  if (it == complex_.end()) it = complex_.emplace(n, std::make_unique<ComplexFft>(n)).first;
  return *it->second;
}

std::size_t next_power_of_two(std::size_t n) {
  std::size_t p = 1;
  while (p < n) p <<= 1;
  return p;
}

bool is_smooth_size(std::size_t n) {
  if (n == 0) return false;
  for (std::size_t f : {2u, 3u, 5u, 7u})
    while (n % f == 0) n /= f;
  return n == 1;
}

std::size_t previous_smooth_size(std::size_t n) {
  if (n <= 1) return 1;
  while (!is_smooth_size(n)) --n;
  return n;
}

std::size_t next_smooth_size(std::size_t n) {
  if (n <= 1) return 1;
  while (!is_smooth_size(n)) ++n;
  return n;
}

}  // namespace gearwatch::dsp
