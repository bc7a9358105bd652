#!/bin/busybox sh
# PID 1 of the vcan test VM (copied to /init of the initramfs by vcan-vm.sh).
# Loads the CAN modules, creates vcan0 and vcan1 (CAN FD: mtu 72), runs the script named in
# /etc/vcan-vm-script and prints its exit status as "VCAN-VM-EXIT <rc>" for the host.
/bin/busybox --install -s /bin
export PATH=/bin:/sbin:/usr/bin:/usr/sbin
mount -t proc proc /proc
mount -t sysfs sys /sys
mount -t devtmpfs dev /dev
mount -t tmpfs tmp /tmp
ip link set lo up
for m in can can-raw can-dev vcan; do
  insmod /lib/can/$m.ko || echo "vcan-vm: insmod $m failed"
done
for i in vcan0 vcan1; do
  ip link add dev $i type vcan && ip link set $i mtu 72 && ip link set $i up ||
    echo "vcan-vm: could not create $i"
done
script=$(cat /etc/vcan-vm-script)
cd /payload
/bin/sh "$script"
echo "VCAN-VM-EXIT $?"
sync
poweroff -f
