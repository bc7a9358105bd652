#pragma once
// A candump -L log as a frame source (test benches, `gearwatch replay`). Reads the file in
// chunks posted to the io_context, so signals and stop() are served between chunks.
// A line that does not parse is counted (health().malformed_lines), reported to the
// bad-line handler with its text, and skipped. So is a line longer than kMaxCandumpLineChars:
// its first characters are reported and the rest is skipped unread into memory, so a file
// without line ends (binary data) cannot make the reader grow.
#include <fstream>
#include <memory>
#include <string>

#include <boost/asio/io_context.hpp>

#include "gearwatch/acquisition/frame_source.hpp"

namespace gearwatch::acquisition {

/// The longest candump -L line kept. The longest valid one (a 13-digit timestamp, a 15-character
/// interface name, an extended id and a 64-byte FD payload) has under 190 characters.
inline constexpr std::size_t kMaxCandumpLineChars = 300;

/// Throws std::runtime_error naming the path when it is a device or a directory, not a log.
void require_capture_file(const std::string& path);

class CandumpFileSource final : public FrameSource {
 public:
  using BadLineHandler = std::function<void(std::size_t line_number, const std::string& line, const std::string& reason)>;

  /// Throws std::runtime_error when the file cannot be opened.
  CandumpFileSource(boost::asio::io_context& io, std::string path, BadLineHandler on_bad_line = {},
                    std::size_t lines_per_chunk = 4096);

  void start(FrameHandler on_frame, EndHandler on_end) override;
  void stop() override;
  const SourceHealth& health() const override { return health_; }
  std::string describe() const override { return "candump log " + path_; }
  std::size_t lines_read() const noexcept { return line_number_; }

 private:
  enum class LineRead { line, overlong, end };
  LineRead read_line(std::size_t& length);
  void read_chunk();

  boost::asio::io_context& io_;
  std::string path_;
  BadLineHandler on_bad_line_;
  std::size_t lines_per_chunk_;
  std::ifstream in_;
  FrameHandler on_frame_;
  EndHandler on_end_;
  SourceHealth health_;
  std::size_t line_number_ = 0;
  bool stopped_ = false;
  std::string line_;  ///< fixed buffer of kMaxCandumpLineChars + 1 characters
  std::string reason_;
};

}  // namespace gearwatch::acquisition
