#pragma once
// A certificate authority made by the test with Debian's openssl: the CA, a server certificate for
// 127.0.0.1 (subjectAltName IP) and a client certificate, all signed by it and valid for two days.
// Test support for the TLS tests of the MQTT publisher and the fleet consumer.
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include "command_runner.hpp"

namespace gearwatch::testing {

struct TestCertificates {
  std::filesystem::path ca, server_cert, server_key, client_cert, client_key;
};

inline TestCertificates make_test_certificates(const std::filesystem::path& dir) {
  std::filesystem::create_directories(dir);
  const auto p = [&](const char* name) { return (dir / name).string(); };
  std::ofstream(dir / "server.ext") << "subjectAltName=IP:127.0.0.1\n";
  const std::string key = " -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes ";
  const std::string steps[] = {
      "openssl req -x509" + key + "-keyout " + p("ca.key") + " -out " + p("ca.crt") + " -days 2 -subj '/CN=gearwatch test CA'",
      "openssl req" + key + "-keyout " + p("server.key") + " -out " + p("server.csr") + " -subj '/CN=127.0.0.1'",
      "openssl x509 -req -in " + p("server.csr") + " -CA " + p("ca.crt") + " -CAkey " + p("ca.key") + " -CAcreateserial -out " +
          p("server.crt") + " -days 2 -extfile " + p("server.ext"),
      "openssl req" + key + "-keyout " + p("client.key") + " -out " + p("client.csr") + " -subj '/CN=gearwatch test client'",
      "openssl x509 -req -in " + p("client.csr") + " -CA " + p("ca.crt") + " -CAkey " + p("ca.key") + " -CAcreateserial -out " +
          p("client.crt") + " -days 2",
  };
  for (const auto& step : steps) {
    const auto r = run_command(step + " 2>&1", std::chrono::seconds(60));
    if (r.status != 0) throw std::runtime_error("openssl failed: " + step + ": " + r.out + r.err);
  }
  return {dir / "ca.crt", dir / "server.crt", dir / "server.key", dir / "client.crt", dir / "client.key"};
}

}  // namespace gearwatch::testing
