#!/usr/bin/env bash
# fetch-kernel.sh — makes sure CACHE_DIR holds Debian's stock kernel (CACHE_DIR/vmlinuz) and its
# CAN modules, decompressed (CACHE_DIR/mods/{can,can-raw,can-dev,vcan}.ko). The kernel package is
# fetched with `apt-get download` (not installed) and unpacked once per cache. Both test VMs use
# it: the vcan VM (vcan-vm.sh) and the systemd VM (tests/systemd/systemd-vm.sh).
#
# Usage: tests/vcan/fetch-kernel.sh CACHE_DIR
set -euo pipefail
cache=${1:?usage: fetch-kernel.sh CACHE_DIR}
mkdir -p "$cache"
[ -f "$cache/vmlinuz" ] && [ -f "$cache/mods/vcan.ko" ] && exit 0

pkg=$(apt-cache depends linux-image-amd64 2>/dev/null |
      sed -n 's/.*Depends: \(linux-image-[0-9][^ ]*\).*/\1/p' | head -1)
if [ -z "$pkg" ]; then
  apt-get update -qq
  pkg=$(apt-cache depends linux-image-amd64 | sed -n 's/.*Depends: \(linux-image-[0-9][^ ]*\).*/\1/p' | head -1)
fi
[ -n "$pkg" ] || { echo "fetch-kernel: cannot find Debian's kernel package (apt-cache depends linux-image-amd64)" >&2; exit 2; }
echo "fetch-kernel: fetching $pkg into $cache" >&2
rm -rf "$cache/root" "$cache/mods" "$cache/vmlinuz"
(cd "$cache" && apt-get download "$pkg" >/dev/null && dpkg-deb -x "$pkg"_*.deb root && rm -f "$pkg"_*.deb)
cp "$cache"/root/boot/vmlinuz-* "$cache/vmlinuz.tmp"
mkdir -p "$cache/mods"
for m in net/can/can.ko net/can/can-raw.ko drivers/net/can/dev/can-dev.ko drivers/net/can/vcan.ko; do
  f=$(ls "$cache"/root/lib/modules/*/kernel/$m* 2>/dev/null | head -1)
  [ -n "$f" ] || { echo "fetch-kernel: the kernel package has no $m" >&2; exit 2; }
  case $f in
    *.xz) xz -dc "$f" >"$cache/mods/$(basename "${f%.xz}")" ;;
    *) cp "$f" "$cache/mods/" ;;
  esac
done
rm -rf "$cache/root"
mv "$cache/vmlinuz.tmp" "$cache/vmlinuz"   # last: its presence marks a complete cache
