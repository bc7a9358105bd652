#!/bin/busybox sh
# PID 1 of the vcan test VM (copied to /init of the initramfs by vcan-vm.sh).
# Loads the CAN modules, creates vcan0 and vcan1 (CAN FD: mtu 72), runs the script named in
# /etc/vcan-vm-script and prints its exit status as "VCAN-VM-EXIT <rc>" for the host.
# If a module does not load or an interface cannot be created, the script is not run and the VM
# reports VCAN-VM-EXIT 126.
/bin/busybox --install -s /bin
export PATH=/bin:/sbin:/usr/bin:/usr/sbin
mount -t proc proc /proc
mount -t sysfs sys /sys
mount -t devtmpfs dev /dev
mount -t tmpfs tmp /tmp
ip link set lo up
# The tests need these interfaces: a VM that cannot make them reports a failure to the host
# (VCAN-VM-EXIT 126) instead of running the tests against a kernel without vcan.
setup_failed() {
  echo "vcan-vm: FAIL: $*"
  echo "VCAN-VM-EXIT 126"
  sync
  poweroff -f
  exit 126
}
for m in can can-raw can-dev vcan; do
  insmod /lib/can/$m.ko || setup_failed "insmod $m failed"
done
for i in vcan0 vcan1; do
  { ip link add dev $i type vcan && ip link set $i mtu 72 && ip link set $i up; } ||
    setup_failed "could not create $i (ip link add/set)"
done
script=$(cat /etc/vcan-vm-script)
cd /payload
/bin/sh "$script"
echo "VCAN-VM-EXIT $?"
sync
poweroff -f
