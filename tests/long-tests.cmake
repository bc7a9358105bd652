# Read by CTest after the discovered Catch2 tests (tests/CMakeLists.txt): the longest tests get a
# COST, so CTest starts them first. A fresh clone has no timing history, every cost is 0 and tests
# start in file order; a long test drawn last then runs alone while the other core idles. The
# values only order the tests (longest first, roughly in proportion to their run time): a renamed
# test simply loses its place.
function(gearwatch_long_test cost name)
  set_tests_properties("${name}" PROPERTIES COST ${cost})
endfunction()
foreach(name
    "periodic gap step: six records replayed one per process give the same stored report as the same six in one replay"
    "gap: gap bench with a few seeds writes the scores as JSON"
    "gap independent: the bench on a no-effect draw, a narrow resonance and a ghost tone"
    "daemon's gap diagnosis end to end: rig tooth errors withheld from the twin are found, stored and raise twin drift"
    "rig end to end: K_wear follows the truth's coefficient and the predicted wear depth stays within 5 %"
    "gap: eccentricity fitted on the rig's records recovers the run-outs the rig was given, across speeds"
    "gap: candidates fitted by re-running the twin are named, with their values, and close the gap"
    "gap: each parametric candidate fitted on data made with its own form recovers its parameters")
  # TIMEOUT: the longest of them runs 5 rig scenarios with twin re-runs; on a loaded 2-core
  # machine that comes close to the 600 s every other Catch2 test gets.
  set_tests_properties("${name}" PROPERTIES TIMEOUT 900)
endforeach()
gearwatch_long_test(50 "periodic gap step: six records replayed one per process give the same stored report as the same six in one replay")
gearwatch_long_test(230 "gap: gap bench with a few seeds writes the scores as JSON")
gearwatch_long_test(75 "gap: eccentricity fitted on the rig's records recovers the run-outs the rig was given, across speeds")
gearwatch_long_test(34 "defects #1: kill -9 while the model lags the committed records, then resume: the model's history equals the uninterrupted one")
gearwatch_long_test(45 "gap: candidates fitted by re-running the twin are named, with their values, and close the gap")
gearwatch_long_test(65 "daemon's gap diagnosis end to end: rig tooth errors withheld from the twin are found, stored and raise twin drift")
gearwatch_long_test(85 "daemon's gap diagnosis end to end: the rig without effects gives a report with no significant family and no alert")
gearwatch_long_test(55 "rig end to end: defects #7: a dry campaign is identified as abrasive wear on both channels and never pitting")
gearwatch_long_test(20 "gap: each parametric candidate fitted on data made with its own form recovers its parameters")
gearwatch_long_test(40 "gap: gap bench's scenario 21 (casing at 151 and 396 Hz, 67 kg): its casing candidate recovers all four values")
gearwatch_long_test(40 "rig end to end: K_wear follows the truth's coefficient and the predicted wear depth stays within 5 %")
gearwatch_long_test(60 "gap independent: the bench on a no-effect draw, a narrow resonance and a ghost tone")
gearwatch_long_test(35 "prognosis bench: two campaigns through the binary, scores recomputed from the trace")
gearwatch_long_test(23 "model thread: a campaign replayed one file per process ends in the state of one long replay")
gearwatch_long_test(35 "prognosis #3: a saturated ICS2 in the correlation triple leaves K_pitting as the inspections set it")
# The daemon's end-to-end gap diagnoses allocate and free large buffers again and again on the
# model thread (its describer reduces a unit tone like a measured record per trial). glibc serves
# them by mmap or trims them off the top of the thread's arena when freed, so their pages are
# faulted in and zeroed afresh each time. A fixed mmap threshold (glibc's ceiling) and a trim
# threshold above the tests' peak keep the freed memory for the next allocation; the arithmetic,
# and so every value the tests read, is the same (docs/ci.md). The gap bench test's `gearwatch gap
# bench` (a child process: it inherits the variable) and the eccentricity fit across speeds (twin
# re-runs in the test's own process) fault their large buffers in afresh alike.
foreach(name
    "daemon's gap diagnosis end to end: the rig without effects gives a report with no significant family and no alert"
    "daemon's gap diagnosis end to end: rig tooth errors withheld from the twin are found, stored and raise twin drift"
    "gap: gap bench with a few seeds writes the scores as JSON"
    "gap: eccentricity fitted on the rig's records recovers the run-outs the rig was given, across speeds")
  set_tests_properties("${name}" PROPERTIES ENVIRONMENT
                       "GLIBC_TUNABLES=glibc.malloc.mmap_threshold=33554432:glibc.malloc.trim_threshold=1073741824")
endforeach()
