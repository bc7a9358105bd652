#pragma once
// Recordings a data-acquisition system (DAQ) or a portable recorder gives: WAV (libsndfile), CSV
// and MATLAB .mat (libmatio). Each reader returns the same typed value: the samples of every
// channel in the file's own unit, the rate when the file carries one, and where it came from.
// Reading only; turning a recording into a capture is `gearwatch import` (docs/acquisition.md).
#include <cstddef>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace gearwatch::acquisition {

enum class DaqFormat { wav, csv, mat };
std::string_view to_string(DaqFormat format);

/// Where a recording's sample rate came from.
enum class RateSource { none, wav_header, csv_time_column, mat_variable };
std::string_view to_string(RateSource source);

/// A refused file: the message is one line that names the file's problem (and, for a CSV, the line).
struct DaqFileError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct DaqRecording {
  DaqFormat format = DaqFormat::wav;
  /// One name per channel: the CSV header's, `<variable>[k]` for a .mat column, `channel k` otherwise.
  std::vector<std::string> names;
  /// channels[c][i]: sample i of channel c in the file's unit (WAV: fraction of full scale).
  std::vector<std::vector<double>> channels;
  double sample_rate_hz = std::numeric_limits<double>::quiet_NaN();  ///< NaN when the file has none
  RateSource rate_source = RateSource::none;
  /// WAV integer PCM only: the largest magnitude a sample can hold, so a clipped channel shows as
  /// samples at the rails. NaN for formats with no rails (float WAV, CSV, .mat).
  double full_scale = std::numeric_limits<double>::quiet_NaN();

  std::size_t samples() const { return channels.empty() ? 0 : channels.front().size(); }
};

struct DaqReadOptions {
  /// CSV: the time column (a header name or a 0-based index); empty = a column named `time`,
  /// `t` or `time_s` (any case) when the header has one, otherwise none.
  std::string csv_time_column;
  /// .mat: the variable holding the samples (a numeric matrix, one column or row per channel);
  /// empty = the only numeric matrix with more than one element in the file.
  std::string mat_variable;
  /// .mat: the scalar variable holding the rate in Hz; empty = the first of fs, Fs, sample_rate,
  /// sampling_rate, SampleRate the file has, if any.
  std::string mat_rate_variable;
};

/// Reads `path` by its extension (.wav, .csv/.txt, .mat). DaqFileError on anything it cannot use.
DaqRecording read_daq_file(const std::string& path, const DaqReadOptions& options = {});
DaqRecording read_wav(const std::string& path);
DaqRecording read_csv(const std::string& path, const DaqReadOptions& options = {});
DaqRecording read_mat(const std::string& path, const DaqReadOptions& options = {});

/// A WAV or MATLAB file recognised by its first bytes ("RIFF"…"WAVE", "MATLAB"), nullopt otherwise
/// (also when it cannot be read): what `replay` refuses as a recording that needs `import` first.
std::optional<DaqFormat> sniff_daq_recording(const std::string& path);

/// The channel a user names: a 0-based index, or a name in `recording.names`. DaqFileError when
/// there is no such channel (the message lists what there is).
std::size_t find_channel(const DaqRecording& recording, const std::string& which);

}  // namespace gearwatch::acquisition
