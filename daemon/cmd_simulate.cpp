#include "commands.hpp"

namespace gearwatch::cli {

void register_simulate(CLI::App& app) { (void)app; }

}  // namespace gearwatch::cli
