#include "commands.hpp"

namespace gearwatch::cli {

void register_replay(CLI::App& app) { (void)app; }

}  // namespace gearwatch::cli
