#!/usr/bin/env bash
# install-deps.sh — installs gearwatch's build and test dependencies from Debian's packages
# when they are missing. Idempotent; needs root (or sudo) only when something is missing.
#   tools/install-deps.sh          build dependencies
#   tools/install-deps.sh --package  plus what tools/package.sh needs (dpkg-shlibdeps, file)
#   tools/install-deps.sh --test-build  build dependencies plus what configuring the tests needs
#   tools/install-deps.sh --test   plus what the tests need (the vcan VM: qemu, busybox, can-utils;
#                                  python3 with numpy for the capture generator tests/capture_gen,
#                                  scipy and h5py for the import test's independent .mat writers;
#                                  headless chromium and a font for the report's browser test;
#                                  the MQTT tests' broker: mosquitto (mosquitto_passwd), and openssl
#                                  for the test CA of the TLS tests;
#                                  the fleet tests' database server: postgresql (initdb, pg_ctl);
#                                  the systemd VM's root: debootstrap, and the .deb it installs;
#                                  the fuzzers: clang-14, libFuzzer and its sanitizer runtimes)
set -euo pipefail
packages=(build-essential cmake ninja-build pkg-config git ca-certificates
          libeigen3-dev libboost-dev libfftw3-dev libsqlite3-dev sqlite3 libspdlog-dev libfmt-dev
          libsystemd-dev libsndfile1-dev libmatio-dev libcli11-dev libtomlplusplus-dev nlohmann-json3-dev catch2
          libmosquitto-dev libpqxx-dev)
package_tools=(dpkg-dev file)
# What configuring the tests needs (tests/CMakeLists.txt looks for python3 with numpy); the rest of
# --test is only needed when the tests run, so tools/test.sh installs it while the build runs.
test_configure=(python3 python3-numpy)
[ "${1:-}" = "--package" ] && packages+=("${package_tools[@]}")
[ "${1:-}" = "--test-build" ] && packages+=("${test_configure[@]}")
[ "${1:-}" = "--test" ] && packages+=("${test_configure[@]}" can-utils qemu-system-x86 busybox-static cpio xz-utils python3-scipy python3-h5py
                                      chromium fonts-dejavu-core mosquitto mosquitto-clients openssl postgresql
                                      debootstrap "${package_tools[@]}" clang-14 libfuzzer-14-dev libclang-rt-14-dev)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0
sudo=""
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "install-deps: missing packages: ${missing[*]} (run as root)" >&2; exit 2; }
  sudo=sudo
fi
echo "install-deps: installing ${missing[*]}" >&2
$sudo apt-get update -qq
DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
