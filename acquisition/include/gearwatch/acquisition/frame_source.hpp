#pragma once
// One interface for where frames come from: a live SocketCAN interface or a candump log.
// Sources run on the acquisition thread's boost::asio::io_context and deliver frames to a
// handler on that thread. The handler is the hot path: it must not throw and must not block.
#include <atomic>
#include <cstdint>
#include <functional>
#include <string>

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
/// Called once when a finite source (a log file) has delivered everything, or a live source
/// has stopped. `reason` is empty on a normal end.
using EndHandler = std::function<void(const std::string& reason)>;

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
