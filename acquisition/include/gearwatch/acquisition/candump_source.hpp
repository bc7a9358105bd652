#pragma once
// A candump -L log as a frame source (test benches, `gearwatch replay`). Reads the file in
// chunks posted to the io_context, so signals and stop() are served between chunks.
// A line that does not parse is counted (health().malformed_lines), reported to the
// bad-line handler with its text, and skipped.
#include <fstream>
#include <memory>
#include <string>

#include <boost/asio/io_context.hpp>

#include "gearwatch/acquisition/frame_source.hpp"

namespace gearwatch::acquisition {

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
  std::string line_, reason_;
};

}  // namespace gearwatch::acquisition
