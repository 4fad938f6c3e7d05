#!/bin/sh
# /init of the socketcan-vm initramfs (busybox ash, PID 1). run.sh copies this file in as /init and
# writes /etc/dgw-vm.conf (module load order, timeouts, library path) and /etc/dgw-tests
# (one test per line: NAME KIND COMMAND). The host reads the DGW-VM-* lines from the serial console.
export PATH=/bin
mount -t devtmpfs devtmpfs /dev 2>/dev/null
exec </dev/console >/dev/console 2>&1
mount -t proc proc /proc
mount -t sysfs sysfs /sys
mount -t tmpfs tmpfs /tmp
. /etc/dgw-vm.conf
export LD_LIBRARY_PATH

uptime_s() { cut -d' ' -f1 /proc/uptime; }

# Never returns: prints the result marker and powers off. If power-off fails, init exits, the kernel
# panics, and panic=-1 with qemu's -no-reboot ends the VM anyway.
finish() {
  echo "DGW-VM-RESULT passed=$1 failed=$2 uptime=$(uptime_s)"
  sync
  poweroff -f
  echo o >/proc/sysrq-trigger
  sleep 5
  exit 1
}

echo "DGW-VM: init up at $(uptime_s) s, kernel $(uname -r)"

for m in $DGW_MODULES; do
  if ! insmod "/lib/modules/$m.ko"; then
    echo "DGW-VM: insmod $m failed"
    finish 0 "$DGW_TEST_COUNT"
  fi
done
ip link set lo up
if ! { ip link add dev vcan0 type vcan && ip link set up vcan0; }; then
  echo "DGW-VM: could not create vcan0"
  finish 0 "$DGW_TEST_COUNT"
fi
echo "DGW-VM: modules loaded ($DGW_MODULES), vcan0 up at $(uptime_s) s"

export DGW_CAN_IFACE=vcan0 GTEST_COLOR=no HOME=/tmp TMPDIR=/tmp
passed=0
failed=0

# Kills every process but init and $1 (what a test left running in the background).
sweep() {
  for p in /proc/[0-9]*; do
    pid=${p#/proc/}
    [ "$pid" = 1 ] || [ "$pid" = "$1" ] || kill -KILL "$pid" 2>/dev/null
  done
}

# verdict KIND RC -> prints the reason and returns 1 when the test failed.
verdict() {
  if [ "$2" = 137 ]; then echo "killed (timeout ${DGW_TEST_TIMEOUT} s?)"; return 1; fi
  if [ "$2" != 0 ]; then echo "exit status $2"; return 1; fi
  [ "$1" = gtest ] || return 0
  if grep -q '^\[  FAILED  \]' /tmp/out; then echo "gtest reports [  FAILED  ]"; return 1; fi
  n=$(sed -n 's/^\[  PASSED  \] \([0-9]*\) test.*/\1/p' /tmp/out)
  if [ -z "$n" ]; then echo "no [  PASSED  ] line"; return 1; fi
  if [ "$n" = 0 ]; then echo "0 tests passed (all skipped: DGW_CAN_IFACE ignored?)"; return 1; fi
  return 0
}

while read -r name kind cmd <&3; do
  case "$name" in '' | '#'*) continue ;; esac
  # Every test starts with vcan0 present and up, whatever the previous one did to it.
  ip link show vcan0 >/dev/null 2>&1 || ip link add dev vcan0 type vcan
  ip link set up vcan0
  t0=$(uptime_s)
  echo "DGW-VM: --- $name ($kind): $cmd"
  rm -f /tmp/out /tmp/fifo
  mkfifo /tmp/fifo
  tee /tmp/out </tmp/fifo &
  tee_pid=$!
  (cd /tmp && exec timeout -s KILL "$DGW_TEST_TIMEOUT" sh -c "$cmd") </dev/null >/tmp/fifo 2>&1
  rc=$?
  sweep "$tee_pid"
  wait "$tee_pid"
  t1=$(uptime_s)
  secs=$(awk "BEGIN{printf \"%.1f\", $t1 - $t0}")
  if reason=$(verdict "$kind" "$rc"); then
    passed=$((passed + 1))
    echo "DGW-VM-TEST $name PASS ${secs}s"
  else
    failed=$((failed + 1))
    echo "DGW-VM-TEST $name FAIL ${secs}s $reason"
  fi
done 3</etc/dgw-tests

finish "$passed" "$failed"
