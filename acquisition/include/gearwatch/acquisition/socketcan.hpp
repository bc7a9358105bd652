#pragma once
// Live SocketCAN acquisition: a CAN_RAW socket (CAN FD enabled) read asynchronously on a
// boost::asio::io_context, with the kernel's drop counter (SO_RXQ_OVFL) turned into
// SourceHealth::kernel_drops and automatic reopening, with exponential backoff, when the
// interface goes down, disappears, or the read fails.
//
// Layers, bottom up (each usable and testable on its own):
//  - CanRawProtocol / CanEndpoint: SocketCAN as an Asio protocol, so that
//    boost::asio::basic_raw_socket<CanRawProtocol> owns the descriptor (RAII) and works with
//    async_wait; plus the CAN-specific socket options as Asio socket-option types.
//  - Pure helpers with no I/O: frame conversion (can_frame / canfd_frame bytes -> CanFrame),
//    control-message parsing (drop counter, timestamp), the cumulative-drop tracker, the
//    reopen backoff and the log rate limiter.
//  - SocketCanSource: the FrameSource the daemon uses.
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <system_error>
#include <vector>

#include <sys/socket.h>
#include <linux/can.h>
#include <linux/can/raw.h>

#include <boost/asio/basic_raw_socket.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/steady_timer.hpp>

#include "gearwatch/acquisition/frame_source.hpp"

namespace gearwatch::acquisition {

// ---------------------------------------------------------------------------------------
// SocketCAN as an Asio protocol
// ---------------------------------------------------------------------------------------

class CanRawProtocol;

/// A SocketCAN address: the interface index (0 = every CAN interface). Wraps sockaddr_can
/// so that Asio can pass it to bind().
class CanEndpoint {
 public:
  using protocol_type = CanRawProtocol;
  using data_type = ::sockaddr;

  CanEndpoint() noexcept;
  explicit CanEndpoint(int interface_index) noexcept;

  protocol_type protocol() const noexcept;
  int interface_index() const noexcept { return address_.can_ifindex; }

  data_type* data() noexcept { return reinterpret_cast<data_type*>(&address_); }
  const data_type* data() const noexcept { return reinterpret_cast<const data_type*>(&address_); }
  std::size_t size() const noexcept { return sizeof(address_); }
  std::size_t capacity() const noexcept { return sizeof(address_); }
  /// Asio calls this after getsockname/recvfrom; a SocketCAN address has one fixed size.
  void resize(std::size_t new_size);

  friend bool operator==(const CanEndpoint& a, const CanEndpoint& b) noexcept {
    return a.address_.can_ifindex == b.address_.can_ifindex;
  }

 private:
  ::sockaddr_can address_;
};

/// The CAN_RAW protocol of the PF_CAN family, in the shape Asio's basic_raw_socket expects.
class CanRawProtocol {
 public:
  using endpoint = CanEndpoint;
  using socket = boost::asio::basic_raw_socket<CanRawProtocol>;

  int family() const noexcept { return PF_CAN; }
  int type() const noexcept { return SOCK_RAW; }
  int protocol() const noexcept { return CAN_RAW; }

  friend bool operator==(const CanRawProtocol&, const CanRawProtocol&) noexcept { return true; }
  friend bool operator!=(const CanRawProtocol&, const CanRawProtocol&) noexcept { return false; }
};

namespace socket_option {

/// An integer-valued socket option at a fixed level/name, usable with Asio's set_option and
/// get_option (the SettableSocketOption / GettableSocketOption requirements).
template <int Level, int Name>
class IntegerOption {
 public:
  IntegerOption() = default;
  explicit IntegerOption(int value) noexcept : value_(value) {}
  int value() const noexcept { return value_; }

  template <class Protocol> int level(const Protocol&) const noexcept { return Level; }
  template <class Protocol> int name(const Protocol&) const noexcept { return Name; }
  template <class Protocol> int* data(const Protocol&) noexcept { return &value_; }
  template <class Protocol> const int* data(const Protocol&) const noexcept { return &value_; }
  template <class Protocol> std::size_t size(const Protocol&) const noexcept { return sizeof(value_); }
  template <class Protocol> void resize(const Protocol&, std::size_t s) {
    if (s != sizeof(value_)) throw std::length_error("integer socket option: unexpected size");
  }

 private:
  int value_ = 0;
};

/// Receive CAN FD frames (canfd_frame, 72 bytes) as well as classic ones (can_frame, 16 bytes).
using FdFrames = IntegerOption<SOL_CAN_RAW, CAN_RAW_FD_FRAMES>;
/// Attach the socket's cumulative drop counter to every received frame (a control message).
using ReceiveQueueOverflow = IntegerOption<SOL_SOCKET, SO_RXQ_OVFL>;
/// Attach the kernel's receive time to every frame.
using Timestamp = IntegerOption<SOL_SOCKET, SO_TIMESTAMP>;
/// Receive-buffer size; the FORCE variant may exceed net.core.rmem_max (needs CAP_NET_ADMIN).
using ReceiveBuffer = IntegerOption<SOL_SOCKET, SO_RCVBUF>;
using ReceiveBufferForce = IntegerOption<SOL_SOCKET, SO_RCVBUFFORCE>;

}  // namespace socket_option

// ---------------------------------------------------------------------------------------
// Pure helpers (no I/O)
// ---------------------------------------------------------------------------------------

/// Converts what one read from a CAN_RAW socket returned — a struct can_frame (CAN_MTU,
/// 16 bytes) or a struct canfd_frame (CANFD_MTU, 72 bytes) — into a CanFrame. Returns false,
/// leaving `out` unspecified, for any other size or an impossible length field.
bool convert_socketcan_frame(const void* bytes, std::size_t size, CanFrame& out) noexcept;

/// What the control messages of one received frame carried.
struct ReceiveMetadata {
  std::optional<std::uint32_t> cumulative_drops;  ///< SO_RXQ_OVFL: drops since the socket opened
  std::optional<double> kernel_time_s;            ///< SO_TIMESTAMP: receive time, seconds
};

/// Reads the SO_RXQ_OVFL and SO_TIMESTAMP control messages of a received message.
ReceiveMetadata parse_receive_metadata(const ::msghdr& message) noexcept;

/// Turns the kernel's cumulative per-socket drop counter (u32, may wrap) into increments.
/// The counter restarts at zero on every new socket: call reset() after each reopen.
class KernelDropTracker {
 public:
  /// Returns how many drops happened since the previous observation on this socket.
  std::uint32_t observe(std::uint32_t cumulative) noexcept {
    const std::uint32_t increment = cumulative - last_;  // modulo 2^32: wrap is harmless
    last_ = cumulative;
    return increment;
  }
  void reset() noexcept { last_ = 0; }

 private:
  std::uint32_t last_ = 0;
};

/// Exponential backoff: initial, 2x initial, 4x ... capped at `maximum`; reset() after a
/// success starts again at `initial`.
class ReopenBackoff {
 public:
  using duration = std::chrono::milliseconds;
  /// Throws std::invalid_argument if initial <= 0 or maximum < initial.
  ReopenBackoff(duration initial, duration maximum);
  /// The delay to wait before the next attempt; each call doubles the following one.
  duration next() noexcept;
  void reset() noexcept { current_ = initial_; }
  duration peek() const noexcept { return current_; }

 private:
  duration initial_;
  duration maximum_;
  duration current_;
};

/// Lets one message through per interval and counts those held back, so that a fault that
/// repeats thousands of times a second produces one log line per interval.
class LogRateLimiter {
 public:
  using clock = std::chrono::steady_clock;
  explicit LogRateLimiter(clock::duration interval) : interval_(interval) {}
  /// True if a message may be logged at `now`; then `suppressed` holds how many were held back
  /// since the last one that went through (and the count restarts).
  bool allow(clock::time_point now, std::uint64_t& suppressed) noexcept;

 private:
  clock::duration interval_;
  std::optional<clock::time_point> last_;
  std::uint64_t held_back_ = 0;
};

/// Checks a network interface name as the kernel would (1..IFNAMSIZ-1 bytes, no '/', no
/// whitespace); throws std::invalid_argument with the reason otherwise.
void validate_interface_name(const std::string& name);

// ---------------------------------------------------------------------------------------
// The live source
// ---------------------------------------------------------------------------------------

struct SocketCanOptions {
  /// Requested socket receive buffer. The kernel's rmem_max caps plain SO_RCVBUF; with
  /// CAP_NET_ADMIN SO_RCVBUFFORCE is used to go past it. The buffer absorbs bursts while the
  /// acquisition thread is busy: at 100 kHz x 2 channels in 64-byte FD frames (~6 700 frames/s,
  /// ~1 KiB of kernel memory each) 8 MiB is about one second.
  std::size_t receive_buffer_bytes = 8u << 20;
  bool fd_frames = true;             ///< CAN_RAW_FD_FRAMES (classic frames arrive either way)
  bool kernel_timestamps = false;    ///< SO_TIMESTAMP into CanFrame::timestamp_s
  std::size_t max_frames_per_wakeup = 256;  ///< one wake-up drains at most this many frames
  std::size_t frames_per_syscall = 64;      ///< recvmmsg batch size
  std::chrono::milliseconds reopen_initial{100};
  std::chrono::milliseconds reopen_maximum{5000};
  std::chrono::milliseconds log_interval{10000};  ///< rate limit of the repeated-error log line
};

/// Reads one SocketCAN interface (e.g. "can0", "vcan0") on an io_context.
///
/// Errors at run time never reach the caller: a failed read (ENETDOWN, ENODEV, ENXIO, an
/// interface removed or down) is counted in health().read_errors, logged (rate-limited), the
/// socket is closed and reopened after an exponential backoff; each successful reopen counts in
/// health().reopens. Only a permanent failure — the kernel has no SocketCAN (EAFNOSUPPORT) or
/// no permission (EPERM/EACCES) — ends the source, through the EndHandler as `failed` with the reason.
/// Not thread-safe: start() and stop() run on the io_context's thread; health() from anywhere.
class SocketCanSource final : public FrameSource {
 public:
  /// Throws std::invalid_argument for an impossible interface name or options. Opens nothing.
  SocketCanSource(boost::asio::io_context& io, std::string interface_name, SocketCanOptions options = {});
  ~SocketCanSource() override;
  SocketCanSource(const SocketCanSource&) = delete;
  SocketCanSource& operator=(const SocketCanSource&) = delete;

  /// Opens the socket and starts reading. If the interface is missing or down, keeps retrying
  /// with backoff (the daemon may start before the interface exists).
  void start(FrameHandler on_frame, EndHandler on_end) override;
  /// First delivers the frames the kernel has already queued on the socket (bounded by what
  /// the receive buffer can hold) and accounts the drops no frame has reported yet (SO_MEMINFO),
  /// so nothing received before the stop is lost uncounted. Then cancels the read and any
  /// pending reopen and closes the socket, so io_context::run() returns once nothing else is
  /// queued, and calls the EndHandler with `stopped`. When called from inside the frame
  /// handler it skips the final delivery.
  void stop() override;
  const SourceHealth& health() const override { return health_; }
  std::string describe() const override;

  /// The receive-buffer size the kernel granted, comparable with the request (Linux reports
  /// twice the usable size; Asio's get_option halves it back); 0 while no socket is open.
  std::size_t granted_receive_buffer() const noexcept { return granted_rcvbuf_; }
  bool is_open() const noexcept;

 private:
  enum class OpenResult { opened, retry, fatal };
  OpenResult open_socket(std::string& reason);
  enum class ReceiveEnd { would_block, budget_spent, failed, stopped };
  void arm_read();
  void on_readable(const boost::system::error_code& ec);
  /// One wake-up's work: receive up to the budget, then wait, continue later, or recover.
  void drain();
  /// Receives and delivers up to `budget` frames.
  ReceiveEnd receive_frames(std::size_t budget, std::error_code& failure);
  /// Adds the drops the kernel counted but no received frame has reported yet.
  void account_unreported_drops() noexcept;
  void add_kernel_drops(std::uint64_t drops);
  void handle_failure(const std::string& what, const std::error_code& ec);
  void schedule_reopen();
  void try_reopen();
  void finish(const SourceEnd& end);

  boost::asio::io_context& io_;
  std::string interface_;
  SocketCanOptions options_;
  CanRawProtocol::socket socket_;
  boost::asio::steady_timer reopen_timer_;
  ReopenBackoff backoff_;
  LogRateLimiter error_log_limiter_;
  KernelDropTracker drop_tracker_;
  SourceHealth health_;
  FrameHandler on_frame_;
  EndHandler on_end_;
  bool running_ = false;
  bool recovering_ = false;            ///< between a failure and the first frame after reopening
  bool receiving_ = false;             ///< inside receive_frames (so inside the frame handler)
  std::uint64_t failures_in_episode_ = 0;
  std::size_t granted_rcvbuf_ = 0;

  // recvmmsg scratch, allocated once in the constructor (no allocation per wake-up).
  struct ReceiveSlot;
  std::vector<ReceiveSlot> slots_;
  std::vector<::mmsghdr> messages_;

  /// Handlers queued on the io_context hold a weak reference to this token, so a handler that
  /// runs after the source was destroyed does nothing.
  std::shared_ptr<char> alive_ = std::make_shared<char>();
};

}  // namespace gearwatch::acquisition
