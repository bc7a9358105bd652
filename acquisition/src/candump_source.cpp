#include "gearwatch/acquisition/candump_source.hpp"

#include <filesystem>
#include <limits>
#include <stdexcept>

#include <boost/asio/post.hpp>

#include "gearwatch/acquisition/candump_log.hpp"

namespace gearwatch::acquisition {

void require_capture_file(const std::string& path) {
  // A device (a terminal, /dev/zero, /dev/urandom) is no log, and a character device never ends:
  // refused before anything is read. Regular files and pipes (a capture streamed in) are read.
  std::error_code ec;
  const auto type = std::filesystem::status(path, ec).type();
  if (type == std::filesystem::file_type::character || type == std::filesystem::file_type::block)
    throw std::runtime_error("capture " + path + " is a device, not a candump log file");
  if (type == std::filesystem::file_type::directory) throw std::runtime_error("capture " + path + " is a directory, not a candump log file");
}

CandumpFileSource::CandumpFileSource(boost::asio::io_context& io, std::string path, BadLineHandler on_bad_line,
                                     std::size_t lines_per_chunk)
    : io_(io), path_(std::move(path)), on_bad_line_(std::move(on_bad_line)), lines_per_chunk_(lines_per_chunk) {
  require_capture_file(path_);
  in_.open(path_, std::ios::binary);
  if (!in_) throw std::runtime_error("cannot open capture " + path_);
  line_.resize(kMaxCandumpLineChars + 1);
}

CandumpFileSource::LineRead CandumpFileSource::read_line(std::size_t& length) {
  // getline into a fixed buffer: at most kMaxCandumpLineChars characters are ever kept, however
  // long the line in the file is.
  in_.getline(line_.data(), static_cast<std::streamsize>(line_.size()));
  const auto got = static_cast<std::size_t>(in_.gcount());
  if (!in_.fail()) {
    length = in_.eof() ? got : got - 1;  // the newline was extracted, not stored
    return LineRead::line;
  }
  if (in_.bad() || (got == 0 && in_.eof())) return LineRead::end;
  // Longer than the buffer: the rest of the line is skipped as it streams by, never stored.
  length = got;
  in_.clear();
  in_.ignore(std::numeric_limits<std::streamsize>::max(), '\n');
  return LineRead::overlong;
}

void CandumpFileSource::start(FrameHandler on_frame, EndHandler on_end) {
  on_frame_ = std::move(on_frame);
  on_end_ = std::move(on_end);
  boost::asio::post(io_, [this] { read_chunk(); });
}

void CandumpFileSource::stop() {
  if (stopped_) return;
  stopped_ = true;
  // The next posted chunk sees the flag and ends the source.
}

void CandumpFileSource::read_chunk() {
  if (stopped_) {
    if (on_end_) on_end_({SourceEndKind::stopped, {}});
    on_end_ = nullptr;
    return;
  }
  for (std::size_t i = 0; i < lines_per_chunk_; ++i) {
    std::size_t length = 0;
    const LineRead read = read_line(length);
    if (read == LineRead::end) {
      const bool error = in_.bad();
      stopped_ = true;
      if (on_end_) on_end_(error ? SourceEnd::failure("read error in " + path_) : SourceEnd{SourceEndKind::finished, {}});
      on_end_ = nullptr;
      return;
    }
    ++line_number_;
    const std::string_view text(line_.data(), length);
    if (read == LineRead::overlong) {
      health_.malformed_lines.fetch_add(1, std::memory_order_relaxed);
      if (on_bad_line_)
        on_bad_line_(line_number_, std::string(text),
                     "line longer than " + std::to_string(kMaxCandumpLineChars) + " characters; the rest of it skipped");
    } else if (auto parsed = parse_candump_line(text, reason_)) {
      health_.frames.fetch_add(1, std::memory_order_relaxed);
      on_frame_(parsed->frame);
    } else if (!reason_.empty()) {
      health_.malformed_lines.fetch_add(1, std::memory_order_relaxed);
      if (on_bad_line_) on_bad_line_(line_number_, std::string(text), reason_);
    }
    if (stopped_) break;
  }
  boost::asio::post(io_, [this] { read_chunk(); });
}

}  // namespace gearwatch::acquisition
