#pragma once
// A real PostgreSQL server for the fleet tests, started by the test: `initdb` into its own
// temporary directory (as `nobody` when the test runs as root: PostgreSQL refuses root), a free
// port on 127.0.0.1, the socket in that directory; stopped with `pg_ctl stop` at the end. Not a
// component: test support. Every wait is bounded.
#include <pwd.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "command_runner.hpp"
#include "mqtt/mqtt_broker.hpp"

namespace gearwatch::testing {

/// The newest /usr/lib/postgresql/<major>/bin that has initdb and pg_ctl (Debian's layout), if any.
inline std::optional<std::filesystem::path> postgres_bin_dir() {
  const std::filesystem::path root = "/usr/lib/postgresql";
  std::vector<std::filesystem::path> found;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(root, ec))
    if (std::filesystem::exists(e.path() / "bin" / "initdb") && std::filesystem::exists(e.path() / "bin" / "pg_ctl"))
      found.push_back(e.path() / "bin");
  if (found.empty()) return std::nullopt;
  std::sort(found.begin(), found.end(), [](const auto& a, const auto& b) {
    return std::stoi(a.parent_path().filename().string()) < std::stoi(b.parent_path().filename().string());
  });
  return found.back();
}

class PostgresServer {
 public:
  PostgresServer(std::filesystem::path dir, std::filesystem::path bin) : dir_(std::move(dir)), bin_(std::move(bin)), port_(free_loopback_port()) {
    std::filesystem::create_directories(dir_);
    if (::geteuid() == 0) {
      const passwd* nobody = ::getpwnam("nobody");
      if (!nobody) throw std::runtime_error("no user nobody to run PostgreSQL as");
      (void)::chown(dir_.c_str(), nobody->pw_uid, nobody->pw_gid);
      // The test's temporary directories above must let nobody through.
      for (auto p = dir_.parent_path(); p != p.root_path(); p = p.parent_path()) {
        std::error_code ec;
        std::filesystem::permissions(p, std::filesystem::perms::others_exec, std::filesystem::perm_options::add, ec);
      }
    }
    const auto r = run(bin_ / "initdb", "-D " + (dir_ / "data").string() + " -A trust -U gw --no-sync >/dev/null");
    if (r.status != 0) throw std::runtime_error("initdb failed: " + r.err);
  }
  ~PostgresServer() { stop(); }
  /// The server's port; once handed out (a URI holds it) start() no longer moves it.
  int port() const noexcept {
    port_handed_out_ = true;
    return port_;
  }
  /// postgresql:// URI of database `name` on this server.
  std::string uri(const std::string& name) const { return "postgresql://gw@127.0.0.1:" + std::to_string(port()) + "/" + name; }

  /// pg_ctl start (it waits 30 s at most), then checks that the postmaster itself listens on the
  /// port. On the first start, while nobody has been told the port, a port taken in the meantime is
  /// replaced by another (five tries); otherwise a collision is an error naming the port.
  void start() {
    const bool may_move = !port_handed_out_ && !started_once_;
    for (int attempt = 1;; ++attempt) {
      if (may_move) port_ = free_loopback_port();  // fresh, just before the server binds it
      const auto r = run(bin_ / "pg_ctl", "-D " + (dir_ / "data").string() + " -o \"-c listen_addresses=127.0.0.1 -p " +
                                              std::to_string(port_) + " -k " + dir_.string() + "\" -l " + (dir_ / "log").string() +
                                              " -w -t 30 start >/dev/null");
      if (r.status == 0) {
        running_ = true;
        started_once_ = true;
        const pid_t pid = postmaster_pid();
        if (pid > 0 && pid_listens_on(pid, port_)) {
          postmaster_ = pid;
          register_server(pid);
          return;
        }
        stop();
        throw std::runtime_error("PostgreSQL started but its postmaster (pid " + std::to_string(pid) + ") does not listen on 127.0.0.1:" +
                                 std::to_string(port_));
      }
      const std::string log = read_log();
      const bool taken = log.find("could not bind") != std::string::npos || log.find("already in use") != std::string::npos;
      const std::string why = "pg_ctl start failed on 127.0.0.1:" + std::to_string(port_) + ": " + r.err + log;
      if (!may_move || !taken || attempt == 5) throw std::runtime_error(why);
      std::cerr << why << "; trying another port" << std::endl;
    }
  }
  /// pg_ctl stop (fast, 30 s at most); a server still there after it is ended with SIGQUIT
  /// (PostgreSQL's immediate shutdown), then SIGKILL.
  void stop() {
    if (!running_) return;
    const pid_t pid = postmaster_pid();
    const auto r = run(bin_ / "pg_ctl", "-D " + (dir_ / "data").string() + " -m fast -w -t 30 stop >/dev/null");
    running_ = false;
    unregister_server(postmaster_);
    if (r.status == 0 || pid <= 0) return;
    std::cerr << "pg_ctl stop failed (" << r.err << "): ending postmaster " << pid << std::endl;
    for (const int sig : {SIGQUIT, SIGKILL}) {
      ::kill(pid, sig);
      if (wait_until([&] { return ::kill(pid, 0) != 0; }, std::chrono::seconds(10))) return;
    }
  }
  void create_database(const std::string& name) {
    const auto r = run_command("PGCONNECT_TIMEOUT=30 " + (bin_ / "psql").string() + " -h 127.0.0.1 -p " + std::to_string(port_) +
                                   " -U gw -d postgres -qc 'CREATE DATABASE " + name + "'",
                               std::chrono::seconds(120));
    if (r.status != 0) throw std::runtime_error("CREATE DATABASE failed: " + r.err);
  }

 private:
  // pg_ctl waits 30 s at most; initdb has two minutes.
  CommandResult run(const std::filesystem::path& program, const std::string& args) const {
    const std::string line = program.string() + " " + args;
    const auto limit = std::chrono::seconds(120);
    if (::geteuid() != 0) return run_command(line, limit);
    return run_command("runuser -u nobody -- " + line, limit);
  }
  // The postmaster's pid: the first line of postmaster.pid while it runs.
  pid_t postmaster_pid() const {
    std::ifstream f(dir_ / "data" / "postmaster.pid");
    long pid = -1;
    f >> pid;
    return f ? static_cast<pid_t>(pid) : -1;
  }
  std::string read_log() const {
    std::ifstream f(dir_ / "log");
    return {std::istreambuf_iterator<char>(f), {}};
  }
  std::filesystem::path dir_, bin_;
  int port_;
  mutable bool port_handed_out_ = false;
  bool started_once_ = false;
  bool running_ = false;
  pid_t postmaster_ = -1;
};

}  // namespace gearwatch::testing
