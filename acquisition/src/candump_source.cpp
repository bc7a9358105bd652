#include "gearwatch/acquisition/candump_source.hpp"

#include <stdexcept>

#include <boost/asio/post.hpp>

#include "gearwatch/acquisition/candump_log.hpp"

namespace gearwatch::acquisition {

CandumpFileSource::CandumpFileSource(boost::asio::io_context& io, std::string path, BadLineHandler on_bad_line,
                                     std::size_t lines_per_chunk)
    : io_(io), path_(std::move(path)), on_bad_line_(std::move(on_bad_line)), lines_per_chunk_(lines_per_chunk) {
  in_.open(path_, std::ios::binary);
  if (!in_) throw std::runtime_error("cannot open capture " + path_);
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
    if (on_end_) on_end_("stopped");
    on_end_ = nullptr;
    return;
  }
  for (std::size_t i = 0; i < lines_per_chunk_; ++i) {
    if (!std::getline(in_, line_)) {
      const bool error = in_.bad();
      stopped_ = true;
      if (on_end_) on_end_(error ? "read error in " + path_ : std::string{});
      on_end_ = nullptr;
      return;
    }
    ++line_number_;
    if (auto parsed = parse_candump_line(line_, reason_)) {
      health_.frames.fetch_add(1, std::memory_order_relaxed);
      on_frame_(parsed->frame);
    } else if (!reason_.empty()) {
      health_.malformed_lines.fetch_add(1, std::memory_order_relaxed);
      if (on_bad_line_) on_bad_line_(line_number_, line_, reason_);
    }
    if (stopped_) break;
  }
  boost::asio::post(io_, [this] { read_chunk(); });
}

}  // namespace gearwatch::acquisition
