#include "logging.hpp"

#include <cstdlib>

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <spdlog/sinks/systemd_sink.h>

namespace gearwatch::logging {

void setup(Sink sink, const std::string& level) {
  std::shared_ptr<spdlog::logger> logger;
  if (sink == Sink::journald) {
    logger = std::make_shared<spdlog::logger>("gearwatch", std::make_shared<spdlog::sinks::systemd_sink_mt>("gearwatch"));
  } else {
    logger = std::make_shared<spdlog::logger>("gearwatch", std::make_shared<spdlog::sinks::stderr_color_sink_mt>());
    logger->set_pattern("%Y-%m-%dT%H:%M:%S.%e %^%l%$ %v");
  }
  logger->set_level(spdlog::level::from_str(level));
  logger->flush_on(spdlog::level::warn);
  spdlog::set_default_logger(logger);
}

void setup(Sink sink, config::LogLevel level) { setup(sink, std::string(config::to_string(level))); }

config::LogLevel summary_command_level(config::LogLevel configured) {
  return configured == config::LogLevel::info ? config::LogLevel::warn : configured;
}

bool running_under_journald() { return std::getenv("JOURNAL_STREAM") != nullptr; }

Sink service_sink(config::LogSink configured) {
  const bool journald = configured == config::LogSink::journald ||
                        (configured == config::LogSink::automatic && running_under_journald());
  return journald ? Sink::journald : Sink::stderr_only;
}

}  // namespace gearwatch::logging
