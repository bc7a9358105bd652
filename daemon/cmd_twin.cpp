// `gearwatch twin ...`: the digital twin's commands (modes, simulate, state).
#include "commands.hpp"

namespace gearwatch::cli {

void register_twin(CLI::App& app) {
  auto* twin = app.add_subcommand("twin", "The digital twin: natural frequencies, simulation, state");
  twin->require_subcommand(1);
}

}  // namespace gearwatch::cli
