#pragma once
// The order-tracked spectra the gap diagnosis compares: one record's synchronous lines on the
// input and the output shaft and its non-synchronous (broadband) part, kept per revolution so
// that a block bootstrap over revolutions can redraw them, and the families the lines and bins
// belong to. Pure computation on core's order tracking and FFTW plans.
#include <array>
#include <complex>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <random>
#include <span>
#include <string>
#include <vector>

#include "gearwatch/gearbox_spec.hpp"
#include "gearwatch/types/gap_report.hpp"
#include "gearwatch/types/record.hpp"

namespace gearwatch::gap {

/// What a run-out of one metre on one shaft does to a record's mesh (run_out_sensitivity()): mesh
/// harmonic n of power P gets ((a·e)² + (n·b·e)²)/4 · P on each first sideband (n·z ± 1 of that
/// shaft) for a run-out e, a the mesh-force modulation index and n·b the mesh-phase modulation
/// (rad) the order tracking keeps, per metre. Zero: not known (the run-out adds nothing).
struct RunOutSensitivity {
  double am_per_m = 0;
  double pm_per_harmonic_per_m = 0;
};

/// How the twin's synchronous lines (complex peak amplitudes, phased on the tacho) change per metre
/// of run-out, read off twin runs with a run-out (run_out_response()): a small run-out enters every
/// pair's compression additively, so the lines are linear in it. Index [0] is the pinion's run-out
/// at phase 0, [1] at phase π/2, [2] and [3] the gear's; a run-out e at phase φ adds
/// e·(cos φ·[0] + sin φ·[1]) (resp. [2], [3]). Input lines [k-1] are input order k, output lines
/// [m-1] output order m.
struct RunOutResponse {
  std::array<std::vector<std::complex<double>>, 4> input_per_m, output_per_m;
};

/// The twin's vertical bearing forces on the casing per metre of its sensor DOF's displacement
/// (Σ k_i y_i / y6, complex, N/m) when the mesh drives the gearbox at f, tabulated in log f
/// (bearing_force_path() builds it from the twin's linearised model). Every line of the twin's
/// record is driven through the mesh, so a casing on the bearings adds its response to the
/// sensor's in this ratio at every line. Shared by all the summaries of a diagnosis.
class BearingForcePath {
 public:
  BearingForcePath(double lowest_hz, double points_per_octave, std::vector<std::complex<double>> ratio);
  /// Linear in log f between the table's points; the end values beyond them.
  std::complex<double> at(double hz) const noexcept;
  double lowest_hz() const noexcept { return lowest_hz_; }
  double highest_hz() const noexcept;

 private:
  double lowest_hz_, points_per_octave_;
  std::vector<std::complex<double>> ratio_;
};

/// The power (peak amplitude², (m/s²)²) of every line and broadband bin of one record, with the
/// record's operating point. Lines are synchronous averages over whole revolutions of one shaft,
/// read after the other shaft's synchronous average is removed; broadband is the residual of both
/// (dsp::SynchronousSeparation) in 2-revolution Hann-windowed blocks minus their average, per
/// 1-order bin [k, k+1) (two half-order bins). The window keeps strong non-synchronous tones from
/// leaking far (a one-revolution rectangular window spreads them as 1/Δ² over the whole band).
struct SpectralSummary {
  double speed_hz = 0;            ///< mean input speed from the tacho
  double torque_nm = std::numeric_limits<double>::quiet_NaN();  ///< the record's input torque (NaN: none)
  double sample_rate_hz = 0;
  std::size_t input_revolutions = 0;
  std::size_t output_revolutions = 0;
  /// Effective number of averages of the (Hann-weighted) line estimates: a white floor N0 per bin
  /// adds N0 / this to each line.
  double input_line_averages = 1, output_line_averages = 1;
  std::vector<double> input_lines;    ///< [k-1]: integer input order k = 1..K_in
  std::vector<double> output_lines;   ///< [m-1]: integer output order m = 1..K_out (mesh orders hold 0, unused)
  std::vector<double> broadband;      ///< [k-1]: non-synchronous power in orders [k, k+1) (2-revolution Hann blocks)
  /// For a twin's record: its response to a run-out of the pinion (input) and of the gear (output)
  /// shaft at this operating point (RecordSpectra::set_run_out_sensitivity).
  RunOutSensitivity pinion_run_out, gear_run_out;
  /// For a twin's record: its bearing-force path (RecordSpectra::set_bearing_force_path); null: not known.
  std::shared_ptr<const BearingForcePath> bearing_force_path;
  /// For a twin's record: its lines' response to a run-out (RecordSpectra::set_run_out_response);
  /// null: not known (the eccentricity form then uses the run-out sensitivities).
  std::shared_ptr<const RunOutResponse> run_out_response;
};

/// The angle grids RecordSpectra reduces a record on: whole revolutions of each shaft, samples a
/// revolution of each (spr, spr_out), the lines each keeps and the input's mean speed. Throws as
/// RecordSpectra's constructor does for an unusable tacho or too few revolutions.
struct ReductionGrid {
  std::size_t input_revolutions = 0, output_revolutions = 0, spr = 0, spr_out = 0, k_in = 0, k_out = 0;
  double speed_hz = 0;
};
ReductionGrid reduction_grid(std::span<const double> tacho_edges, double sample_rate_hz, const GearPairSpec& gears,
                             std::size_t min_revolutions = 4);

/// One record reduced to per-revolution spectra (so a bootstrap can redraw revolutions).
class RecordSpectra {
 public:
  /// Order-tracks `channel` of the record on the input and the output shaft (tacho 0, one edge per
  /// revolution unless given). Throws std::invalid_argument naming the reason when the record cannot
  /// be analysed: no tacho, irregular tacho, fewer than `min_revolutions` input revolutions or
  /// fewer than 2 output revolutions, non-finite samples.
  RecordSpectra(const Record& record, int channel, const GearPairSpec& gears, std::size_t min_revolutions = 4,
                int edges_per_rev = 1);
  /// As the constructor (channel 0, one edge a revolution, 4 revolutions at least) for a record
  /// that holds cos(2π·order·θ) alone, θ its input angle in revolutions from the first edge, at
  /// constant speed: its angle-domain samples are the cosine itself past the leading revolution
  /// (the resampler's there, where its kernel reads before the record's start), not interpolated.
  /// They differ from the constructor's by the interpolator's pass-band error on the tone.
  static RecordSpectra of_tone(const Record& record, const GearPairSpec& gears, double order);

  /// The summary over the given revolutions (indices may repeat: a bootstrap draw). Empty lists mean all.
  SpectralSummary summary(const std::vector<std::size_t>& input_revs = {},
                          const std::vector<std::size_t>& output_revs = {},
                          const std::vector<std::size_t>& blocks = {}) const;
  /// The revolutions (and broadband blocks) of one block-bootstrap draw: blocks of `block`
  /// consecutive revolutions from random starts, circular, drawn from `rng` for the broadband
  /// blocks first, then the output and the input revolutions.
  struct BootstrapDraw {
    std::vector<std::size_t> input_revs, output_revs, blocks;
  };
  BootstrapDraw draw_bootstrap(std::mt19937_64& rng, std::size_t block) const;
  /// summary() over a draw of draw_bootstrap().
  SpectralSummary bootstrap(std::mt19937_64& rng, std::size_t block) const;
  /// Equal for two objects only when their spectra and everything summary() carries are equal (a
  /// copy keeps it; construction and every setter take a new one): a key for caching summaries.
  std::uint64_t identity() const noexcept { return identity_; }

  /// Carried into every summary and bootstrap draw (the twin's response to a run-out).
  void set_run_out_sensitivity(RunOutSensitivity pinion, RunOutSensitivity gear) noexcept {
    pinion_run_out_ = pinion;
    gear_run_out_ = gear;
    identity_ = next_identity();
  }
  /// Carried into every summary and bootstrap draw (the twin's bearing forces per sensor displacement).
  void set_bearing_force_path(std::shared_ptr<const BearingForcePath> path) noexcept {
    bearing_force_path_ = std::move(path);
    identity_ = next_identity();
  }
  /// Carried into every summary and bootstrap draw (the twin's lines' response to a run-out).
  void set_run_out_response(std::shared_ptr<const RunOutResponse> response) noexcept {
    run_out_response_ = std::move(response);
    identity_ = next_identity();
  }
  /// The synchronous lines over all revolutions, complex (summary() holds their power): input
  /// orders 1..K_in and output orders 1..K_out.
  std::vector<std::complex<double>> input_line_means() const;
  std::vector<std::complex<double>> output_line_means() const;
  double speed_hz() const noexcept { return speed_hz_; }
  double torque_nm() const noexcept { return torque_nm_; }
  std::size_t input_revolutions() const noexcept { return in_revs_; }
  std::size_t output_revolutions() const noexcept { return out_revs_; }

 private:
  RecordSpectra(const Record& record, int channel, const GearPairSpec& gears, std::size_t min_revolutions,
                int edges_per_rev, std::optional<double> tone_order);
  static std::uint64_t next_identity() noexcept;
  std::uint64_t identity_ = next_identity();
  double speed_hz_ = 0, sample_rate_hz_ = 0, torque_nm_ = 0;
  std::size_t in_revs_ = 0, out_revs_ = 0, k_in_ = 0, k_out_ = 0, blocks_ = 0;
  int pinion_teeth_ = 19, gear_teeth_ = 52;
  RunOutSensitivity pinion_run_out_, gear_run_out_;
  std::shared_ptr<const BearingForcePath> bearing_force_path_;
  std::shared_ptr<const RunOutResponse> run_out_response_;
  std::vector<std::complex<double>> in_dft_;   // [rev * k_in + k-1], scaled to peak amplitude
  std::vector<std::complex<double>> out_dft_;  // [rev * k_out + m-1]
  std::vector<std::complex<double>> block_dft_;  // [block * 2k_in + j-1]: half-order bins j = 1..2k_in
};

/// The twin's run-out response from its record without a run-out and four with one of `unit_m` each
/// (the pinion's at phase 0 and π/2, the gear's at phase 0 and π/2), all at one operating point:
/// (lines with − lines without) / unit_m. Throws std::invalid_argument for a unit that is not
/// positive and finite.
std::shared_ptr<const RunOutResponse> run_out_response(const RecordSpectra& without,
                                                       const std::array<const RecordSpectra*, 4>& with_unit,
                                                       double unit_m);

/// The sideband families hold n·z ± m for m = 1..kSidebandOrders: a once-per-revolution
/// modulation (eccentricity, a run-out) puts its lines there, and a family spread over every
/// order between the mesh harmonics would dilute them (2 changed lines among 18 read as a third
/// of their gap). The other non-mesh orders are the shaft's orders.
inline constexpr int kSidebandOrders = 1;

/// How far a tone's leakage is followed (add_non_synchronous_tone): lines of each shaft and
/// half-order broadband bins each side of the tone. The defaults hold what a tone up to about 30 dB
/// over its neighbours puts there (beyond three orders a line keeps below 1/(3π·R)² of it); a
/// stronger tone, seen against lines 40 dB under it, leaks measurably further.
struct ToneReach {
  int input_lines = 3;      ///< input orders ⌊x⌋ − (n − 1) … ⌊x⌋ + n
  int output_lines = 4;     ///< output orders ⌊y⌋ − (n − 1) … ⌊y⌋ + n
  int broadband_bins = 3;   ///< half-order bins each side of the tone's
  /// A reach of `orders` input orders each side on both shafts and in the broadband part.
  static ToneReach orders(double orders, const GearPairSpec& gears);
};

/// Adds a tone of `power` at a fractional input order to the broadband part the way a
/// non-synchronous tone enters it (the 2-revolution Hann window's spread over half-order bins,
/// `half_bins` each side; the shares normalised over the bins followed).
void add_tone_to_broadband(SpectralSummary& s, double order, double power, int half_bins = 3);

/// Adds a non-synchronous tone of `power` at a fractional input order the way RecordSpectra sees
/// it. A mean over R whole revolutions is one DFT over R revolutions read at an integer order, so it
/// keeps e^{iπRΔ}·sinc(RΔ) of a tone Δ orders away. Each shaft's lines are read after the other
/// shaft's average is taken out, and with 5 output revolutions that average holds a tenth of the
/// tone's amplitude at the nearest output orders, enough to change the input lines' leakage by half;
/// so the two averages are followed in turn, coherently, over the neighbouring orders. The broadband
/// part gets the rest, times B/(B − 1) for its B blocks (a deterministic tone in the variance about
/// the block mean). With 16 revolutions a tone 0.4 orders from a line puts 0.2 % of its power in it:
/// next to a mesh harmonic 40 dB above its sidebands, several dB on them. Tones at or below
/// `negligible_power` go to the broadband part whole (the lines' share of them cannot show).
void add_non_synchronous_tone(SpectralSummary& s, double input_order, double power, const GearPairSpec& gears,
                              double negligible_power = 0, ToneReach reach = {});

/// Σ of the input-order lines' power: the reference of the comparison's floor and of the forms'
/// negligible-power thresholds.
double total_input_line_power(const SpectralSummary& s) noexcept;

/// Which family a line or bin belongs to (the partition used throughout the diagnosis).
FamilyKind input_line_family(int order, int pinion_teeth) noexcept;
/// Output orders that are mesh orders (multiples of z_gear) are counted on the input side only.
bool output_line_is_mesh(int order, int gear_teeth) noexcept;
FamilyKind output_line_family(int order, int gear_teeth) noexcept;

/// A signal sampled uniformly in input angle (`spr` samples an input revolution, from angle 0) on a
/// grid of `samples_per_rev` samples a revolution of a shaft turning once every `per_rev` input
/// revolutions, `revolutions` of them: what AngularResampler::resample gives with a tacho every
/// spr samples, its positions computed directly (they are linear in the index). The shaft
/// separation's resampling of the output-only signal; exposed for its test.
void resample_uniform_angle(std::span<const float> x, std::size_t spr, std::size_t samples_per_rev,
                            std::size_t revolutions, double per_rev, std::span<double> out);

}  // namespace gearwatch::gap
