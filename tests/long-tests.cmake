# Read by CTest after the discovered Catch2 tests (tests/CMakeLists.txt): the longest tests get a
# COST, so CTest starts them first. A fresh clone has no timing history, every cost is 0 and tests
# start in file order; a long test drawn last then runs alone while the other core idles. The
# values only order the tests: a renamed test simply loses its place.
foreach(name
    "gap: gap bench with a few seeds writes the scores as JSON"
    "gap independent: the bench on a no-effect draw, a narrow resonance and a ghost tone"
    "daemon's gap diagnosis end to end: rig tooth errors withheld from the twin are found, stored and raise twin drift"
    "rig end to end: K_wear follows the truth's coefficient and the predicted wear depth stays within 5 %"
    "gap: eccentricity fitted on the rig's records recovers the run-outs the rig was given, across speeds"
    "gap: candidates fitted by re-running the twin are named, with their values, and close the gap"
    "gap: each parametric candidate fitted on data made with its own form recovers its parameters")
  # TIMEOUT: the longest of them runs 5 rig scenarios with twin re-runs; on a loaded 2-core
  # machine that comes close to the 600 s every other Catch2 test gets.
  set_tests_properties("${name}" PROPERTIES COST 100 TIMEOUT 900)
endforeach()
