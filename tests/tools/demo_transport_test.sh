#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The demo's choice of transport (scripts/lib/common.sh, mgc_can_interface): the first CAN
# interface that is up, on made-up /sys/class/net folders; nothing without one.
#   demo_transport_test.sh SOURCE_DIR
set -euo pipefail
source "$1/scripts/lib/common.sh"
net="$(mktemp -d)"
trap 'rm -rf "$net"' EXIT
fail=0

iface() {  # iface NAME TYPE FLAGS
  mkdir -p "$net/$1"
  echo "$2" >"$net/$1/type"
  echo "$3" >"$net/$1/flags"
}
expect() {  # expect WHAT WANTED
  local got
  got="$(mgc_can_interface "$net")"
  if [ "$got" = "$2" ]; then
    echo "ok: $1: '$got'"
  else
    echo "FAILED: $1: got '$got', wanted '$2'"
    fail=1
  fi
}

iface lo 772 0x9
iface eth0 1 0x1003
expect "no CAN interface" ""
iface vcan0 280 0xc0
expect "a CAN interface that is down" ""
iface vcan1 280 0xc1
expect "a CAN interface that is up" "vcan1"
echo garbage >"$net/vcan0/flags"
expect "unreadable flags are not up" "vcan1"
echo 0xc1 >"$net/vcan0/flags"
expect "the first of two that are up" "vcan0"
# Under set -e the demo calls it on the machine's own folder: whatever is there, status 0.
if mgc_can_interface >/dev/null; then
  echo "ok: this machine's /sys/class/net: status 0"
else
  echo "FAILED: this machine's /sys/class/net: status $?"
  fail=1
fi
exit "$fail"
