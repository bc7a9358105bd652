// Tests of the live SocketCAN source.
// Two groups:
//  - "[socketcan]" host tests: frame conversion, control-message parsing, drop counting,
//    backoff, rate limiting, validation, and the failure path of a kernel without AF_CAN.
//  - "[.vcan]" tests against a real vcan0/vcan1. They need a kernel with CAN, so they
//    are hidden (the leading dot): a plain run of the test binary, and CTest's discovery, leave
//    them out instead of counting them as passed. tests/vcan/run-vcan-unit-tests.sh runs them by
//    their tag "[vcan]" inside a qemu VM whose kernel has CAN (CTest: vcan_socketcan_source).
//    Run by hand without an interface, they fail.
#include "gearwatch/acquisition/socketcan.hpp"

#include <chrono>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include <linux/can/error.h>
#include <net/if.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <catch2/catch.hpp>

namespace test_socketcan {  // this file's own: the test files compile together (unity build)

using namespace gearwatch::acquisition;
using namespace std::chrono_literals;

namespace {

std::vector<std::uint8_t> bytes_of(const void* p, std::size_t n) {
  const auto* b = static_cast<const std::uint8_t*>(p);
  return {b, b + n};
}

}  // namespace

// ---------------------------------------------------------------------------------------
// Host tests
// ---------------------------------------------------------------------------------------

TEST_CASE("CanRawProtocol and CanEndpoint carry the kernel's CAN_RAW numbers", "[socketcan]") {
  // Values from linux/socket.h, linux/can.h: PF_CAN 29, SOCK_RAW 3, CAN_RAW 1.
  const CanRawProtocol protocol;
  CHECK(protocol.family() == 29);
  CHECK(protocol.type() == 3);
  CHECK(protocol.protocol() == 1);

  const CanEndpoint endpoint(7);
  CHECK(endpoint.interface_index() == 7);
  CHECK(endpoint.size() == sizeof(::sockaddr_can));
  CHECK(endpoint.capacity() == sizeof(::sockaddr_can));
  const auto* raw = reinterpret_cast<const ::sockaddr_can*>(endpoint.data());
  CHECK(raw->can_family == AF_CAN);
  CHECK(raw->can_ifindex == 7);
  CHECK(CanEndpoint().interface_index() == 0);  // 0 = any CAN interface

  CanEndpoint resizable;
  CHECK_NOTHROW(resizable.resize(sizeof(::sockaddr_can)));
  CHECK_THROWS_AS(resizable.resize(sizeof(::sockaddr_can) + 1), std::length_error);

  // The CAN socket options map to the kernel's (level, name) pairs: linux/can/raw.h and
  // asm-generic/socket.h (SOL_CAN_RAW 101, CAN_RAW_FD_FRAMES 5, SOL_SOCKET 1, SO_RXQ_OVFL 40).
  CHECK(socket_option::FdFrames(1).level(protocol) == 101);
  CHECK(socket_option::FdFrames(1).name(protocol) == 5);
  CHECK(socket_option::ReceiveQueueOverflow(1).level(protocol) == 1);
  CHECK(socket_option::ReceiveQueueOverflow(1).name(protocol) == 40);
  CHECK(*socket_option::ReceiveBuffer(1234).data(protocol) == 1234);
}

TEST_CASE("classic can_frame bytes convert to CanFrame", "[socketcan]") {
  CanFrame out;
  SECTION("standard data frame") {
    ::can_frame raw{};
    raw.can_id = 0x123;
    raw.len = 8;
    for (int i = 0; i < 8; ++i) raw.data[i] = static_cast<std::uint8_t>(0xA0 + i);
    REQUIRE(convert_socketcan_frame(&raw, sizeof(raw), out));
    CHECK(out.id == 0x123);
    CHECK(out.len == 8);
    CHECK_FALSE(out.fd);
    CHECK_FALSE(out.extended);
    CHECK_FALSE(out.remote);
    CHECK_FALSE(out.error);
    CHECK(out.fd_flags == 0);
    CHECK(bytes_of(out.data.data(), 8) == bytes_of(raw.data, 8));
    CHECK(out.data[8] == 0);
  }
  SECTION("extended identifier keeps 29 bits") {
    ::can_frame raw{};
    raw.can_id = 0x1ABCDEF0u | CAN_EFF_FLAG;
    raw.len = 3;
    raw.data[0] = 1; raw.data[1] = 2; raw.data[2] = 3;
    REQUIRE(convert_socketcan_frame(&raw, sizeof(raw), out));
    CHECK(out.extended);
    CHECK(out.id == 0x1ABCDEF0u);
    CHECK(out.len == 3);
    CHECK(out.data[2] == 3);
  }
  SECTION("standard identifier masks to 11 bits, remote and error flags") {
    ::can_frame raw{};
    raw.can_id = 0x7FF | CAN_RTR_FLAG;
    REQUIRE(convert_socketcan_frame(&raw, sizeof(raw), out));
    CHECK(out.id == 0x7FF);
    CHECK(out.remote);
    raw.can_id = CAN_ERR_FLAG | CAN_ERR_BUSOFF;  // 0x40: bus-off error class
    REQUIRE(convert_socketcan_frame(&raw, sizeof(raw), out));
    CHECK(out.error);
    CHECK(out.id == 0x40);
  }
  SECTION("impossible length is rejected") {
    ::can_frame raw{};
    raw.len = 9;
    CHECK_FALSE(convert_socketcan_frame(&raw, sizeof(raw), out));
  }
}

TEST_CASE("canfd_frame bytes convert to CanFrame", "[socketcan]") {
  CanFrame out;
  ::canfd_frame raw{};
  raw.can_id = 0x101;
  raw.len = 64;
  raw.flags = CANFD_BRS | CANFD_ESI | 0x04;  // 0x04 = CANFD_FDF on newer kernels: not a user flag
  for (int i = 0; i < 64; ++i) raw.data[i] = static_cast<std::uint8_t>(i * 3);
  REQUIRE(convert_socketcan_frame(&raw, sizeof(raw), out));
  CHECK(out.fd);
  CHECK(out.id == 0x101);
  CHECK(out.len == 64);
  CHECK(out.fd_flags == 0x03);
  CHECK(bytes_of(out.data.data(), 64) == bytes_of(raw.data, 64));

  raw.len = 12;  // a valid FD length above 8: the rest of `data` must be cleared
  REQUIRE(convert_socketcan_frame(&raw, sizeof(raw), out));
  CHECK(out.len == 12);
  CHECK(out.data[11] == 33);
  CHECK(out.data[12] == 0);

  raw.len = 13;  // not a CAN FD length (DLC steps are 12, 16, 20, 24, 32, 48, 64)
  CHECK_FALSE(convert_socketcan_frame(&raw, sizeof(raw), out));
  CHECK_FALSE(convert_socketcan_frame(&raw, 71, out));  // neither CAN_MTU nor CANFD_MTU
  CHECK_FALSE(convert_socketcan_frame(&raw, 0, out));
  CHECK_FALSE(convert_socketcan_frame(nullptr, CANFD_MTU, out));
}

TEST_CASE("receive metadata reads the drop counter and the timestamp control messages", "[socketcan]") {
  alignas(::cmsghdr) unsigned char control[CMSG_SPACE(sizeof(std::uint32_t)) + CMSG_SPACE(sizeof(::timeval))] = {};
  ::msghdr message{};
  message.msg_control = control;
  message.msg_controllen = sizeof(control);

  ::cmsghdr* first = CMSG_FIRSTHDR(&message);
  first->cmsg_level = SOL_SOCKET;
  first->cmsg_type = SO_RXQ_OVFL;
  first->cmsg_len = CMSG_LEN(sizeof(std::uint32_t));
  const std::uint32_t drops = 4000000123u;
  std::memcpy(CMSG_DATA(first), &drops, sizeof(drops));

  ::cmsghdr* second = CMSG_NXTHDR(&message, first);
  REQUIRE(second != nullptr);
  second->cmsg_level = SOL_SOCKET;
  second->cmsg_type = SCM_TIMESTAMP;
  second->cmsg_len = CMSG_LEN(sizeof(::timeval));
  const ::timeval tv{1700000000, 250000};
  std::memcpy(CMSG_DATA(second), &tv, sizeof(tv));

  const ReceiveMetadata meta = parse_receive_metadata(message);
  REQUIRE(meta.cumulative_drops.has_value());
  CHECK(*meta.cumulative_drops == 4000000123u);
  REQUIRE(meta.kernel_time_s.has_value());
  // 1.7e9 s + 0.25 s: a double holds this to ~2e-7 s (52-bit mantissa at 2^31 s).
  CHECK(*meta.kernel_time_s == Approx(1700000000.25).margin(1e-6));

  message.msg_controllen = CMSG_SPACE(sizeof(std::uint32_t));  // only the first message
  const ReceiveMetadata only_drops = parse_receive_metadata(message);
  CHECK(only_drops.cumulative_drops.has_value());
  CHECK_FALSE(only_drops.kernel_time_s.has_value());

  ::msghdr empty{};
  const ReceiveMetadata none = parse_receive_metadata(empty);
  CHECK_FALSE(none.cumulative_drops.has_value());
  CHECK_FALSE(none.kernel_time_s.has_value());
}

TEST_CASE("KernelDropTracker turns the cumulative u32 counter into increments", "[socketcan]") {
  KernelDropTracker tracker;
  CHECK(tracker.observe(0) == 0);
  CHECK(tracker.observe(0) == 0);
  CHECK(tracker.observe(5) == 5);
  CHECK(tracker.observe(5) == 0);
  CHECK(tracker.observe(12) == 7);
  CHECK(tracker.observe(0xFFFFFFF0u) == 0xFFFFFFF0u - 12);
  CHECK(tracker.observe(0x10u) == 0x20u);  // wrapped: 0x10 more than 2^32 - 0x10
  tracker.reset();                         // new socket: its counter starts at zero
  CHECK(tracker.observe(3) == 3);
}

TEST_CASE("ReopenBackoff doubles from the initial delay up to the cap", "[socketcan]") {
  ReopenBackoff backoff(100ms, 5000ms);
  const std::vector<long> expected{100, 200, 400, 800, 1600, 3200, 5000, 5000};
  for (const long ms : expected) CHECK(backoff.next().count() == ms);
  backoff.reset();
  CHECK(backoff.peek().count() == 100);
  CHECK(backoff.next().count() == 100);

  ReopenBackoff uneven(30ms, 100ms);  // a cap that is not a power-of-two multiple
  CHECK(uneven.next().count() == 30);
  CHECK(uneven.next().count() == 60);
  CHECK(uneven.next().count() == 100);
  CHECK(uneven.next().count() == 100);

  CHECK_THROWS_AS(ReopenBackoff(0ms, 100ms), std::invalid_argument);
  CHECK_THROWS_AS(ReopenBackoff(200ms, 100ms), std::invalid_argument);
}

TEST_CASE("LogRateLimiter lets one message per interval through and counts the rest", "[socketcan]") {
  LogRateLimiter limiter(10s);
  const LogRateLimiter::clock::time_point t0{};
  std::uint64_t suppressed = 99;
  CHECK(limiter.allow(t0 + 1s, suppressed));
  CHECK(suppressed == 0);
  CHECK_FALSE(limiter.allow(t0 + 2s, suppressed));
  CHECK_FALSE(limiter.allow(t0 + 5s, suppressed));
  CHECK_FALSE(limiter.allow(t0 + 10999ms, suppressed));
  CHECK(limiter.allow(t0 + 11s, suppressed));  // exactly one interval after the last one through
  CHECK(suppressed == 3);
  CHECK(limiter.allow(t0 + 30s, suppressed));
  CHECK(suppressed == 0);
}

TEST_CASE("interface names and options are validated before anything is opened", "[socketcan]") {
  CHECK_NOTHROW(validate_interface_name("can0"));
  CHECK_NOTHROW(validate_interface_name("vcan0"));
  CHECK_NOTHROW(validate_interface_name("abcdefghijklmno"));  // 15 = IFNAMSIZ - 1
  CHECK_THROWS_AS(validate_interface_name("abcdefghijklmnop"), std::invalid_argument);
  CHECK_THROWS_AS(validate_interface_name(""), std::invalid_argument);
  CHECK_THROWS_AS(validate_interface_name("can/0"), std::invalid_argument);
  CHECK_THROWS_AS(validate_interface_name("can 0"), std::invalid_argument);

  boost::asio::io_context io;
  CHECK_THROWS_AS(SocketCanSource(io, ""), std::invalid_argument);
  SocketCanOptions options;
  options.frames_per_syscall = 0;
  CHECK_THROWS_AS(SocketCanSource(io, "can0", options), std::invalid_argument);
  options = {};
  options.reopen_initial = 0ms;
  CHECK_THROWS_AS(SocketCanSource(io, "can0", options), std::invalid_argument);
  options = {};
  options.reopen_maximum = 50ms;  // below the 100 ms initial delay
  CHECK_THROWS_AS(SocketCanSource(io, "can0", options), std::invalid_argument);
  options = {};
  options.receive_buffer_bytes = 0;
  CHECK_THROWS_AS(SocketCanSource(io, "can0", options), std::invalid_argument);

  SocketCanSource source(io, "can0");
  CHECK_FALSE(source.is_open());  // the constructor opens nothing
  CHECK(source.describe() == "socketcan:can0 (CAN FD)");
  CHECK_THROWS_AS(source.start(nullptr, nullptr), std::invalid_argument);
}

namespace {

/// True when this kernel can create CAN_RAW sockets.
bool kernel_has_socketcan() {
  const int fd = ::socket(PF_CAN, SOCK_RAW, CAN_RAW);
  if (fd < 0) return false;
  ::close(fd);
  return true;
}

}  // namespace

TEST_CASE("without AF_CAN the source ends with a clear reason and run() returns", "[socketcan]") {
  if (kernel_has_socketcan()) {
    WARN("this kernel has SocketCAN: the missing-AF_CAN path cannot be exercised here");
    SUCCEED();
    return;
  }
  boost::asio::io_context io;
  SocketCanSource source(io, "vcan0");
  std::vector<SourceEnd> ends;
  int frames = 0;
  source.start([&](const CanFrame&) { ++frames; }, [&](const SourceEnd& end) { ends.push_back(end); });
  CHECK(ends.empty());  // never called from inside start()
  const std::size_t handlers = io.run_for(5s);
  CHECK(io.stopped());  // ran out of work by itself: nothing left armed
  CHECK(handlers == 1);
  REQUIRE(ends.size() == 1);
  CHECK(ends[0].kind == SourceEndKind::failed);
  CHECK(ends[0].error.find("no SocketCAN support") != std::string::npos);
  CHECK(frames == 0);
  CHECK(source.health().frames == 0);
  CHECK(source.health().reopens == 0);
  CHECK_FALSE(source.is_open());
  source.stop();  // after the end: harmless, no second EndHandler call
  CHECK(ends.size() == 1);
}

// ---------------------------------------------------------------------------------------
// Tests on a real vcan interface (inside the test VM)
// ---------------------------------------------------------------------------------------

namespace {

/// The [vcan] tests only run when asked for by their tag (inside the test VM). There a missing
/// interface means the VM's setup is broken, so it is a failure, never a silent pass.
void require_interface(const char* name) {
  if (!kernel_has_socketcan()) FAIL("this kernel has no SocketCAN; run the [vcan] tests with tests/vcan/run-vcan-unit-tests.sh");
  if (::if_nametoindex(name) == 0) FAIL("no network interface " << name << "; the [vcan] tests need the test VM's vcan0/vcan1");
}

/// A plain CAN_RAW socket that writes frames, as a sensor front-end would.
class RawSender {
 public:
  explicit RawSender(const char* interface_name) {
    fd_ = ::socket(PF_CAN, SOCK_RAW, CAN_RAW);
    REQUIRE(fd_ >= 0);
    const int on = 1;
    REQUIRE(::setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_FD_FRAMES, &on, sizeof(on)) == 0);
    ::sockaddr_can address{};
    address.can_family = AF_CAN;
    address.can_ifindex = static_cast<int>(::if_nametoindex(interface_name));
    REQUIRE(::bind(fd_, reinterpret_cast<::sockaddr*>(&address), sizeof(address)) == 0);
  }
  ~RawSender() { ::close(fd_); }
  RawSender(const RawSender&) = delete;
  RawSender& operator=(const RawSender&) = delete;

  void send(const void* frame, std::size_t size) {
    for (int attempt = 0; attempt < 1000; ++attempt) {
      const ssize_t n = ::write(fd_, frame, size);
      if (n == static_cast<ssize_t>(size)) return;
      if (n < 0 && errno == ENOBUFS) {  // transmit queue full: wait for it, never lose the frame
        std::this_thread::sleep_for(100us);
        continue;
      }
      FAIL("write to CAN socket failed: " << std::strerror(errno));
    }
    FAIL("write to CAN socket kept failing with ENOBUFS");
  }
  void send_classic(canid_t id, std::uint8_t len, std::uint8_t seed) {
    ::can_frame f{};
    f.can_id = id;
    f.len = len;
    for (int i = 0; i < len; ++i) f.data[i] = static_cast<std::uint8_t>(seed + i);
    send(&f, sizeof(f));
  }
  void send_fd(canid_t id, std::uint8_t len, std::uint8_t flags, std::uint8_t seed) {
    ::canfd_frame f{};
    f.can_id = id;
    f.len = len;
    f.flags = flags;
    for (int i = 0; i < len; ++i) f.data[i] = static_cast<std::uint8_t>(seed + i);
    send(&f, sizeof(f));
  }

 private:
  int fd_ = -1;
};

/// Runs the io_context in short slices until `done()` or the time limit.
template <class Predicate>
bool run_until(boost::asio::io_context& io, Predicate done, std::chrono::milliseconds limit) {
  const auto deadline = std::chrono::steady_clock::now() + limit;
  while (!done()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    io.restart();
    io.run_for(5ms);
  }
  return true;
}

int shell(const std::string& command) {
  const int status = std::system(command.c_str());
  INFO("command: " << command);
  REQUIRE(status == 0);
  return status;
}

}  // namespace

TEST_CASE("classic and FD frames on vcan0 arrive through SocketCanSource intact", "[.vcan]") {
  require_interface("vcan0");
  boost::asio::io_context io;
  SocketCanSource source(io, "vcan0");
  std::vector<CanFrame> received;
  std::vector<SourceEnd> ends;
  source.start([&](const CanFrame& f) { received.push_back(f); },
               [&](const SourceEnd& end) { ends.push_back(end); });
  REQUIRE(source.is_open());  // vcan0 is up: opened synchronously, frames queue from now on
  // Root in the VM: SO_RCVBUFFORCE grants the 8 MiB asked, past net.core.rmem_max.
  CHECK(source.granted_receive_buffer() >= SocketCanOptions{}.receive_buffer_bytes);

  RawSender sender("vcan0");
  sender.send_classic(0x123, 8, 10);
  sender.send_classic(0x1ABCDEF0u | CAN_EFF_FLAG, 3, 20);
  sender.send_classic(0x7FF | CAN_RTR_FLAG, 0, 0);
  sender.send_fd(0x100, 64, CANFD_BRS, 30);
  sender.send_fd(0x101, 12, 0, 40);
  sender.send_fd(0x102, 0, CANFD_ESI, 0);
  const int bulk = 500;  // a burst larger than one recvmmsg batch and one wake-up budget
  for (int i = 0; i < bulk; ++i) sender.send_fd(0x100, 64, CANFD_BRS, static_cast<std::uint8_t>(i));

  REQUIRE(run_until(io, [&] { return received.size() >= 6 + bulk; }, 10000ms));
  source.stop();
  io.restart();
  io.run_for(100ms);
  CHECK(io.stopped());  // after stop() nothing is left armed
  REQUIRE(ends.size() == 1);
  CHECK(ends[0].kind == SourceEndKind::stopped);
  CHECK(ends[0].error.empty());

  REQUIRE(received.size() == 6 + bulk);
  CHECK(source.health().frames == 6 + bulk);
  CHECK(source.health().kernel_drops == 0);
  CHECK(source.health().read_errors == 0);
  CHECK(source.health().reopens == 0);

  CHECK(received[0].id == 0x123);
  CHECK_FALSE(received[0].fd);
  CHECK(received[0].len == 8);
  CHECK(received[0].data[7] == 17);
  CHECK(received[1].extended);
  CHECK(received[1].id == 0x1ABCDEF0u);
  CHECK(received[1].len == 3);
  CHECK(received[1].data[2] == 22);
  CHECK(received[2].remote);
  CHECK(received[2].id == 0x7FF);
  CHECK(received[3].fd);
  CHECK(received[3].id == 0x100);
  CHECK(received[3].len == 64);
  CHECK(received[3].fd_flags == CANFD_BRS);
  CHECK(received[3].data[63] == 93);
  CHECK(received[4].len == 12);
  CHECK(received[4].data[11] == 51);
  CHECK(received[5].len == 0);
  CHECK(received[5].fd_flags == CANFD_ESI);
  // The bulk arrives complete and in order (vcan delivers in send order).
  int out_of_order = 0;
  for (int i = 0; i < bulk; ++i) {
    const CanFrame& f = received[6 + i];
    if (f.data[0] != static_cast<std::uint8_t>(i) || f.data[63] != static_cast<std::uint8_t>(i + 63)) ++out_of_order;
  }
  CHECK(out_of_order == 0);
}

TEST_CASE("kernel drops in a full receive buffer are counted exactly", "[.vcan]") {
  require_interface("vcan0");
  boost::asio::io_context io;
  SocketCanOptions options;
  options.receive_buffer_bytes = 4096;  // tiny on purpose: a burst must overflow it
  SocketCanSource source(io, "vcan0", options);
  std::vector<CanFrame> received;
  source.start([&](const CanFrame& f) { received.push_back(f); }, [](const SourceEnd&) {});
  REQUIRE(source.is_open());

  // Send the burst while nobody reads: the kernel keeps the first frames that fit and drops
  // the rest, incrementing the socket's drop counter.
  RawSender sender("vcan0");
  const int burst = 2000;
  for (int i = 0; i < burst; ++i) sender.send_fd(0x100, 64, 0, static_cast<std::uint8_t>(i % 251));
  REQUIRE(run_until(io, [&] { return !received.empty(); }, 5000ms));
  io.restart();
  io.run_for(200ms);  // drain what the buffer held
  const std::size_t kept = received.size();
  // The counter reaches user space only with the next frame queued: send a marker.
  sender.send_classic(0x7AA, 1, 0);
  REQUIRE(run_until(io, [&] { return !received.empty() && received.back().id == 0x7AA; }, 5000ms));
  source.stop();

  INFO("kept " << kept << " of " << burst << ", kernel_drops " << source.health().kernel_drops);
  CHECK(kept > 0);
  CHECK(kept < static_cast<std::size_t>(burst));
  // Conservation: every frame sent was either delivered or counted as dropped.
  CHECK(kept + source.health().kernel_drops == static_cast<std::uint64_t>(burst));
  CHECK(received.size() == kept + 1);
  // The kernel drops the newest frames when full, so the kept ones are the first `kept`.
  int mismatched = 0;
  for (std::size_t i = 0; i < kept; ++i)
    if (received[i].data[0] != static_cast<std::uint8_t>(i % 251)) ++mismatched;
  CHECK(mismatched == 0);
}

TEST_CASE("stop() delivers the frames already queued and counts the drops no frame reported", "[.vcan]") {
  require_interface("vcan0");
  RawSender sender("vcan0");
  {
    boost::asio::io_context io;
    SocketCanSource source(io, "vcan0");
    std::vector<CanFrame> received;
    std::vector<SourceEnd> ends;
    source.start([&](const CanFrame& f) { received.push_back(f); },
                 [&](const SourceEnd& end) { ends.push_back(end); });
    REQUIRE(source.is_open());
    for (int i = 0; i < 50; ++i) sender.send_classic(0x300, 2, static_cast<std::uint8_t>(i));
    source.stop();  // the io_context never ran: only stop() can deliver them
    REQUIRE(received.size() == 50);
    CHECK(received[49].data[0] == 49);
    CHECK(ends.size() == 1);
    CHECK(source.health().kernel_drops == 0);
  }
  {
    boost::asio::io_context io;
    SocketCanOptions options;
    options.receive_buffer_bytes = 4096;
    SocketCanSource source(io, "vcan0", options);
    std::size_t received = 0;
    source.start([&](const CanFrame&) { ++received; }, [](const SourceEnd&) {});
    REQUIRE(source.is_open());
    const int burst = 2000;
    for (int i = 0; i < burst; ++i) sender.send_fd(0x100, 64, 0, 0);
    source.stop();  // no frame after the overflow: the drops are read with SO_MEMINFO
    INFO("kept " << received << ", kernel_drops " << source.health().kernel_drops);
    CHECK(received > 0);
    CHECK(received + source.health().kernel_drops == static_cast<std::uint64_t>(burst));
  }
}

TEST_CASE("an interface that goes down and comes back is reopened with backoff", "[.vcan]") {
  require_interface("vcan0");
  boost::asio::io_context io;
  SocketCanOptions options;
  options.reopen_initial = 20ms;
  options.reopen_maximum = 160ms;
  SocketCanSource source(io, "vcan0", options);
  std::vector<CanFrame> received;
  std::vector<SourceEnd> ends;
  source.start([&](const CanFrame& f) { received.push_back(f); },
               [&](const SourceEnd& end) { ends.push_back(end); });
  REQUIRE(source.is_open());
  {
    RawSender sender("vcan0");
    for (int i = 0; i < 10; ++i) sender.send_classic(0x200, 8, static_cast<std::uint8_t>(i));
  }
  REQUIRE(run_until(io, [&] { return received.size() == 10; }, 5000ms));
  CHECK(source.health().read_errors == 0);

  shell("ip link set vcan0 down");
  REQUIRE(run_until(io, [&] { return source.health().read_errors >= 1; }, 5000ms));
  // While down, every reopen attempt fails; let a few of them happen.
  REQUIRE(run_until(io, [&] { return source.health().read_errors >= 3; }, 5000ms));
  CHECK(source.health().reopens == 0);
  shell("ip link set vcan0 up");
  REQUIRE(run_until(io, [&] { return source.health().reopens >= 1; }, 5000ms));
  {
    RawSender sender("vcan0");
    for (int i = 0; i < 10; ++i) sender.send_classic(0x201, 8, static_cast<std::uint8_t>(100 + i));
  }
  REQUIRE(run_until(io, [&] { return received.size() == 20; }, 5000ms));
  source.stop();

  CHECK(ends.size() == 1);  // only the stop(): the outage did not end the source
  CHECK(source.health().reopens == 1);  // one successful reopen after the outage
  CHECK(source.health().read_errors >= 3);
  CHECK(source.health().frames == 20);
  CHECK(source.health().kernel_drops == 0);
  CHECK(received[10].id == 0x201);
  CHECK(received[19].data[0] == 109);
}

TEST_CASE("an interface that is removed and re-created is reopened", "[.vcan]") {
  require_interface("vcan1");
  boost::asio::io_context io;
  SocketCanOptions options;
  options.reopen_initial = 20ms;
  options.reopen_maximum = 80ms;
  SocketCanSource source(io, "vcan1", options);
  int frames = 0;
  source.start([&](const CanFrame&) { ++frames; }, [](const SourceEnd&) {});
  REQUIRE(source.is_open());

  shell("ip link del vcan1");  // the kernel unbinds the socket with ENODEV
  REQUIRE(run_until(io, [&] { return source.health().read_errors >= 2; }, 5000ms));
  CHECK_FALSE(source.is_open());
  shell("ip link add dev vcan1 type vcan && ip link set vcan1 mtu 72 && ip link set vcan1 up");
  REQUIRE(run_until(io, [&] { return source.health().reopens == 1; }, 5000ms));
  {
    RawSender sender("vcan1");
    for (int i = 0; i < 5; ++i) sender.send_fd(0x100, 64, 0, static_cast<std::uint8_t>(i));
  }
  REQUIRE(run_until(io, [&] { return frames == 5; }, 5000ms));
  source.stop();
  CHECK(source.health().frames == 5);
  CHECK(source.health().reopens == 1);
}

TEST_CASE("a missing interface is retried on the backoff schedule until it appears", "[.vcan]") {
  require_interface("vcan0");
  boost::asio::io_context io;
  SocketCanOptions options;
  options.reopen_initial = 10ms;
  options.reopen_maximum = 40ms;
  SocketCanSource source(io, "gwmissing0", options);
  std::vector<SourceEnd> ends;
  const auto t0 = std::chrono::steady_clock::now();
  source.start([](const CanFrame&) {}, [&](const SourceEnd& end) { ends.push_back(end); });
  CHECK_FALSE(source.is_open());
  CHECK(source.health().read_errors == 1);  // the first attempt, inside start()
  REQUIRE(run_until(io, [&] { return source.health().read_errors >= 6; }, 5000ms));
  const auto elapsed = std::chrono::steady_clock::now() - t0;
  // Attempts 2..6 wait 10, 20, 40, 40, 40 ms after each previous failure; timers never fire
  // early, so the sixth failure cannot come before 150 ms.
  CHECK(elapsed >= 150ms);
  CHECK(ends.empty());  // a missing interface is not fatal: the daemon may start before it exists
  source.stop();
  REQUIRE(ends.size() == 1);
  CHECK(ends[0].kind == SourceEndKind::stopped);
  CHECK(ends[0].error.empty());
  io.restart();
  io.run_for(200ms);
  CHECK(io.stopped());  // the pending reopen timer was cancelled
}

TEST_CASE("a non-CAN interface is a permanent error", "[.vcan]") {
  require_interface("lo");
  boost::asio::io_context io;
  SocketCanSource source(io, "lo");
  std::vector<SourceEnd> ends;
  source.start([](const CanFrame&) {}, [&](const SourceEnd& end) { ends.push_back(end); });
  io.run_for(1s);
  CHECK(io.stopped());
  REQUIRE(ends.size() == 1);
  CHECK(ends[0].kind == SourceEndKind::failed);
  CHECK(ends[0].error == "interface lo is not a CAN interface");
}

}  // namespace test_socketcan
