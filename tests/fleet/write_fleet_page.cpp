// The fleet page of the known fleet (fleet_page_fixture.hpp) for the browser test:
//   write_fleet_page GEARWATCH OUT_DIR
// starts a PostgreSQL server in a temporary directory (Debian's binaries), writes the known fleet
// through the fleet store, runs `GEARWATCH fleet report --out OUT_DIR` and stops the server.
// Exit 77 when no PostgreSQL server binaries are installed.
#include <cstdio>
#include <exception>

#include "fleet/fleet_page_fixture.hpp"
#include "fleet/postgres_server.hpp"
#include "temp_dir.hpp"

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: write_fleet_page GEARWATCH OUT_DIR\n");
    return 2;
  }
  using namespace gearwatch::testing;
  const auto bin = postgres_bin_dir();
  if (!bin) {
    std::fprintf(stderr, "write_fleet_page: no PostgreSQL server binaries under /usr/lib/postgresql/*/bin\n");
    return 77;
  }
  try {
    TempDir dir{"fleet-page"};
    PostgresServer pg(dir.path() / "pg", *bin);
    pg.start();
    pg.create_database("fleet");
    {
      gearwatch::storage::fleet::FleetStore store(pg.uri("fleet"));
      store.migrate();
      write_known_fleet(store);
    }
    const auto r = run_command(std::string(argv[1]) + " fleet report --database " + pg.uri("fleet") + " --out " + argv[2]);
    std::fputs(r.out.c_str(), stdout);
    std::fputs(r.err.c_str(), stderr);
    return r.status;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "write_fleet_page: %s\n", e.what());
    return 1;
  }
}
