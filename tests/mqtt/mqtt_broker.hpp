#pragma once
// A real mosquitto broker for the MQTT tests, started by the test on 127.0.0.1 (a free port, a
// password file made with mosquitto_passwd, persistence in its own temporary directory), and a
// libmosquitto subscriber with a persistent session that collects what the broker delivers.
// Not a component: test support. Every wait is bounded.
#include <arpa/inet.h>
#include <mosquitto.h>
#include <netinet/in.h>
#include <pwd.h>
#include <sys/wait.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <cstdio>
#include <functional>
#include <iostream>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "command_runner.hpp"
#include "step_log.hpp"

namespace gearwatch::testing {

inline int free_loopback_port() {
  const int s = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ::bind(s, reinterpret_cast<sockaddr*>(&a), sizeof a);
  socklen_t len = sizeof a;
  ::getsockname(s, reinterpret_cast<sockaddr*>(&a), &len);
  ::close(s);
  return ntohs(a.sin_port);
}

inline bool port_accepts(int port) {
  const int s = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  a.sin_port = htons(static_cast<std::uint16_t>(port));
  const bool ok = ::connect(s, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
  ::close(s);
  return ok;
}

/// Whether process `pid` holds the socket listening on 127.0.0.1:`port` (/proc/net/tcp's inode
/// among its descriptors): a server that could not bind its port (another test's server or a
/// client took it after free_loopback_port() let it go) is told apart from the stranger answering.
inline bool pid_listens_on(pid_t pid, int port) {
  char local[32];
  std::snprintf(local, sizeof local, "0100007F:%04X", static_cast<unsigned>(port));
  std::ifstream tcp("/proc/net/tcp");
  std::string line, inode;
  std::getline(tcp, line);  // header
  while (std::getline(tcp, line)) {
    std::istringstream f(line);
    std::string slot, loc, rem, st, queues, timer, retransmits, uid, timeout, node;
    f >> slot >> loc >> rem >> st >> queues >> timer >> retransmits >> uid >> timeout >> node;
    if (loc == local && st == "0A") inode = node;  // 0A: LISTEN
  }
  if (inode.empty()) return false;
  std::error_code ec;
  const std::string want = "socket:[" + inode + "]";
  for (const auto& e : std::filesystem::directory_iterator("/proc/" + std::to_string(pid) + "/fd", ec)) {
    std::error_code ignored;
    if (std::filesystem::read_symlink(e.path(), ignored).string() == want) return true;
  }
  return false;
}

/// Polls `done` every 20 ms until it holds or `timeout` passes.
inline bool wait_until(const std::function<bool()>& done, std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!done()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return true;
}

class MosquittoBroker {
 public:
  MosquittoBroker(std::filesystem::path dir, std::string user, std::string password)
      : dir_(std::move(dir)), user_(std::move(user)), password_(std::move(password)), port_(free_loopback_port()) {
    std::filesystem::create_directories(dir_);
    std::ofstream(dir_ / "pw") << "";
    add_user(user_, password_);
  }
  /// Another user of the password file (before start()).
  void add_user(const std::string& user, const std::string& password) {
    const auto r = run_command("mosquitto_passwd -b " + (dir_ / "pw").string() + " '" + user + "' '" + password + "'", std::chrono::seconds(60));
    if (r.status != 0) throw std::runtime_error("mosquitto_passwd: " + r.err);
    give_to_broker(dir_ / "pw");
  }
  /// The listener speaks TLS only, wants a client certificate signed by the test CA, and the ACL
  /// file's rules apply (before start()).
  void use_tls_and_acl(const std::filesystem::path& ca, const std::filesystem::path& cert, const std::filesystem::path& key,
                       const std::string& acl) {
    std::ofstream(dir_ / "acl") << acl;
    for (const auto& f : {ca, cert, key, dir_ / "acl"}) give_to_broker(f);
    listener_options_ = "cafile " + ca.string() + "\ncertfile " + cert.string() + "\nkeyfile " + key.string() +
                 "\nrequire_certificate true\nacl_file " + (dir_ / "acl").string() + "\n";
  }
  ~MosquittoBroker() { stop(); }
  /// The broker's port; once handed out (configs hold it) start() no longer moves it.
  int port() const noexcept {
    port_handed_out_ = true;
    return port_;
  }

  /// Starts mosquitto and waits (10 s at most) until this very process listens on the port and
  /// its main loop runs (below). On the first start, when nobody has been told the port yet, a
  /// port taken in the meantime is replaced by another (five tries); otherwise the collision is an
  /// error naming the port.
  void start() {
    const bool may_move = !port_handed_out_ && !started_once_;
    for (int attempt = 1;; ++attempt) {
      if (may_move) port_ = free_loopback_port();  // fresh, just before the broker binds it
      write_config();
      pid_ = spawn({"-c", (dir_ / "m.conf").string()}, dir_ / "stdout", dir_ / "stderr", 0, "/usr/sbin/mosquitto");
      detail::forget_child(pid_);  // this object ends it (stop), not the test's ChildrenGuard
      bool exited = false;
      int status = 0;
      const bool ready = wait_until(
          [&] {
            exited = ::waitpid(pid_, &status, WNOHANG) == pid_;
            return exited || (pid_listens_on(pid_, port_) && main_loop_runs());
          },
          std::chrono::seconds(10)) && !exited;
      if (ready) {
        started_once_ = true;
        register_server(pid_);
        return;
      }
      if (!exited) terminate_child(pid_);
      pid_ = -1;
      const std::string why = "mosquitto " + std::string(exited ? "exited" : "was not ready within 10 s") + " on 127.0.0.1:" +
                              std::to_string(port_) + (port_accepts(port_) ? " (another process listens there)" : "") + ": " + log();
      if (!may_move || !exited || attempt == 5) throw std::runtime_error(why);
      std::cerr << why << "; trying another port" << std::endl;
    }
  }
  /// SIGTERM: the broker saves its sessions (persistence) and exits. SIGTERM again each second
  /// (one that arrived before its main loop ran is lost, see main_loop_runs), SIGKILL after 10 s.
  void stop() {
    if (pid_ <= 0) return;
    unregister_server(pid_);
    int status = 0, sent = 0;
    bool exited = false;
    while (!exited && sent < 10) {
      ::kill(pid_, SIGTERM);
      ++sent;
      exited = detail::reap_within(pid_, status, std::chrono::seconds(1));
    }
    if (!exited) {
      ::kill(pid_, SIGKILL);
      detail::reap_within(pid_, status, std::chrono::seconds(10));
    }
    if (sent > 1)
      std::cerr << "mosquitto on port " << port_ << (exited ? " exited after SIGTERM number " + std::to_string(sent) : " ignored 10 SIGTERMs: killed")
                << std::endl;
    pid_ = -1;
  }

 private:
  std::string log() const {
    std::ifstream in(dir_ / "stderr");
    return {std::istreambuf_iterator<char>(in), {}};
  }
  // mosquitto 2.0 installs its SIGTERM handler after its listeners open and only then sets its
  // run flag (run = 1) and enters its main loop: a SIGTERM in between is lost, and a broker stopped
  // right after the port first accepted kept running (the TLS fleet test's plain broker, stopped
  // at once, hung in waitpid). Only the main loop accepts connections and logs "New connection":
  // a probe connection logged proves the flag is set and a SIGTERM from now on is honoured.
  bool main_loop_runs() const {
    if (log().find("New connection from") != std::string::npos) return true;
    (void)port_accepts(port_);  // the probe; its log line shows on a later poll
    return false;
  }
  // As root, mosquitto drops to `nobody` (the recipe's unprivileged user): it must own its files.
  void give_to_broker(const std::filesystem::path& p) const {
    if (::geteuid() != 0) return;
    const passwd* nobody = ::getpwnam("nobody");
    (void)::chown(p.c_str(), nobody->pw_uid, nobody->pw_gid);
    std::filesystem::permissions(p, std::filesystem::perms::owner_read | std::filesystem::perms::owner_write);
  }
  void write_config() {
    const bool root = ::geteuid() == 0;
    std::ofstream(dir_ / "m.conf") << "listener " << port_ << " 127.0.0.1\n" << listener_options_ << "allow_anonymous false\npassword_file "
                                   << (dir_ / "pw").string() << "\npersistence true\npersistence_location " << dir_.string() << "/\n"
                                   << (root ? "user nobody\n" : "");
    if (root) {
      const passwd* nobody = ::getpwnam("nobody");
      for (const auto& p : {dir_, dir_ / "m.conf"}) (void)::chown(p.c_str(), nobody->pw_uid, nobody->pw_gid);
    }
  }
  std::filesystem::path dir_;
  std::string user_, password_;
  std::string listener_options_;
  int port_;
  mutable bool port_handed_out_ = false;
  bool started_once_ = false;
  pid_t pid_ = -1;
};

struct ReceivedMessage {
  std::string topic, payload;
  bool retained = false;
};

/// QoS 1 subscriber with a persistent session (clean_session false): while it is away, the
/// broker keeps its messages; libmosquitto's own loop thread reconnects it.
class MqttSubscriber {
 public:
  MqttSubscriber(int port, const std::string& user, const std::string& password, const std::string& filter) : filter_(filter) {
    mosquitto_lib_init();
    client_ = mosquitto_new("gearwatch-test-subscriber", false, this);
    mosquitto_username_pw_set(client_, user.c_str(), password.c_str());
    mosquitto_reconnect_delay_set(client_, 1, 1, false);
    mosquitto_connect_callback_set(client_, [](mosquitto* m, void* obj, int rc) {
      auto* self = static_cast<MqttSubscriber*>(obj);
      if (rc == 0) mosquitto_subscribe(m, nullptr, self->filter_.c_str(), 1);
    });
    mosquitto_subscribe_callback_set(client_, [](mosquitto*, void* obj, int, int, const int*) {
      static_cast<MqttSubscriber*>(obj)->subscribed_ = true;
    });
    mosquitto_message_callback_set(client_, [](mosquitto*, void* obj, const mosquitto_message* m) {
      auto* self = static_cast<MqttSubscriber*>(obj);
      std::lock_guard lock(self->mutex_);
      self->messages_.push_back({m->topic, std::string(static_cast<const char*>(m->payload), static_cast<std::size_t>(m->payloadlen)),
                                 m->retain});
    });
    if (mosquitto_connect(client_, "127.0.0.1", port, 30) != MOSQ_ERR_SUCCESS) throw std::runtime_error("subscriber: cannot connect");
    mosquitto_loop_start(client_);
    if (!wait_until([&] { return subscribed_.load(); }, std::chrono::seconds(10))) throw std::runtime_error("subscriber: no SUBACK in 10 s");
  }
  ~MqttSubscriber() {
    mosquitto_disconnect(client_);
    mosquitto_loop_stop(client_, true);
    mosquitto_destroy(client_);
  }
  std::vector<ReceivedMessage> messages() const {
    std::lock_guard lock(mutex_);
    return messages_;
  }

 private:
  std::string filter_;
  mosquitto* client_ = nullptr;
  std::atomic<bool> subscribed_{false};
  mutable std::mutex mutex_;
  std::vector<ReceivedMessage> messages_;
};

}  // namespace gearwatch::testing
