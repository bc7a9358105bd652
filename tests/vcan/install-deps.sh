#!/usr/bin/env bash
# install-deps.sh — installs what the vcan test VM needs, from Debian's packages, when missing:
# qemu-system-x86 (the emulator), busybox-static (the VM's userland), cpio (the initramfs),
# xz-utils (the kernel's compressed modules), can-utils (canplayer, replayed inside the VM) and
# sqlite3 (the end-to-end comparison, run inside the VM). Idempotent; needs root only when
# something is missing.
set -euo pipefail
missing=()
command -v qemu-system-x86_64 >/dev/null || missing+=(qemu-system-x86)
# the VM's /bin/busybox must be the static build: the initramfs has no C library of its own
dpkg -s busybox-static >/dev/null 2>&1 || missing+=(busybox-static)
command -v cpio >/dev/null || missing+=(cpio)
command -v xz >/dev/null || missing+=(xz-utils)
command -v canplayer >/dev/null || missing+=(can-utils)
command -v sqlite3 >/dev/null || missing+=(sqlite3)
[ ${#missing[@]} -eq 0 ] && exit 0
if [ "$(id -u)" -ne 0 ]; then
  echo "vcan-vm: missing Debian packages: ${missing[*]} (run as root: apt-get install ${missing[*]})" >&2
  exit 2
fi
echo "vcan-vm: installing ${missing[*]}" >&2
apt-get update -qq
DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing[@]}" >/dev/null
