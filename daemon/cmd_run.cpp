#include "commands.hpp"

namespace gearwatch::cli {

void register_run(CLI::App& app) { (void)app; }

}  // namespace gearwatch::cli
