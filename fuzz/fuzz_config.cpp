// libFuzzer target: the configuration parser (config::parse_config). Any text either gives a
// configuration or throws ConfigError whose message starts with the file's name, as the daemon
// prints it ("NAME:LINE: key 'a.b': reason"); anything else — another exception, a crash, an
// undefined operation — is a finding.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "gearwatch/config/config.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const auto config = gearwatch::config::parse_config(text, "fuzz.toml");
    if (config.rig.channels.empty() || config.rig.tachos.empty()) {
      std::fprintf(stderr, "fuzz_config: a configuration without channels or tachos was accepted\n");
      std::abort();
    }
  } catch (const gearwatch::config::ConfigError& e) {
    if (std::string(e.what()).rfind("fuzz.toml", 0) != 0) {
      std::fprintf(stderr, "fuzz_config: an error that does not name the file: %s\n", e.what());
      std::abort();
    }
  }
  return 0;
}
