#!/usr/bin/env bash
# vcan-vm.sh — run a script against a real Linux vcan interface, also on a machine whose own
# kernel has no CAN support (no AF_CAN, no vcan module): it boots Debian's stock kernel under
# qemu's software emulation, loads can, can-raw, can-dev and vcan, creates vcan0 and vcan1
# (CAN FD capable, mtu 72) and runs the given script inside with /bin/sh.
#
# Usage: tests/vcan/vcan-vm.sh PAYLOAD_DIR SCRIPT [TIMEOUT_S]
#   PAYLOAD_DIR  copied to /payload inside the VM (binaries, data, scripts). The shared
#                libraries of every executable in it are copied in too, at their host paths.
#   SCRIPT       path INSIDE the VM of the script to run, e.g. /payload/inside.sh
#   TIMEOUT_S    wall-clock limit for the whole VM run (default 240)
# The VM's console is this script's stdout. The inner script's exit status is printed by the
# VM as "VCAN-VM-EXIT <rc>" and returned; 126 means the VM could not load the CAN modules or
# create vcan0/vcan1 (the script did not run), 125 that the VM did not get that far.
#
# Environment:
#   GEARWATCH_VCAN_CACHE  where the kernel and its CAN modules are kept
#                         (default ${XDG_CACHE_HOME:-$HOME/.cache}/gearwatch-vcan)
#   GEARWATCH_VCAN_SMP    virtual CPUs (default 2)   GEARWATCH_VCAN_MEM  MiB (default 2048)
#   GEARWATCH_VCAN_CPU    qemu CPU model (default max: with AVX2, FFTW runs ~2x faster under
#                         emulation than with an SSE4-only model such as Nehalem)
#
# Needs the Debian packages qemu-system-x86, busybox-static, cpio and xz-utils; they are
# installed with apt-get when missing (as root). The kernel package is fetched with
# `apt-get download` (not installed) and unpacked into the cache once (fetch-kernel.sh).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
payload=${1:?usage: vcan-vm.sh PAYLOAD_DIR SCRIPT [TIMEOUT_S]}
script=${2:?usage: vcan-vm.sh PAYLOAD_DIR SCRIPT [TIMEOUT_S]}
limit=${3:-240}
cache=${GEARWATCH_VCAN_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/gearwatch-vcan}
[ -d "$payload" ] || { echo "vcan-vm: payload folder '$payload' does not exist" >&2; exit 2; }

"$here/install-deps.sh"

# 1. Debian's kernel and its CAN modules, unpacked once.
"$here/fetch-kernel.sh" "$cache"

# 2. initramfs: busybox, the modules, the payload and its libraries, and the init script.
work=$(mktemp -d)
out=$(mktemp)
trap 'rm -rf "$work" "$work.cpio" "$out"' EXIT
mkdir -p "$work"/{bin,sbin,proc,sys,dev,tmp,etc,lib/can}
cp /bin/busybox "$work/bin/"
cp "$cache"/mods/*.ko "$work/lib/can/"
cp -a "$payload" "$work/payload"
find "$work/payload" -type f -perm -u+x | while read -r f; do
  for lib in $(ldd "$f" 2>/dev/null | grep -o '/[^ ]*' || true); do
    [ -e "$work$lib" ] || { mkdir -p "$work$(dirname "$lib")"; cp -L "$lib" "$work$lib"; }
  done
done
cp "$here/vm-init.sh" "$work/init"
chmod +x "$work/init"
printf '%s\n' "$script" >"$work/etc/vcan-vm-script"
# Not compressed: the emulated kernel inflated it more slowly than it copies the plain archive.
(cd "$work" && find . | cpio -o -H newc 2>/dev/null >"$work.cpio")

# 3. Boot. Software emulation (TCG): it needs no KVM and behaves the same on any x86-64 host.
# no_timer_check: on a busy host the emulated clock can miss the kernel's check of the IO-APIC
# timer, which then panics at boot (as systemd-vm.sh).
# -nic none: the tests use vcan and loopback only; no network card (its option ROM, its driver).
timeout "$limit" qemu-system-x86_64 -accel tcg -cpu "${GEARWATCH_VCAN_CPU:-max}" -smp "${GEARWATCH_VCAN_SMP:-2}" -nic none \
  -m "${GEARWATCH_VCAN_MEM:-2048}" -kernel "$cache/vmlinuz" -initrd "$work.cpio" \
  -append "console=ttyS0 quiet panic=-1 no_timer_check" -nographic -no-reboot -display none </dev/null |
  tee "$out" || true
rc=$(sed -n 's/.*VCAN-VM-EXIT \([0-9][0-9]*\).*/\1/p' "$out" | tail -1)
[ -n "$rc" ] || { echo "vcan-vm: the VM did not finish the script within ${limit}s" >&2; exit 125; }
exit "$rc"
