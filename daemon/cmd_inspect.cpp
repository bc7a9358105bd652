#include "commands.hpp"

namespace gearwatch::cli {

void register_inspect(CLI::App& app) { (void)app; }

}  // namespace gearwatch::cli
