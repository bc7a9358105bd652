#pragma once
// One interface for where frames come from: a live SocketCAN interface or a candump log.
// Sources run on the acquisition thread's boost::asio::io_context and deliver frames to a
// handler on that thread. The handler is the hot path: it must not throw and must not block.
#include <atomic>
#include <cstdint>
#include <functional>
#include <string>
#include <utility>

#include "gearwatch/acquisition/can_frame.hpp"

namespace gearwatch::acquisition {

/// Counters a source keeps about itself; readable from any thread.
struct SourceHealth {
  std::atomic<std::uint64_t> frames{0};          ///< frames delivered to the handler
  std::atomic<std::uint64_t> kernel_drops{0};    ///< SocketCAN: frames the kernel dropped (SO_RXQ_OVFL)
  std::atomic<std::uint64_t> read_errors{0};     ///< failed reads (interface down, I/O error)
  std::atomic<std::uint64_t> reopens{0};         ///< times the socket was reopened after an error
  std::atomic<std::uint64_t> malformed_lines{0}; ///< candump log: lines that do not parse
};

using FrameHandler = std::function<void(const CanFrame&)>;

/// How a source ended.
enum class SourceEndKind : std::uint8_t {
  finished,  ///< a finite source (a log file) delivered everything
  stopped,   ///< stop() ended it
  failed,    ///< an error ended it (SourceEnd::error says which)
};
inline const char* to_string(SourceEndKind kind) noexcept {
  switch (kind) {
    case SourceEndKind::finished: return "finished";
    case SourceEndKind::stopped: return "stopped";
    case SourceEndKind::failed: return "failed";
  }
  return "unknown";
}

struct SourceEnd {
  SourceEndKind kind = SourceEndKind::finished;
  std::string error;  ///< why it failed, for people ("" unless kind == failed)
  static SourceEnd failure(std::string why) { return {SourceEndKind::failed, std::move(why)}; }
};

/// Called once when a finite source (a log file) has delivered everything, a source was stopped,
/// or an error ended it.
using EndHandler = std::function<void(const SourceEnd& end)>;

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  /// Starts delivering frames on the io_context this source was built with.
  virtual void start(FrameHandler on_frame, EndHandler on_end) = 0;
  /// Stops delivery; safe to call from the io_context's thread (e.g. a signal handler).
  virtual void stop() = 0;
  virtual const SourceHealth& health() const = 0;
  virtual std::string describe() const = 0;
};

}  // namespace gearwatch::acquisition
