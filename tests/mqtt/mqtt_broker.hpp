#pragma once
// A real mosquitto broker for the MQTT tests, started by the test on 127.0.0.1 (a free port, a
// password file made with mosquitto_passwd, persistence in its own temporary directory), and a
// libmosquitto subscriber with a persistent session that collects what the broker delivers.
// Not a component: test support. Every wait is bounded.
#include <arpa/inet.h>
#include <mosquitto.h>
#include <netinet/in.h>
#include <pwd.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "command_runner.hpp"

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
    write_config("");
  }
  /// Another user of the password file (before start()).
  void add_user(const std::string& user, const std::string& password) {
    const auto r = run_command("mosquitto_passwd -b " + (dir_ / "pw").string() + " '" + user + "' '" + password + "'");
    if (r.status != 0) throw std::runtime_error("mosquitto_passwd: " + r.err);
    give_to_broker(dir_ / "pw");
  }
  /// The listener speaks TLS only, wants a client certificate signed by the test CA, and the ACL
  /// file's rules apply (before start()).
  void use_tls_and_acl(const std::filesystem::path& ca, const std::filesystem::path& cert, const std::filesystem::path& key,
                       const std::string& acl) {
    std::ofstream(dir_ / "acl") << acl;
    for (const auto& f : {ca, cert, key, dir_ / "acl"}) give_to_broker(f);
    write_config("cafile " + ca.string() + "\ncertfile " + cert.string() + "\nkeyfile " + key.string() +
                 "\nrequire_certificate true\nacl_file " + (dir_ / "acl").string() + "\n");
  }
  ~MosquittoBroker() { stop(); }
  int port() const noexcept { return port_; }

  void start() {
    pid_ = spawn({"-c", (dir_ / "m.conf").string()}, dir_ / "stdout", dir_ / "stderr", 0, "/usr/sbin/mosquitto");
    if (!wait_until([&] { return port_accepts(port_); }, std::chrono::seconds(10)))
      throw std::runtime_error("mosquitto did not listen within 10 s");
  }
  /// SIGTERM: the broker saves its sessions (persistence) and exits.
  void stop() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGTERM);
    wait_exit(pid_);
    pid_ = -1;
  }

 private:
  // As root, mosquitto drops to `nobody` (the recipe's unprivileged user): it must own its files.
  void give_to_broker(const std::filesystem::path& p) const {
    if (::geteuid() != 0) return;
    const passwd* nobody = ::getpwnam("nobody");
    (void)::chown(p.c_str(), nobody->pw_uid, nobody->pw_gid);
    std::filesystem::permissions(p, std::filesystem::perms::owner_read | std::filesystem::perms::owner_write);
  }
  void write_config(const std::string& listener_options) {
    const bool root = ::geteuid() == 0;
    std::ofstream(dir_ / "m.conf") << "listener " << port_ << " 127.0.0.1\n" << listener_options << "allow_anonymous false\npassword_file "
                                   << (dir_ / "pw").string() << "\npersistence true\npersistence_location " << dir_.string() << "/\n"
                                   << (root ? "user nobody\n" : "");
    if (root) {
      const passwd* nobody = ::getpwnam("nobody");
      for (const auto& p : {dir_, dir_ / "m.conf"}) (void)::chown(p.c_str(), nobody->pw_uid, nobody->pw_gid);
    }
  }
  std::filesystem::path dir_;
  std::string user_, password_;
  int port_;
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
