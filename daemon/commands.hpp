#pragma once
// Subcommand registration. Each subcommand lives in its own cmd_<name>.cpp and adds itself
// to the application here; main.cpp only calls these in order.
#include <stdexcept>
#include <string>

// CLI11 is one of the costliest headers to compile (its validators are objects built in every file
// that includes it), so this header names CLI::App only: the files that build or run subcommands
// include <CLI/CLI.hpp> (cli_common.hpp does), the ones that only need CommandError do not.
namespace CLI {
class App;
}  // namespace CLI

namespace gearwatch::cli {

/// Thrown by a subcommand to end with a one-line reason and a non-zero exit status.
struct CommandError : std::runtime_error {
  explicit CommandError(const std::string& what, int status = 1) : std::runtime_error(what), exit_status(status) {}
  int exit_status;
};

void register_run(CLI::App& app);
void register_replay(CLI::App& app);
void register_simulate(CLI::App& app);
/// `import`: a DAQ recording (WAV, CSV, .mat) as a capture (cmd_import.cpp).
void register_import(CLI::App& app);
void register_query(CLI::App& app);
void register_inspect(CLI::App& app);
void register_twin(CLI::App& app);
/// `twin wear`, added to the `twin` subcommand by register_twin (cmd_twin_wear.cpp).
void register_twin_wear(CLI::App* twin);
void register_report(CLI::App& app);
/// `twin state` (cmd_twin_state.cpp).
void register_twin_state(CLI::App* twin);
/// The `gap` subcommand, created on first use: each `gap` child registers itself through it, in any order.
CLI::App* gap_command(CLI::App& app);
/// `gap report` (cmd_gap.cpp).
void add_gap_report_command(CLI::App& app);
/// `gap diagnose`: the diagnosis on captures a user brings (cmd_gap_diagnose.cpp).
void add_gap_diagnose_command(CLI::App& app);
/// `gap bench`, the withheld-effect check (cmd_gap_bench.cpp).
void add_gap_bench_command(CLI::App& app);
/// `gap` and all its subcommands.
void register_gap(CLI::App& app);
/// The `bench` subcommand, created on first use: each `bench` child registers itself through it.
CLI::App* bench_command(CLI::App& app);
/// `bench prognosis` (cmd_bench_prognosis.cpp).
void add_bench_prognosis_command(CLI::App& app);
/// `bench` and all its subcommands.
void register_bench(CLI::App& app);
void register_commission(CLI::App& app);
/// `publish`: the MQTT sender in a unit of its own (cmd_publish.cpp, docs/mqtt.md).
void register_publish(CLI::App& app);
/// `fleet ingest`: the fleet consumer, MQTT into PostgreSQL (cmd_fleet.cpp, docs/fleet.md).
void register_fleet(CLI::App& app);

}  // namespace gearwatch::cli
