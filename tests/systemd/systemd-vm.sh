#!/usr/bin/env bash
# systemd-vm.sh — boots a Debian bookworm root with systemd as PID 1 under qemu (software
# emulation, no KVM needed), with real vcan0/vcan1 (CAN FD, mtu 72), installs Debian packages
# into it and runs a script there as a systemd unit: for testing gearwatch the way a plant runs
# it (the .deb, Type=notify, the watchdog, DynamicUser, every hardening option of the unit).
# It works on machines whose own kernel has no CAN and that run no systemd.
#
# Usage: tests/systemd/systemd-vm.sh PAYLOAD_DIR [TIMEOUT_S]
#        tests/systemd/systemd-vm.sh --prepare   only fetch the kernel and cache the base root (steps
#                                                1-2, no boot): tools/test.sh runs it while it builds
#   PAYLOAD_DIR/inside.sh   run inside with bash, as root, by a oneshot unit once multi-user.target
#                           is reached; its output goes to the console (this script's stdout); its
#                           exit status is printed as "SYSTEMD-VM-EXIT <rc>" and returned
#   PAYLOAD_DIR/debs/*.deb  installed into the root with apt-get before the boot; their
#                           dependencies come from the cached root (see below)
#   everything else         at /payload inside
#   TIMEOUT_S               wall-clock limit of the VM run (default 600); 125 = no exit status
#
# Caching (GEARWATCH_SYSTEMD_CACHE, default ${XDG_CACHE_HOME:-$HOME/.cache}/gearwatch-systemd):
#   base-<key>.tar   debootstrap of bookworm (minbase + systemd, iproute2, can-utils, sqlite3, ...)
#                    and the VM's own units; <key> is a hash of step 2 of this script, so editing it rebuilds
#                    (~1-2 min, needs a Debian mirror: GEARWATCH_DEBIAN_MIRROR, default
#                    http://deb.debian.org/debian)
#   deps-<key>.tar   base + the packages' Depends, installed with apt-get; <key> adds the Depends
#                    fields, so a package with new dependencies gets a new root. Each run then
#                    installs the packages with apt-get on a copy: their dependencies are there
#                    already, so nothing is downloaded.
# The kernel and its CAN modules are the vcan VM's (tests/vcan/fetch-kernel.sh, same cache).
#
# Environment: GEARWATCH_SYSTEMD_SMP (virtual CPUs, default 2), GEARWATCH_SYSTEMD_MEM (MiB,
# default 2048: the whole root lives in RAM), GEARWATCH_VCAN_CACHE (the kernel's cache).
# Needs root (debootstrap, chroot) and the Debian packages debootstrap, qemu-system-x86 and cpio
# (tools/install-deps.sh --test).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
prepare_only=0
if [ "${1:-}" = "--prepare" ]; then
  prepare_only=1
else
  payload=$(cd "${1:?usage: systemd-vm.sh PAYLOAD_DIR [TIMEOUT_S] | --prepare}" && pwd)
  [ -f "$payload/inside.sh" ] || { echo "systemd-vm: $payload/inside.sh does not exist" >&2; exit 2; }
fi
limit=${2:-600}
cache=${GEARWATCH_SYSTEMD_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/gearwatch-systemd}
kernel_cache=${GEARWATCH_VCAN_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/gearwatch-vcan}
mirror=${GEARWATCH_DEBIAN_MIRROR:-http://deb.debian.org/debian}
[ "$(id -u)" -eq 0 ] || { echo "systemd-vm: needs root (debootstrap, chroot)" >&2; exit 2; }
for tool in debootstrap qemu-system-x86_64 cpio; do
  command -v "$tool" >/dev/null ||
    { echo "systemd-vm: $tool is missing (tools/install-deps.sh --test installs it)" >&2; exit 2; }
done
mkdir -p "$cache"
log() { echo "systemd-vm [+$(( $(date +%s) - t_begin )) s] $*" >&2; }
t_begin=$(date +%s)

# 1. Debian's kernel and its CAN modules (shared with the vcan VM)
"$here/../vcan/fetch-kernel.sh" "$kernel_cache"

# 2. the base root, cached
base_key=$(sed -n '/^# 2\. the base root/,/^# 3\. /p' "$0" | sha256sum | cut -c1-16)
base=$cache/base-$base_key.tar
if [ ! -f "$base" ]; then
  log "building the base root (debootstrap bookworm from $mirror)"
  rm -f "$cache"/base-*.tar "$cache"/deps-*.tar
  r=$(mktemp -d "$cache/root.XXXXXX")
  chmod 755 "$r"   # it becomes /: a DynamicUser service must be able to enter it
  debootstrap --variant=minbase \
    --include=systemd,systemd-sysv,iproute2,can-utils,kmod,sqlite3,procps \
    bookworm "$r" "$mirror" >"$cache/debootstrap.log" 2>&1 ||
    { tail -n 20 "$cache/debootstrap.log" >&2; rm -rf "$r"; echo "systemd-vm: debootstrap failed" >&2; exit 2; }
  # The CAN modules are loaded by path (insmod): no depmod, no kernel-version directory.
  cat >"$r/etc/systemd/system/vcan.service" <<'UNIT'
[Unit]
Description=CAN modules, vcan0 and vcan1 (CAN FD)
DefaultDependencies=no
After=local-fs.target
Before=network.target
[Service]
Type=oneshot
RemainAfterExit=yes
ExecStart=/bin/sh -c 'for m in can can-raw can-dev vcan; do insmod /usr/lib/systemd-vm/can/$m.ko || exit 1; done; for i in vcan0 vcan1; do ip link add dev $i type vcan && ip link set $i mtu 72 && ip link set up $i || exit 1; done'
[Install]
WantedBy=multi-user.target
UNIT
  # Powered off with --force (units not stopped one by one): once the exit status is on the
  # console nothing in the VM needs an orderly stop (its root lives in RAM and is thrown away).
  cat >"$r/etc/systemd/system/vmtest.service" <<'UNIT'
[Unit]
Description=the payload's inside.sh, then power off
After=multi-user.target vcan.service
[Service]
Type=oneshot
StandardOutput=tty
StandardError=tty
TTYPath=/dev/ttyS0
ExecStart=/bin/sh -c '/bin/bash /payload/inside.sh; echo "SYSTEMD-VM-EXIT $?"; systemctl --no-block --force poweroff'
[Install]
WantedBy=multi-user.target
UNIT
  chroot "$r" systemctl enable vcan.service vmtest.service >/dev/null 2>&1
  # No udev in this root (nothing to trigger), no D-Bus (systemctl and systemd-analyze talk to
  # systemd over its private socket as root), no logins, no timers: each would only cost boot time.
  # Nor consoles for logins (getty-static starts five without logind), utmp records, modules loaded
  # on demand (the CAN modules are vcan.service's; nothing else loads any) or binfmt: under
  # emulation each unit's fork and exec costs a noticeable part of a second before the test starts.
  chroot "$r" systemctl mask systemd-udevd.service systemd-udev-trigger.service systemd-udev-settle.service \
    systemd-logind.service getty@tty1.service serial-getty@ttyS0.service apt-daily.timer \
    apt-daily-upgrade.timer dpkg-db-backup.timer e2scrub_all.timer e2scrub_reap.service fstrim.timer \
    getty-static.service systemd-update-utmp.service systemd-update-utmp-runlevel.service \
    systemd-user-sessions.service modprobe@.service proc-sys-fs-binfmt_misc.automount >/dev/null 2>&1
  # No generators: the root has no fstab, no encrypted or GPT-discovered volumes, no SysV scripts,
  # no kernel command-line units; systemd runs each of them (a process apiece) before loading units.
  mkdir -p "$r/etc/systemd/system-generators"
  for g in "$r"/lib/systemd/system-generators/*; do ln -sf /dev/null "$r/etc/systemd/system-generators/${g##*/}"; done
  echo vm >"$r/etc/hostname"
  rm -rf "$r"/usr/share/doc/* "$r"/usr/share/man/* "$r"/usr/share/locale/* "$r"/var/cache/apt/archives/*.deb
  tar -C "$r" -cf "$base.tmp" . && mv "$base.tmp" "$base"
  rm -rf "$r"
  log "base root cached: $(du -h "$base" | cut -f1)"
fi

# 3. the base plus the packages' dependencies, cached per Depends
# (--prepare stops before it: it needs the package's Depends, so a built gearwatch)
[ "$prepare_only" = 1 ] && { log "kernel and base root cached"; exit 0; }
debs=()
[ -d "$payload/debs" ] && for d in "$payload"/debs/*.deb; do [ -f "$d" ] && debs+=("$d"); done
depends=""
for d in "${debs[@]}"; do depends+="$(dpkg-deb -f "$d" Depends),"; done
deps_key=$(printf '%s\n%s\n' "$base_key" "$depends" | sha256sum | cut -c1-16)
rootball=$cache/deps-$deps_key.tar
if [ ! -f "$rootball" ]; then
  # the first alternative of each dependency, without its version constraint
  names=$(printf '%s' "$depends" | tr ',' '\n' | sed 's/|.*//; s/(.*)//; s/[[:space:]]//g' | sed '/^$/d' | sort -u | tr '\n' ' ')
  log "installing the packages' dependencies into a copy of the base root: $names"
  rm -f "$cache"/deps-*.tar
  r=$(mktemp -d "$cache/root.XXXXXX")
  chmod 755 "$r"
  tar -C "$r" -xf "$base"
  cp /etc/resolv.conf "$r/etc/resolv.conf" 2>/dev/null || true
  # shellcheck disable=SC2086
  chroot "$r" /bin/sh -c "apt-get -o APT::Sandbox::User=root update -qq && DEBIAN_FRONTEND=noninteractive \
    apt-get -o APT::Sandbox::User=root install -y -qq --no-install-recommends $names && apt-get clean" \
    >"$cache/deps.log" 2>&1 ||
    { tail -n 20 "$cache/deps.log" >&2; rm -rf "$r"; echo "systemd-vm: could not install the dependencies $names" >&2; exit 2; }
  # Without apt's package lists (half of this root): installing the packages into it (step 4) needs
  # only dpkg's status, their dependencies being installed.
  rm -rf "$r"/usr/share/doc/* "$r"/usr/share/man/* "$r"/var/lib/apt/lists/*
  mkdir -p "$r/var/lib/apt/lists/partial"
  tar -C "$r" -cf "$rootball.tmp" . && mv "$rootball.tmp" "$rootball"
  rm -rf "$r"
fi

# 4. this run's root: the cached root + the packages (offline) + the CAN modules + the payload
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkdir -p "$work/root"
tar -C "$work/root" -xf "$rootball"
chmod 755 "$work/root"
# apt's package lists and caches (a root cached before step 3 dropped them) are not needed to
# install packages whose dependencies are there, nor in the VM: without them the initramfs the
# emulated kernel unpacks is half the size.
rm -rf "$work/root"/var/lib/apt/lists/* && mkdir -p "$work/root/var/lib/apt/lists/partial"
if [ ${#debs[@]} -gt 0 ]; then
  mkdir -p "$work/root/tmp/debs" && cp "${debs[@]}" "$work/root/tmp/debs/"
  chroot "$work/root" /bin/sh -c 'DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends /tmp/debs/*.deb' \
    >"$work/apt.log" 2>&1 || { cat "$work/apt.log" >&2; echo "systemd-vm: apt-get could not install the packages" >&2; exit 2; }
  rm -rf "$work/root/tmp/debs" "$work/root"/var/cache/apt/*.bin
  log "installed with apt-get: $(cd "$payload/debs" && ls -- *.deb | tr '\n' ' ')"
fi
mkdir -p "$work/root/usr/lib/systemd-vm/can" && cp "$kernel_cache"/mods/*.ko "$work/root/usr/lib/systemd-vm/can/"
mkdir -p "$work/root/payload" && cp -a "$payload/." "$work/root/payload/" && rm -rf "$work/root/payload/debs"
(cd "$work/root" && find . | cpio -o -H newc 2>/dev/null >"$work/root.cpio")
rm -rf "$work/root"
log "root ready: $(du -h "$work/root.cpio" | cut -f1) initramfs; booting"

# 5. boot (software emulation; the root lives in RAM). no_timer_check: on a busy host the
# emulated clock can miss the kernel's check of the IO-APIC timer, which then panics at boot.
# -nic none: the tests use loopback and vcan only; no network card (its option ROM, its driver).
timeout "$limit" qemu-system-x86_64 -accel tcg -cpu max -smp "${GEARWATCH_SYSTEMD_SMP:-2}" -nic none \
  -m "${GEARWATCH_SYSTEMD_MEM:-2048}" -kernel "$kernel_cache/vmlinuz" -initrd "$work/root.cpio" \
  -append "console=ttyS0 rdinit=/sbin/init ${GEARWATCH_SYSTEMD_CMDLINE:-quiet systemd.show_status=false} panic=-1 no_timer_check" \
  -nographic -no-reboot -display none </dev/null | tee "$work/console.log" || true
rc=$(sed -n 's/.*SYSTEMD-VM-EXIT \([0-9][0-9]*\).*/\1/p' "$work/console.log" | tail -1)
log "VM done"
[ -n "$rc" ] || { echo "systemd-vm: the VM did not finish the script within ${limit} s" >&2; exit 125; }
exit "$rc"
