#include "commands.hpp"

namespace gearwatch::cli {

void register_query(CLI::App& app) { (void)app; }

}  // namespace gearwatch::cli
