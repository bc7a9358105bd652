#pragma once
// A real PostgreSQL server for the fleet tests, started by the test: `initdb` into its own
// temporary directory (as `nobody` when the test runs as root: PostgreSQL refuses root), a free
// port on 127.0.0.1, the socket in that directory; stopped with `pg_ctl stop` at the end. Not a
// component: test support. Every wait is bounded.
#include <pwd.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
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
  int port() const noexcept { return port_; }
  /// postgresql:// URI of database `name` on this server.
  std::string uri(const std::string& name) const { return "postgresql://gw@127.0.0.1:" + std::to_string(port_) + "/" + name; }

  void start() {
    const auto r = run(bin_ / "pg_ctl", "-D " + (dir_ / "data").string() + " -o \"-c listen_addresses=127.0.0.1 -p " +
                                            std::to_string(port_) + " -k " + dir_.string() + "\" -l " + (dir_ / "log").string() +
                                            " -w -t 30 start >/dev/null");
    if (r.status != 0) throw std::runtime_error("pg_ctl start failed: " + r.err);
    running_ = true;
  }
  void stop() {
    if (!running_) return;
    run(bin_ / "pg_ctl", "-D " + (dir_ / "data").string() + " -m fast -w -t 30 stop >/dev/null");
    running_ = false;
  }
  void create_database(const std::string& name) {
    const auto r = run_command((bin_ / "psql").string() + " -h 127.0.0.1 -p " + std::to_string(port_) +
                               " -U gw -d postgres -qc 'CREATE DATABASE " + name + "'");
    if (r.status != 0) throw std::runtime_error("CREATE DATABASE failed: " + r.err);
  }

 private:
  CommandResult run(const std::filesystem::path& program, const std::string& args) const {
    const std::string line = program.string() + " " + args;
    if (::geteuid() != 0) return run_command(line);
    return run_command("runuser -u nobody -- " + line);
  }
  std::filesystem::path dir_, bin_;
  int port_;
  bool running_ = false;
};

}  // namespace gearwatch::testing
