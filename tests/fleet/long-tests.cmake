# Read by CTest after the fleet tests are discovered (tests/CMakeLists.txt): the one fleet test that
# runs the daemon's model and gap step gets a COST, so CTest starts it early instead of last (see
# tests/long-tests.cmake for why the order matters).
set_tests_properties("fleet: a daemon's own model runs land in fleet.model_states as in its model_runs and the page shows the newest forecast"
                     PROPERTIES COST 60)
