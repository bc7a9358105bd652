#pragma once
// Time-synchronous averaging (thesis §4.3.2, §7.2) on angle-domain signals, and the residual:
// the raw signal minus the synchronous parts of both shafts of a gear pair.
#include <cstddef>
#include <span>
#include <vector>

#include "gearwatch/dsp/fft.hpp"

namespace gearwatch::dsp {

/// out[k] = mean over r of x[r*period + k], using every whole period in x.
/// Returns the number of periods averaged (0 when x is shorter than one period).
std::size_t time_synchronous_average(std::span<const double> x, std::size_t period, std::span<double> out);

/// The end taper SynchronousSeparation takes its averages with by default (see there).
inline constexpr double kSynchronousEndTaperFraction = 0.02;

/// The mean over the whole periods of x at each position, weighted by a Tukey window of
/// `end_taper_fraction` over those periods' samples (0: time_synchronous_average), into
/// out[0 .. period). Returns the number of periods averaged (0 when x is shorter than one period).
std::size_t tapered_synchronous_average(std::span<const double> x, std::size_t period, double end_taper_fraction,
                                        std::span<double> out);

/// Peak amplitudes of harmonics of `order` (in orders of the shaft the TSA belongs to) in a TSA
/// of one revolution: amplitude[h-1] = 2 |DFT(tsa)[h*order]| / size, h = 1..count. Harmonics at
/// or above the Nyquist order are returned as NaN.
void synchronous_harmonic_amplitudes(std::span<const double> tsa, int order, std::size_t count,
                                     FftPlanCache& plans, std::vector<double>& amplitudes);

/// RMS_SA(N) of thesis Eq. 7.1: sqrt(sum_{i=1..N} A_GMi^2), A = peak amplitudes of the first N
/// gear-mesh harmonics. Note the equation as printed omits the 1/2 of a sinusoid's mean square,
/// so this is sqrt(2) x the RMS of the mesh-harmonic-only TSA; we keep the thesis's form so values
/// compare with the thesis and with the twin (which must call this same function).
/// Throws std::invalid_argument if N exceeds the amplitudes given or any used amplitude is NaN.
double rms_sa(std::span<const double> gmf_amplitudes, std::size_t harmonics);

/// Separates an angle-domain record into the synchronous parts of both shafts and the residual.
/// Each TSA is a weighted mean over the revolutions, the weights a Tukey window over the whole
/// record (tapered_synchronous_average, kSynchronousEndTaperFraction by default): a plain mean of a record whose last sample does
/// not join its first carries (x[end] - x[0]) / R as a step at every revolution boundary of the
/// TSA, and the residual then holds a click train at the shaft period (in a band 60 dB below the
/// record it reads ICS2 ~ H). The weighted mean is still exact for any periodic content.
/// The output shaft's TSA is computed on the record resampled to the output shaft's angle; its
/// harmonics shared with the input shaft (the gear-mesh orders, multiples of z_gear/gcd output
/// orders) and its mean are removed so they are not subtracted twice, and it is brought onto the
/// input-angle grid exactly by FFT zero-padding: input sample j sits at output-angle index
/// j*z_pinion/g of a TSA upsampled z_gear/g times (g = gcd of the tooth counts).
class SynchronousSeparation {
 public:
  struct Result {
    std::size_t input_averages = 0;
    std::size_t output_averages = 0;
  };
  /// input_angle: whole input revolutions, samples_per_rev each; output_angle: whole output
  /// revolutions at the same samples_per_rev. residual gets input_angle.size() samples.
  Result separate(std::span<const double> input_angle, std::span<const double> output_angle,
                  std::size_t samples_per_rev, int pinion_teeth, int gear_teeth, FftPlanCache& plans,
                  std::span<double> residual);
  std::span<const double> input_tsa() const noexcept { return input_tsa_; }
  std::span<const double> output_tsa() const noexcept { return output_tsa_; }
  /// 0 gives the plain mean of time_synchronous_average.
  void set_end_taper_fraction(double fraction) noexcept { end_taper_fraction_ = fraction; }

 private:
  double end_taper_fraction_ = kSynchronousEndTaperFraction;
  RealBuffer input_tsa_, output_tsa_, upsampled_;
  ComplexBuffer spectrum_, padded_;
};

}  // namespace gearwatch::dsp
