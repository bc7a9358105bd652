#include "gearwatch/acquisition/daq_file.hpp"

#include <matio.h>
#include <sndfile.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <memory>

namespace gearwatch::acquisition {

std::string_view to_string(DaqFormat format) {
  switch (format) {
    case DaqFormat::wav: return "wav";
    case DaqFormat::csv: return "csv";
    case DaqFormat::mat: return "mat";
  }
  return "unknown";
}

std::string_view to_string(RateSource source) {
  switch (source) {
    case RateSource::none: return "none";
    case RateSource::wav_header: return "WAV header";
    case RateSource::csv_time_column: return "CSV time column";
    case RateSource::mat_variable: return ".mat variable";
  }
  return "unknown";
}

namespace {

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

void require_regular_file(const std::string& path) {
  std::error_code ec;
  const auto st = std::filesystem::status(path, ec);
  if (ec || !std::filesystem::exists(st)) throw DaqFileError(path + ": no such file");
  if (!std::filesystem::is_regular_file(st)) throw DaqFileError(path + ": not a regular file");
}

// ---- WAV -------------------------------------------------------------------------------------

/// The largest magnitude of the file's integer PCM samples as libsndfile scales them to doubles
/// (full scale 1.0), or NaN for float data, which has no rails.
double wav_full_scale(int format) {
  switch (format & SF_FORMAT_SUBMASK) {
    case SF_FORMAT_PCM_S8:
    case SF_FORMAT_PCM_U8: return 127.0 / 128.0;
    case SF_FORMAT_PCM_16: return 32767.0 / 32768.0;
    case SF_FORMAT_PCM_24: return 8388607.0 / 8388608.0;
    case SF_FORMAT_PCM_32: return 2147483647.0 / 2147483648.0;
    default: return std::numeric_limits<double>::quiet_NaN();
  }
}

}  // namespace

DaqRecording read_wav(const std::string& path) {
  require_regular_file(path);
  SF_INFO info{};
  std::unique_ptr<SNDFILE, int (*)(SNDFILE*)> file(sf_open(path.c_str(), SFM_READ, &info), &sf_close);
  if (!file) throw DaqFileError(path + ": not a readable sound file (" + sf_strerror(nullptr) + ")");
  if (info.channels < 1 || info.frames <= 0) throw DaqFileError(path + ": no samples");
  DaqRecording r;
  r.format = DaqFormat::wav;
  r.sample_rate_hz = info.samplerate;
  r.rate_source = RateSource::wav_header;
  r.full_scale = wav_full_scale(info.format);
  const auto channels = static_cast<std::size_t>(info.channels);
  const auto frames = static_cast<std::size_t>(info.frames);
  // Integer PCM read as doubles at full scale 1.0 (libsndfile's normalisation, on by default):
  // the unit is the same whatever the bit depth, and --scale says what full scale is.
  std::vector<double> interleaved(channels * frames);
  const sf_count_t got = sf_readf_double(file.get(), interleaved.data(), info.frames);
  if (got != info.frames)
    throw DaqFileError(path + ": truncated: the header announces " + std::to_string(info.frames) + " frames, " +
                       std::to_string(got) + " could be read");
  r.channels.assign(channels, std::vector<double>(frames));
  for (std::size_t i = 0; i < frames; ++i)
    for (std::size_t c = 0; c < channels; ++c) r.channels[c][i] = interleaved[i * channels + c];
  for (std::size_t c = 0; c < channels; ++c) r.names.push_back("channel " + std::to_string(c));
  return r;
}

// ---- CSV -------------------------------------------------------------------------------------

namespace {

char detect_delimiter(const std::string& line) {
  for (char d : {'\t', ';', ','})
    if (line.find(d) != std::string::npos) return d;
  return ',';
}

std::string trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  if (s.size() >= 2 && s.front() == '"' && s.back() == '"') s = s.substr(1, s.size() - 2);
  return std::string(s);
}

std::vector<std::string> split(const std::string& line, char delimiter) {
  std::vector<std::string> cells;
  std::size_t start = 0;
  for (;;) {
    const std::size_t end = line.find(delimiter, start);
    cells.push_back(trim(std::string_view(line).substr(start, end == std::string::npos ? std::string::npos : end - start)));
    if (end == std::string::npos) return cells;
    start = end + 1;
  }
}

/// The whole cell as a number (from_chars: no locale, no trailing text). "nan" and "inf" parse
/// and are refused later as non-finite samples, with the others.
bool parse_number(const std::string& cell, double& value) {
  const char* first = cell.data();
  const char* last = first + cell.size();
  if (first != last && *first == '+') ++first;
  const auto [ptr, ec] = std::from_chars(first, last, value);
  return ec == std::errc() && ptr == last && first != last;
}

bool all_numeric(const std::vector<std::string>& cells) {
  double v;
  return std::all_of(cells.begin(), cells.end(), [&](const std::string& c) { return parse_number(c, v); });
}

/// The time column's index in the header (or a given index), or npos.
std::size_t time_column(const std::vector<std::string>& names, const std::string& wanted, const std::string& path) {
  if (!wanted.empty()) {
    for (std::size_t i = 0; i < names.size(); ++i)
      if (names[i] == wanted) return i;
    std::size_t index = 0;
    const auto [p, ec] = std::from_chars(wanted.data(), wanted.data() + wanted.size(), index);
    if (ec == std::errc() && p == wanted.data() + wanted.size() && index < names.size()) return index;
    throw DaqFileError(path + ": no time column " + wanted + " (the file has " + std::to_string(names.size()) + " columns)");
  }
  for (std::size_t i = 0; i < names.size(); ++i) {
    const std::string n = lower(names[i]);
    if (n == "time" || n == "t" || n == "time_s" || n == "time (s)" || n == "time [s]") return i;
  }
  return std::string::npos;
}

/// The rate a uniformly sampled time column gives; DaqFileError when it is not uniform.
double rate_from_time(const std::vector<double>& t, const std::string& path, std::size_t first_data_line) {
  if (t.size() < 2) throw DaqFileError(path + ": a time column needs at least two rows");
  const double dt = (t.back() - t.front()) / static_cast<double>(t.size() - 1);
  if (!(dt > 0)) throw DaqFileError(path + ": the time column does not increase");
  // A step off by more than a tenth of a sample is a missing or repeated row, not rounding.
  for (std::size_t i = 1; i < t.size(); ++i)
    if (std::fabs(t[i] - t[0] - static_cast<double>(i) * dt) > 0.1 * dt)
      throw DaqFileError(path + ": line " + std::to_string(first_data_line + i) +
                         ": the time column is not uniformly sampled (a missing or repeated row?)");
  return 1.0 / dt;
}

}  // namespace

DaqRecording read_csv(const std::string& path, const DaqReadOptions& options) {
  require_regular_file(path);
  std::ifstream in(path);
  if (!in) throw DaqFileError(path + ": cannot be read");
  DaqRecording r;
  r.format = DaqFormat::csv;
  std::string line;
  std::size_t line_no = 0, width = 0, first_data_line = 0;
  char delimiter = ',';
  std::vector<std::string> names;
  std::vector<std::vector<double>> columns;
  while (std::getline(in, line)) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (trim(line).empty() || line.front() == '#') continue;
    if (width == 0) {
      delimiter = detect_delimiter(line);
      const auto cells = split(line, delimiter);
      width = cells.size();
      columns.assign(width, {});
      if (!all_numeric(cells)) {  // a header row of channel names
        names = cells;
        continue;
      }
      for (std::size_t c = 0; c < width; ++c) names.push_back("column " + std::to_string(c));
    }
    const auto cells = split(line, delimiter);
    if (cells.size() != width)
      throw DaqFileError(path + ": line " + std::to_string(line_no) + ": " + std::to_string(cells.size()) + " cells, " +
                         std::to_string(width) + " expected");
    if (first_data_line == 0) first_data_line = line_no;
    for (std::size_t c = 0; c < width; ++c) {
      double v;
      if (!parse_number(cells[c], v))
        throw DaqFileError(path + ": line " + std::to_string(line_no) + ", column " + std::to_string(c + 1) +
                           ": not a number: \"" + cells[c].substr(0, 40) + "\"");
      columns[c].push_back(v);
    }
  }
  if (in.bad()) throw DaqFileError(path + ": read error");
  if (width == 0 || columns.front().empty()) throw DaqFileError(path + ": no rows of samples");
  const std::size_t t = time_column(names, options.csv_time_column, path);
  for (std::size_t c = 0; c < width; ++c) {
    if (c == t) continue;
    r.names.push_back(names[c]);
    r.channels.push_back(std::move(columns[c]));
  }
  if (t != std::string::npos) {
    r.sample_rate_hz = rate_from_time(columns[t], path, first_data_line);
    r.rate_source = RateSource::csv_time_column;
  }
  if (r.channels.empty()) throw DaqFileError(path + ": no column besides the time column");
  return r;
}

// ---- MATLAB .mat -----------------------------------------------------------------------------

namespace {

using MatPtr = std::unique_ptr<mat_t, int (*)(mat_t*)>;
using VarPtr = std::unique_ptr<matvar_t, void (*)(matvar_t*)>;

bool numeric_class(matio_classes c) {
  switch (c) {
    case MAT_C_DOUBLE: case MAT_C_SINGLE: case MAT_C_INT8: case MAT_C_UINT8: case MAT_C_INT16: case MAT_C_UINT16:
    case MAT_C_INT32: case MAT_C_UINT32: case MAT_C_INT64: case MAT_C_UINT64: return true;
    default: return false;
  }
}

bool numeric_matrix(const matvar_t& v) { return numeric_class(v.class_type) && !v.isComplex && v.rank == 2; }

std::size_t elements(const matvar_t& v) {
  std::size_t n = 1;
  for (int d = 0; d < v.rank; ++d) n *= v.dims[d];
  return n;
}

template <class T>
double element_as(const void* data, std::size_t i) {
  return static_cast<double>(static_cast<const T*>(data)[i]);
}

double element(const matvar_t& v, std::size_t i) {
  switch (v.class_type) {
    case MAT_C_DOUBLE: return element_as<double>(v.data, i);
    case MAT_C_SINGLE: return element_as<float>(v.data, i);
    case MAT_C_INT8: return element_as<std::int8_t>(v.data, i);
    case MAT_C_UINT8: return element_as<std::uint8_t>(v.data, i);
    case MAT_C_INT16: return element_as<std::int16_t>(v.data, i);
    case MAT_C_UINT16: return element_as<std::uint16_t>(v.data, i);
    case MAT_C_INT32: return element_as<std::int32_t>(v.data, i);
    case MAT_C_UINT32: return element_as<std::uint32_t>(v.data, i);
    case MAT_C_INT64: return element_as<std::int64_t>(v.data, i);
    case MAT_C_UINT64: return element_as<std::uint64_t>(v.data, i);
    default: return std::numeric_limits<double>::quiet_NaN();
  }
}

std::vector<std::string> variable_names(mat_t* mat) {
  std::vector<std::string> names;
  Mat_Rewind(mat);
  while (matvar_t* v = Mat_VarReadNextInfo(mat)) {
    VarPtr hold(v, &Mat_VarFree);
    if (v->name != nullptr) names.emplace_back(v->name);
  }
  return names;
}

/// The samples variable: the one named, or the only numeric matrix of more than one element.
std::string samples_variable(mat_t* mat, const std::vector<std::string>& names, const std::string& wanted,
                             const std::string& path) {
  if (!wanted.empty()) return wanted;
  std::vector<std::string> candidates;
  for (const auto& n : names) {
    VarPtr v(Mat_VarReadInfo(mat, n.c_str()), &Mat_VarFree);
    if (v && numeric_matrix(*v) && elements(*v) > 1) candidates.push_back(n);
  }
  if (candidates.size() == 1) return candidates.front();
  std::string list;
  for (const auto& n : candidates) list += (list.empty() ? "" : ", ") + n;
  if (candidates.empty()) throw DaqFileError(path + ": no numeric matrix in the file");
  throw DaqFileError(path + ": several numeric matrices (" + list + "): name one with --mat-variable");
}

VarPtr read_variable(mat_t* mat, const std::string& name, const std::string& path) {
  VarPtr v(Mat_VarRead(mat, name.c_str()), &Mat_VarFree);
  if (!v) throw DaqFileError(path + ": no variable " + name);
  if (!numeric_matrix(*v))
    throw DaqFileError(path + ": variable " + name + " is not a real numeric matrix (a struct, cell, text, sparse or complex array)");
  if (v->data == nullptr || elements(*v) == 0) throw DaqFileError(path + ": variable " + name + " is empty");
  return v;
}

double rate_variable(mat_t* mat, const std::vector<std::string>& names, const std::string& wanted, const std::string& path,
                     bool& found) {
  std::string name = wanted;
  if (name.empty())
    for (const char* n : {"fs", "Fs", "sample_rate", "sampling_rate", "SampleRate"})
      if (std::find(names.begin(), names.end(), n) != names.end()) {
        name = n;
        break;
      }
  found = !name.empty();
  if (!found) return std::numeric_limits<double>::quiet_NaN();
  VarPtr v = read_variable(mat, name, path);
  if (elements(*v) != 1) throw DaqFileError(path + ": the rate variable " + name + " is not a scalar");
  return element(*v, 0);
}

}  // namespace

DaqRecording read_mat(const std::string& path, const DaqReadOptions& options) {
  require_regular_file(path);
  MatPtr mat(Mat_Open(path.c_str(), MAT_ACC_RDONLY), &Mat_Close);
  if (!mat) throw DaqFileError(path + ": not a MATLAB .mat file this build can read (v4, v5, or v7.3 with HDF5)");
  const auto names = variable_names(mat.get());
  const std::string name = samples_variable(mat.get(), names, options.mat_variable, path);
  VarPtr v = read_variable(mat.get(), name, path);
  // Samples run along the longer dimension, channels along the shorter: a recording is always
  // longer than it is wide. Column-major storage: element (i, j) is at i + j·rows.
  const std::size_t rows = v->dims[0], cols = v->dims[1];
  const bool channels_in_columns = rows >= cols;
  const std::size_t channels = channels_in_columns ? cols : rows, samples = channels_in_columns ? rows : cols;
  DaqRecording r;
  r.format = DaqFormat::mat;
  r.channels.assign(channels, std::vector<double>(samples));
  for (std::size_t c = 0; c < channels; ++c) {
    for (std::size_t i = 0; i < samples; ++i)
      r.channels[c][i] = element(*v, channels_in_columns ? i + c * rows : c + i * rows);
    r.names.push_back(name + "[" + std::to_string(c) + "]");
  }
  bool found = false;
  const double fs = rate_variable(mat.get(), names, options.mat_rate_variable, path, found);
  if (found) {
    r.sample_rate_hz = fs;
    r.rate_source = RateSource::mat_variable;
  }
  return r;
}

// ---- dispatch --------------------------------------------------------------------------------

DaqRecording read_daq_file(const std::string& path, const DaqReadOptions& options) {
  const std::string ext = lower(std::filesystem::path(path).extension().string());
  if (ext == ".wav") return read_wav(path);
  if (ext == ".csv" || ext == ".txt") return read_csv(path, options);
  if (ext == ".mat") return read_mat(path, options);
  throw DaqFileError(path + ": unknown recording format \"" + ext + "\" (.wav, .csv, .txt or .mat)");
}

std::optional<DaqFormat> sniff_daq_recording(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return std::nullopt;
  std::ifstream in(path, std::ios::binary);
  std::array<char, 12> head{};
  in.read(head.data(), head.size());
  const std::string_view h(head.data(), static_cast<std::size_t>(in.gcount()));
  if (h.size() == 12 && h.substr(0, 4) == "RIFF" && h.substr(8, 4) == "WAVE") return DaqFormat::wav;
  if (h.substr(0, 6) == "MATLAB") return DaqFormat::mat;
  return std::nullopt;
}

std::size_t find_channel(const DaqRecording& recording, const std::string& which) {
  for (std::size_t i = 0; i < recording.names.size(); ++i)
    if (recording.names[i] == which) return i;
  std::size_t index = 0;
  const auto [p, ec] = std::from_chars(which.data(), which.data() + which.size(), index);
  if (ec == std::errc() && p == which.data() + which.size() && index < recording.channels.size()) return index;
  std::string list;
  for (std::size_t i = 0; i < recording.names.size(); ++i) list += (i ? ", " : "") + std::to_string(i) + " = " + recording.names[i];
  throw DaqFileError("no channel " + which + " in the recording (it has " + list + ")");
}

}  // namespace gearwatch::acquisition
