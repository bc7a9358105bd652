// Live SocketCAN source. See socketcan.hpp for the contract and docs/acquisition-socketcan.md
// for the design.
#include "gearwatch/acquisition/socketcan.hpp"

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cstring>
#include <stdexcept>
#include <utility>

#include <net/if.h>
#include <net/if_arp.h>
#include <sys/ioctl.h>
#include <sys/time.h>
#include <sys/uio.h>
#include <linux/sock_diag.h>

#include <boost/asio/post.hpp>
#include <spdlog/spdlog.h>

namespace gearwatch::acquisition {

// ---------------------------------------------------------------------------------------
// CanEndpoint
// ---------------------------------------------------------------------------------------

CanEndpoint::CanEndpoint() noexcept : CanEndpoint(0) {}

CanEndpoint::CanEndpoint(int interface_index) noexcept {
  std::memset(&address_, 0, sizeof(address_));
  address_.can_family = AF_CAN;
  address_.can_ifindex = interface_index;
}

CanEndpoint::protocol_type CanEndpoint::protocol() const noexcept { return CanRawProtocol{}; }

void CanEndpoint::resize(std::size_t new_size) {
  // getsockname() on a CAN_RAW socket may report a shorter address (older kernels fill only
  // family and ifindex); anything larger than sockaddr_can is not a CAN address.
  if (new_size > sizeof(address_)) throw std::length_error("CanEndpoint: address larger than sockaddr_can");
}

// ---------------------------------------------------------------------------------------
// Pure helpers
// ---------------------------------------------------------------------------------------

namespace {

void fill_identifier(canid_t can_id, CanFrame& out) noexcept {
  out.extended = (can_id & CAN_EFF_FLAG) != 0;
  out.remote = (can_id & CAN_RTR_FLAG) != 0;
  out.error = (can_id & CAN_ERR_FLAG) != 0;
  // An error frame's identifier carries the error class bits (CAN_ERR_MASK).
  out.id = out.error ? (can_id & CAN_ERR_MASK) : (can_id & (out.extended ? CAN_EFF_MASK : CAN_SFF_MASK));
}

}  // namespace

bool convert_socketcan_frame(const void* bytes, std::size_t size, CanFrame& out) noexcept {
  if (bytes == nullptr) return false;
  if (size == CAN_MTU) {
    ::can_frame raw;
    std::memcpy(&raw, bytes, sizeof(raw));
    if (raw.len > CAN_MAX_DLEN) return false;
    fill_identifier(raw.can_id, out);
    out.fd = false;
    out.fd_flags = 0;
    out.len = raw.len;
    std::copy_n(raw.data, raw.len, out.data.begin());
    std::fill(out.data.begin() + raw.len, out.data.end(), std::uint8_t{0});
    return true;
  }
  if (size == CANFD_MTU) {
    ::canfd_frame raw;
    std::memcpy(&raw, bytes, sizeof(raw));
    if (!is_valid_fd_length(raw.len)) return false;
    fill_identifier(raw.can_id, out);
    out.remote = false;  // CAN FD has no remote frames
    out.fd = true;
    out.fd_flags = raw.flags & (CANFD_BRS | CANFD_ESI);
    out.len = raw.len;
    std::copy_n(raw.data, raw.len, out.data.begin());
    std::fill(out.data.begin() + raw.len, out.data.end(), std::uint8_t{0});
    return true;
  }
  return false;
}

ReceiveMetadata parse_receive_metadata(const ::msghdr& message) noexcept {
  ReceiveMetadata meta;
  if (message.msg_control == nullptr || message.msg_controllen < sizeof(::cmsghdr)) return meta;
  // CMSG_NXTHDR takes a non-const msghdr but only reads it.
  auto& msg = const_cast<::msghdr&>(message);
  for (::cmsghdr* c = CMSG_FIRSTHDR(&msg); c != nullptr; c = CMSG_NXTHDR(&msg, c)) {
    if (c->cmsg_level != SOL_SOCKET) continue;
    if (c->cmsg_type == SO_RXQ_OVFL && c->cmsg_len >= CMSG_LEN(sizeof(std::uint32_t))) {
      std::uint32_t drops = 0;
      std::memcpy(&drops, CMSG_DATA(c), sizeof(drops));
      meta.cumulative_drops = drops;
    } else if (c->cmsg_type == SCM_TIMESTAMP && c->cmsg_len >= CMSG_LEN(sizeof(::timeval))) {
      ::timeval tv;
      std::memcpy(&tv, CMSG_DATA(c), sizeof(tv));
      meta.kernel_time_s = static_cast<double>(tv.tv_sec) + 1e-6 * static_cast<double>(tv.tv_usec);
    }
  }
  return meta;
}

ReopenBackoff::ReopenBackoff(duration initial, duration maximum)
    : initial_(initial), maximum_(maximum), current_(initial) {
  if (initial.count() <= 0) throw std::invalid_argument("reopen backoff: the initial delay must be positive");
  if (maximum < initial) throw std::invalid_argument("reopen backoff: the maximum delay is below the initial one");
}

ReopenBackoff::duration ReopenBackoff::next() noexcept {
  const duration delay = current_;
  current_ = (current_ > maximum_ / 2) ? maximum_ : current_ * 2;
  return delay;
}

bool LogRateLimiter::allow(clock::time_point now, std::uint64_t& suppressed) noexcept {
  if (last_ && now - *last_ < interval_) {
    ++held_back_;
    return false;
  }
  suppressed = held_back_;
  held_back_ = 0;
  last_ = now;
  return true;
}

void validate_interface_name(const std::string& name) {
  if (name.empty()) throw std::invalid_argument("SocketCAN interface name is empty");
  if (name.size() >= IFNAMSIZ)
    throw std::invalid_argument("SocketCAN interface name '" + name + "' is longer than " +
                                std::to_string(IFNAMSIZ - 1) + " characters");
  for (const char c : name) {
    if (c == '/' || c == ':' || static_cast<unsigned char>(c) <= ' ' || c == 0x7f)
      throw std::invalid_argument("SocketCAN interface name '" + name + "' contains an invalid character");
  }
  if (name == "." || name == "..") throw std::invalid_argument("SocketCAN interface name '" + name + "' is invalid");
}

// ---------------------------------------------------------------------------------------
// SocketCanSource
// ---------------------------------------------------------------------------------------

struct SocketCanSource::ReceiveSlot {
  ::canfd_frame frame;  // large enough for a can_frame too
  ::iovec iov;
  // Room for the drop counter and a timestamp, plus slack for any control message a future
  // kernel adds (an undersized buffer would only set MSG_CTRUNC, but we would lose the counter).
  alignas(::cmsghdr) unsigned char control[CMSG_SPACE(sizeof(std::uint32_t)) + CMSG_SPACE(sizeof(::timeval)) + 64];
};

namespace {

/// Errors after which retrying cannot help: no SocketCAN in this kernel, or no permission.
bool is_permanent_open_error(int err) {
  return err == EAFNOSUPPORT || err == EPROTONOSUPPORT || err == ESOCKTNOSUPPORT || err == EPERM || err == EACCES;
}

std::string errno_text(int err) { return std::error_code(err, std::generic_category()).message(); }

constexpr std::size_t max_frames_per_syscall = 1024;

}  // namespace

SocketCanSource::SocketCanSource(boost::asio::io_context& io, std::string interface_name, SocketCanOptions options)
    : io_(io),
      interface_(std::move(interface_name)),
      options_(options),
      socket_(io),
      reopen_timer_(io),
      backoff_(options.reopen_initial, options.reopen_maximum),
      error_log_limiter_(options.log_interval) {
  validate_interface_name(interface_);
  if (options_.receive_buffer_bytes == 0 || options_.receive_buffer_bytes > static_cast<std::size_t>(INT_MAX) / 2)
    throw std::invalid_argument("SocketCAN receive buffer must be between 1 byte and 1 GiB");
  if (options_.max_frames_per_wakeup == 0) throw std::invalid_argument("SocketCAN max_frames_per_wakeup must be positive");
  if (options_.frames_per_syscall == 0 || options_.frames_per_syscall > max_frames_per_syscall)
    throw std::invalid_argument("SocketCAN frames_per_syscall must be in 1.." + std::to_string(max_frames_per_syscall));
  if (options_.log_interval.count() < 0) throw std::invalid_argument("SocketCAN log_interval must not be negative");

  slots_.resize(options_.frames_per_syscall);
  messages_.resize(options_.frames_per_syscall);
  for (std::size_t i = 0; i < slots_.size(); ++i) {
    slots_[i].iov.iov_base = &slots_[i].frame;
    slots_[i].iov.iov_len = sizeof(slots_[i].frame);
    std::memset(&messages_[i], 0, sizeof(messages_[i]));
    messages_[i].msg_hdr.msg_iov = &slots_[i].iov;
    messages_[i].msg_hdr.msg_iovlen = 1;
    messages_[i].msg_hdr.msg_control = slots_[i].control;
  }
}

SocketCanSource::~SocketCanSource() {
  // No EndHandler from the destructor: the owner is tearing down and may already be gone.
  on_end_ = nullptr;
  running_ = false;
  boost::system::error_code ignored;
  reopen_timer_.cancel();
  socket_.close(ignored);
}

bool SocketCanSource::is_open() const noexcept { return socket_.is_open(); }

std::string SocketCanSource::describe() const {
  std::string text = "socketcan:" + interface_ + (options_.fd_frames ? " (CAN FD" : " (classic CAN");
  if (granted_rcvbuf_ != 0) text += ", receive buffer " + std::to_string(granted_rcvbuf_) + " B";
  return text + ")";
}

void SocketCanSource::start(FrameHandler on_frame, EndHandler on_end) {
  if (running_) throw std::logic_error("SocketCanSource::start called twice");
  if (!on_frame) throw std::invalid_argument("SocketCanSource::start needs a frame handler");
  on_frame_ = std::move(on_frame);
  on_end_ = std::move(on_end);
  running_ = true;
  std::string reason;
  switch (open_socket(reason)) {
    case OpenResult::opened:
      spdlog::info("listening on {} ({})", interface_, describe());
      arm_read();
      break;
    case OpenResult::retry:
      health_.read_errors.fetch_add(1, std::memory_order_relaxed);
      recovering_ = true;
      failures_in_episode_ = 1;
      spdlog::warn("socketcan {}: cannot open yet ({}); retrying with backoff", interface_, reason);
      schedule_reopen();
      break;
    case OpenResult::fatal: {
      // Handlers never run inside the initiating call (as in Asio): report the end from the loop.
      spdlog::error("socketcan {}: {}", interface_, reason);
      std::weak_ptr<char> alive = alive_;
      boost::asio::post(io_, [this, alive, reason] {
        if (alive.lock()) finish(SourceEnd::failure(reason));
      });
      break;
    }
  }
}

void SocketCanSource::stop() {
  if (!running_) return;
  if (socket_.is_open() && !receiving_) {
    // Deliver what the kernel already holds. Bounded: each queued frame costs the receive
    // buffer at least ~512 bytes of its doubled size, so the buffer holds fewer frames than
    // this, and a sender that keeps flooding cannot hold the stop up for long.
    const std::size_t bound = options_.receive_buffer_bytes / 256 + options_.frames_per_syscall;
    std::error_code ignored;
    if (receive_frames(bound, ignored) == ReceiveEnd::stopped) return;  // the handler stopped us
  }
  finish({SourceEndKind::stopped, {}});
}

void SocketCanSource::finish(const SourceEnd& end) {
  running_ = false;
  account_unreported_drops();
  reopen_timer_.cancel();
  boost::system::error_code ignored;
  socket_.close(ignored);
  granted_rcvbuf_ = 0;
  if (auto on_end = std::exchange(on_end_, nullptr)) on_end(end);
}

SocketCanSource::OpenResult SocketCanSource::open_socket(std::string& reason) {
  boost::system::error_code ec;
  socket_.close(ec);
  socket_.open(CanRawProtocol{}, ec);
  if (ec) {
    if (ec.value() == EAFNOSUPPORT || ec.value() == EPROTONOSUPPORT)
      reason = "this kernel has no SocketCAN support (socket(PF_CAN, SOCK_RAW, CAN_RAW): " + ec.message() +
               "); load the can and can_raw modules";
    else
      reason = "cannot create a CAN_RAW socket: " + ec.message();
    return is_permanent_open_error(ec.value()) ? OpenResult::fatal : OpenResult::retry;
  }
  const int fd = socket_.native_handle();

  auto fail = [&](const std::string& what, int err, bool permanent) {
    reason = what + ": " + errno_text(err);
    socket_.close(ec);
    return permanent ? OpenResult::fatal : OpenResult::retry;
  };

  ::ifreq request{};
  std::memcpy(request.ifr_name, interface_.c_str(), interface_.size() + 1);  // validated < IFNAMSIZ
  if (::ioctl(fd, SIOCGIFINDEX, &request) < 0) return fail("interface " + interface_ + " not found", errno, false);
  const int interface_index = request.ifr_ifindex;
  if (::ioctl(fd, SIOCGIFHWADDR, &request) == 0 && request.ifr_hwaddr.sa_family != ARPHRD_CAN) {
    reason = "interface " + interface_ + " is not a CAN interface";
    socket_.close(ec);
    return OpenResult::fatal;
  }
  if (::ioctl(fd, SIOCGIFFLAGS, &request) < 0) return fail("interface " + interface_ + " flags", errno, false);
  // Binding to a down interface succeeds but the socket reports ENETDOWN at once; checking
  // first gives a clearer reason and saves a pointless bind.
  if ((request.ifr_flags & IFF_UP) == 0) return fail("interface " + interface_ + " is down", ENETDOWN, false);

  // Options before bind(), so no frame is ever queued under the defaults.
  if (options_.fd_frames) {
    socket_.set_option(socket_option::FdFrames(1), ec);
    if (ec) return fail("CAN_RAW_FD_FRAMES (kernel without CAN FD?)", ec.value(), true);
  }
  // The kernel doubles the value for its bookkeeping; Asio's get_option halves it back.
  const int wanted = static_cast<int>(options_.receive_buffer_bytes);
  socket_.set_option(socket_option::ReceiveBufferForce(wanted), ec);
  if (ec) socket_.set_option(socket_option::ReceiveBuffer(wanted), ec);  // no CAP_NET_ADMIN: capped by rmem_max
  socket_option::ReceiveBuffer granted;
  socket_.get_option(granted, ec);
  granted_rcvbuf_ = ec ? 0 : static_cast<std::size_t>(granted.value());
  socket_.set_option(socket_option::ReceiveQueueOverflow(1), ec);
  if (ec) return fail("SO_RXQ_OVFL", ec.value(), true);
  if (options_.kernel_timestamps) {
    socket_.set_option(socket_option::Timestamp(1), ec);
    if (ec) return fail("SO_TIMESTAMP", ec.value(), true);
  }
  socket_.bind(CanEndpoint(interface_index), ec);
  if (ec) return fail("bind to " + interface_, ec.value(), false);
  socket_.non_blocking(true, ec);
  if (ec) return fail("non-blocking mode", ec.value(), false);
  drop_tracker_.reset();  // the kernel's counter starts at zero on the new socket
  if (granted_rcvbuf_ < options_.receive_buffer_bytes)
    spdlog::warn("socketcan {}: receive buffer {} B granted of {} B asked (raise net.core.rmem_max or grant "
                 "CAP_NET_ADMIN)", interface_, granted_rcvbuf_, options_.receive_buffer_bytes);
  return OpenResult::opened;
}

void SocketCanSource::arm_read() {
  // Asio's epoll reactor is edge-triggered and a plain wait is not speculative: waiting is
  // only correct once the socket has been read until EAGAIN (drain() guarantees it).
  std::weak_ptr<char> alive = alive_;
  socket_.async_wait(CanRawProtocol::socket::wait_read, [this, alive](const boost::system::error_code& ec) {
    if (alive.lock()) on_readable(ec);
  });
}

void SocketCanSource::on_readable(const boost::system::error_code& ec) {
  if (!running_ || ec == boost::asio::error::operation_aborted) return;
  if (ec) {
    handle_failure("wait failed", std::error_code(ec.value(), std::generic_category()));
    return;
  }
  drain();
}

void SocketCanSource::drain() {
  std::error_code failure;
  switch (receive_frames(options_.max_frames_per_wakeup, failure)) {
    case ReceiveEnd::would_block:
      arm_read();
      break;
    case ReceiveEnd::budget_spent: {
      // Frames are probably still queued: continue after other handlers had a turn (a wait
      // here could miss them, see arm_read()).
      std::weak_ptr<char> alive = alive_;
      boost::asio::post(io_, [this, alive] {
        if (alive.lock() && running_) drain();
      });
      break;
    }
    case ReceiveEnd::failed:
      handle_failure("read failed", failure);
      break;
    case ReceiveEnd::stopped:
      break;
  }
}

SocketCanSource::ReceiveEnd SocketCanSource::receive_frames(std::size_t budget, std::error_code& failure) {
  const int fd = socket_.native_handle();
  receiving_ = true;
  struct ClearFlag {
    bool& flag;
    ~ClearFlag() { flag = false; }
  } clear_flag{receiving_};
  std::size_t delivered = 0;
  CanFrame frame;
  while (delivered < budget) {
    const auto batch = static_cast<unsigned>(std::min(options_.frames_per_syscall, budget - delivered));
    for (unsigned i = 0; i < batch; ++i) messages_[i].msg_hdr.msg_controllen = sizeof(ReceiveSlot::control);
    const int received = ::recvmmsg(fd, messages_.data(), batch, MSG_DONTWAIT, nullptr);
    if (received < 0) {
      const int err = errno;
      if (err == EINTR) continue;
      if (err == EAGAIN || err == EWOULDBLOCK) return ReceiveEnd::would_block;
      failure = std::error_code(err, std::generic_category());
      return ReceiveEnd::failed;
    }
    std::uint64_t new_drops = 0;
    for (int i = 0; i < received; ++i) {
      const ::msghdr& header = messages_[i].msg_hdr;
      const ReceiveMetadata meta = parse_receive_metadata(header);
      if (meta.cumulative_drops) new_drops += drop_tracker_.observe(*meta.cumulative_drops);
      if (!convert_socketcan_frame(&slots_[i].frame, messages_[i].msg_len, frame)) {
        // Not a can_frame or canfd_frame: cannot come from a CAN_RAW socket unless the kernel
        // changes its ABI. Count it, skip it, keep the socket.
        health_.read_errors.fetch_add(1, std::memory_order_relaxed);
        continue;
      }
      frame.timestamp_s = meta.kernel_time_s.value_or(0.0);
      if (recovering_) {
        recovering_ = false;
        backoff_.reset();
        failures_in_episode_ = 0;
      }
      health_.frames.fetch_add(1, std::memory_order_relaxed);
      on_frame_(frame);
      if (!running_) {  // stopped from inside the handler: the socket is closed
        add_kernel_drops(new_drops);
        return ReceiveEnd::stopped;
      }
    }
    add_kernel_drops(new_drops);
    delivered += static_cast<std::size_t>(received);
  }
  return ReceiveEnd::budget_spent;
}

void SocketCanSource::add_kernel_drops(std::uint64_t drops) {
  if (drops == 0) return;
  health_.kernel_drops.fetch_add(drops, std::memory_order_relaxed);
  std::uint64_t suppressed = 0;
  if (error_log_limiter_.allow(LogRateLimiter::clock::now(), suppressed))
    spdlog::warn("socketcan {}: the kernel dropped {} frame(s), receive buffer full (total {}; {} similar "
                 "message(s) suppressed)", interface_, drops, health_.kernel_drops.load(), suppressed);
}

void SocketCanSource::account_unreported_drops() noexcept {
  if (!socket_.is_open()) return;
  // SO_MEMINFO exposes the same cumulative counter SO_RXQ_OVFL attaches to frames; it catches
  // the drops after the last frame that was queued, which no control message will ever report.
  std::uint32_t meminfo[SK_MEMINFO_VARS] = {};
  ::socklen_t size = sizeof(meminfo);
  if (::getsockopt(socket_.native_handle(), SOL_SOCKET, SO_MEMINFO, meminfo, &size) != 0 ||
      size < (SK_MEMINFO_DROPS + 1) * sizeof(std::uint32_t))
    return;
  try {
    add_kernel_drops(drop_tracker_.observe(meminfo[SK_MEMINFO_DROPS]));
  } catch (...) {  // only the log line can throw; the count is already added
  }
}

void SocketCanSource::handle_failure(const std::string& what, const std::error_code& ec) {
  health_.read_errors.fetch_add(1, std::memory_order_relaxed);
  account_unreported_drops();  // the counter dies with the socket
  boost::system::error_code ignored;
  socket_.close(ignored);
  granted_rcvbuf_ = 0;
  if (!recovering_) {
    recovering_ = true;
    failures_in_episode_ = 0;
    backoff_.reset();
  }
  ++failures_in_episode_;
  std::uint64_t suppressed = 0;
  if (error_log_limiter_.allow(LogRateLimiter::clock::now(), suppressed))
    spdlog::warn("socketcan {}: {}: {}; reopening in {} ms (read errors {}, {} similar message(s) suppressed)",
                 interface_, what, ec.message(), backoff_.peek().count(), health_.read_errors.load(), suppressed);
  schedule_reopen();
}

void SocketCanSource::schedule_reopen() {
  reopen_timer_.expires_after(backoff_.next());
  std::weak_ptr<char> alive = alive_;
  reopen_timer_.async_wait([this, alive](const boost::system::error_code& ec) {
    if (!alive.lock() || ec == boost::asio::error::operation_aborted || !running_) return;
    try_reopen();
  });
}

void SocketCanSource::try_reopen() {
  std::string reason;
  switch (open_socket(reason)) {
    case OpenResult::opened:
      health_.reopens.fetch_add(1, std::memory_order_relaxed);
      spdlog::info("socketcan {}: reopened after {} failed attempt(s); listening on {} ({})", interface_,
                   failures_in_episode_, interface_, describe());
      // The backoff is reset by the first frame, not here: an interface that accepts the bind
      // and fails again at once must not be retried in a tight loop.
      arm_read();
      break;
    case OpenResult::retry: {
      health_.read_errors.fetch_add(1, std::memory_order_relaxed);
      ++failures_in_episode_;
      std::uint64_t suppressed = 0;
      if (error_log_limiter_.allow(LogRateLimiter::clock::now(), suppressed))
        spdlog::warn("socketcan {}: reopen failed ({}); next attempt in {} ms ({} similar message(s) suppressed)",
                     interface_, reason, backoff_.peek().count(), suppressed);
      schedule_reopen();
      break;
    }
    case OpenResult::fatal:
      spdlog::error("socketcan {}: {}", interface_, reason);
      finish(SourceEnd::failure(reason));
      break;
  }
}

}  // namespace gearwatch::acquisition
