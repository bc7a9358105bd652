#!/usr/bin/env bash
# package.sh — builds gearwatch (Release) and its Debian package into build/:
# build/gearwatch_<version>_<arch>.deb (CPack's DEB generator; Depends from dpkg-shlibdeps).
# Lists the package's contents and control fields. docs/packaging.md says what goes where.
#   tools/package.sh             build dir build/
#   GEARWATCH_BUILD_DIR=dir tools/package.sh
set -euo pipefail
top=$(cd "$(dirname "$0")/.." && pwd)
cd "$top"
build=${GEARWATCH_BUILD_DIR:-build}
tools/install-deps.sh --package
# The package installs into /usr (also when this build dir was configured for another prefix).
if [ -f "$build/CMakeCache.txt" ]; then
  cmake -S . -B "$build" -DCMAKE_INSTALL_PREFIX=/usr >/dev/null
else
  cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_INSTALL_PREFIX=/usr >/dev/null
fi
cmake --build "$build" --target gearwatch --parallel "$(nproc)"
(cd "$build" && cpack -G DEB --config CPackConfig.cmake >/dev/null)
deb=$(ls -t "$build"/gearwatch_*.deb | head -1)
dpkg-deb -f "$deb" Package Version Architecture Depends
dpkg-deb -c "$deb"
echo "package: $deb"
