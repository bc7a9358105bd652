#!/usr/bin/env python3
"""Replays a ctest -jN run on N slots from the per-test times in its log (tools/test.sh's output)
to predict the tests phase under other COST / RUN_SERIAL / RESOURCE_LOCK settings (docs/ci.md).

Usage: tools/ctest-schedule.py CI_LOG [--jobs 2] [--vm-lock | --vm-serial] [--vm-slowdown F] [--no-costs]
The COSTs, RUN_SERIAL and RESOURCE_LOCKs are read from tests/long-tests.cmake and
tests/CMakeLists.txt (--vm-lock / --vm-serial override them for the VM tests). The model: a free slot
takes the first ready test in decreasing COST (ties in test-number order), a RUN_SERIAL test waits
for an empty machine and runs alone, a test whose RESOURCE_LOCK is held is passed over, and the
fuzz runs wait for fuzz_build (their fixture). --no-costs replays the order a fresh clone would get
without the COSTs (every cost 0: test-number order)."""
import argparse
import pathlib
import re

ROOT = pathlib.Path(__file__).resolve().parent.parent
VM_TESTS = ("vcan_end_to_end_run_equals_replay", "systemd_service_from_deb", "vcan_socketcan_source")


def read_log(path):
    times, numbers = {}, {}
    for line in open(path, errors="replace"):
        m = re.match(r"\s*\d+/\d+ Test\s+#(\d+): (.*?) \.{3,}.*?(Passed|Failed|Timeout)\s+([\d.]+) sec", line)
        if m:
            times[m.group(2)] = float(m.group(4))
            numbers[m.group(2)] = int(m.group(1))
    return times, numbers


def read_costs():
    costs = {}
    long_tests = (ROOT / "tests/long-tests.cmake").read_text()
    for m in re.finditer(r'gearwatch_long_test\((\d+) "(.*?)"\)', long_tests):
        costs[m.group(2)] = int(m.group(1))
    lists = (ROOT / "tests/CMakeLists.txt").read_text()
    loops = {m.group(1): m.group(2).split() for m in re.finditer(r"foreach\((\w+) ([^)]*)\)", lists)}
    for m in re.finditer(r"set_tests_properties\(([^)]*?) PROPERTIES([^)]*?)COST (\d+)", lists):
        for name in m.group(1).split():
            var = re.fullmatch(r"\$\{(\w+)\}", name)
            for n in loops.get(var.group(1), []) if var else [name]:
                costs[n] = int(m.group(3))
    return costs


def read_serial_and_locks():
    """RUN_SERIAL tests and RESOURCE_LOCKs as tests/CMakeLists.txt sets them."""
    serial, locks = set(), {}
    lists = (ROOT / "tests/CMakeLists.txt").read_text()
    for m in re.finditer(r"set_tests_properties\(([^)]*?) PROPERTIES([^)]*)\)", lists):
        names = m.group(1).split()
        if re.search(r"RUN_SERIAL TRUE", m.group(2)):
            serial.update(names)
        lock = re.search(r"RESOURCE_LOCK (\S+)", m.group(2))
        if lock:
            locks.update({n: lock.group(1) for n in names})
    return serial, locks


def model(times, numbers, costs, jobs, serial, locks, slowdown, after):
    pending = sorted(times, key=lambda n: (-costs.get(n, 0), numbers[n]))
    running, done, t = [], set(), 0.0
    while pending or running:
        started = True
        while started and len(running) < jobs:
            started = False
            if any(n in serial for _, n in running):
                break
            held = {locks[n] for _, n in running if n in locks}
            for n in pending:
                if n in after and after[n] not in done:
                    continue
                if n in serial:
                    if running:
                        break  # waits for an empty machine; CTest holds the queue behind it
                elif n in locks and locks[n] in held:
                    continue
                running.append((t + times[n] * slowdown.get(n, 1.0), n))
                pending.remove(n)
                started = True
                break
        running.sort()
        t, n = running.pop(0)
        done.add(n)
    return t


def main():
    p = argparse.ArgumentParser()
    p.add_argument("log")
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--vm-lock", action="store_true", help="all VM tests under one RESOURCE_LOCK, none RUN_SERIAL")
    p.add_argument("--vm-serial", action="store_true", help="all VM tests RUN_SERIAL (as before the lock)")
    p.add_argument("--vm-slowdown", type=float, default=1.0, help="VM tests this much slower beside another test")
    p.add_argument("--vm-cost", type=int, nargs=3, default=[300, 260, 20], metavar=("E2E", "SYSTEMD", "UNITS"))
    p.add_argument("--no-costs", action="store_true", help="every COST 0, as a fresh clone without them")
    a = p.parse_args()
    times, numbers = read_log(a.log)
    costs = {} if a.no_costs else read_costs()
    after = {n: "fuzz_build" for n in times if n.startswith("fuzz_") and n != "fuzz_build"}
    vm = [n for n in VM_TESTS if n in times]
    serial, locks = read_serial_and_locks()
    if a.vm_lock:
        costs.update(dict(zip(VM_TESTS, a.vm_cost)))
        serial, locks = serial - set(vm), {**locks, **{n: "vm" for n in vm}}
    elif a.vm_serial:
        serial, locks = serial | set(vm), {n: l for n, l in locks.items() if n not in vm}
        costs = {n: c for n, c in costs.items() if n not in vm}
    slow = {n: a.vm_slowdown for n in vm if n not in serial}
    total = sum(times.values())
    print(f"{len(times)} tests, {total:.0f} s in all, longest {max(times.values()):.0f} s, "
          f"VM tests {sum(times[n] for n in vm):.0f} s")
    print(f"tests phase on {a.jobs} slots: {model(times, numbers, costs, a.jobs, serial, locks, slow, after):.0f} s "
          f"(RUN_SERIAL: {', '.join(sorted(n for n in serial if n in times)) or 'none'}; "
          f"work-bound floor {total / a.jobs:.0f} s)")


if __name__ == "__main__":
    main()
