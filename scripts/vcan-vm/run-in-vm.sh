#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Runs test binaries on a real Linux vcan inside a small qemu VM, for machines whose own kernel
# has no CAN (see docs/protocol.md, "Testing on a real vcan").
#
#   scripts/vcan-vm/run-in-vm.sh BINARY [BINARY...]
#
# The VM boots Debian's kernel (downloaded, never installed) from a busybox initramfs, loads
# can, can-raw, can-dev and vcan, brings up vcan0 and vcan1, runs each binary with no arguments
# from a writable folder and prints "MGC-VM-RESULT <name> <exit status>" for each. Exits 0 only
# when every binary reported 0. The kernel and its modules are cached in $MGC_BUILD_DIR/vcan-vm/.
#
# Environment: MGC_BUILD_DIR (default <repo>/build), MGC_VM_TIMEOUT_S (whole VM, default 300),
# MGC_VM_ACCEL=tcg (emulate even where KVM is present).
set -euo pipefail
# shellcheck source=scripts/lib/common.sh
source "$(dirname "${BASH_SOURCE[0]}")/../lib/common.sh"

VM_DIR="$MGC_BUILD_DIR/vcan-vm"
VM_TIMEOUT_S="${MGC_VM_TIMEOUT_S:-300}"
# In load order: vcan needs can-dev's symbols, can-raw needs can's.
VM_MODULES=(can can-raw can-dev vcan)

die() {
  echo "run-in-vm: $*" >&2
  exit 1
}

[ $# -ge 1 ] || die "usage: $0 BINARY [BINARY...]"
declare -A seen_names=()
for bin in "$@"; do
  [[ -f $bin && -x $bin ]] || die "not an executable file: $bin"
  name="$(basename "$bin")"
  # The name is spliced into the VM's /init and matched in its console output.
  [[ $name =~ ^[A-Za-z0-9._-]+$ ]] || die "binary name $name: use letters, digits, '.', '_' or '-' only"
  [ -z "${seen_names[$name]:-}" ] || die "two binaries named $name: the results could not be told apart"
  seen_names[$name]=1
done

# The VM's own packages, checked and installed like the build's (common.sh's list may carry them
# too, so that scripts/test.sh installs them before any test runs).
# shellcheck disable=SC2034 # read by mgc_install_packages
MGC_PACKAGES=(qemu-system-x86 busybox-static cpio gzip)
mgc_install_packages || die "could not install the VM's Debian packages"

# The versioned kernel package behind linux-image-amd64, e.g. linux-image-6.1.0-56-amd64. Its name
# changes with Debian's updates, so it is resolved on every run; without package lists (a fresh
# container) apt-get update fetches them once.
resolve_kernel_package() {
  apt-cache depends linux-image-amd64 2>/dev/null | awk '$1 == "Depends:" && $2 ~ /^linux-image-[0-9]/ { print $2; exit }'
}
kernel_pkg="$(resolve_kernel_package)"
if [ -z "$kernel_pkg" ]; then
  echo "run-in-vm: no package list knows linux-image-amd64; running apt-get update"
  if [ "$(id -u)" -eq 0 ]; then apt-get update -qq; else sudo apt-get update -qq; fi ||
    die "apt-get update failed, so the kernel package cannot be resolved (is Debian's mirror reachable?)"
  kernel_pkg="$(resolve_kernel_package)"
  [ -n "$kernel_pkg" ] || die "linux-image-amd64 does not depend on a versioned linux-image-* package here"
fi

kernel_dir="$VM_DIR/$kernel_pkg"
have_kernel() {
  [ -f "$kernel_dir/vmlinuz" ] || return 1
  local m
  for m in "${VM_MODULES[@]}"; do [ -f "$kernel_dir/$m.ko" ] || return 1; done
}

# Downloads the kernel package and keeps only vmlinuz and the four modules, uncompressed (busybox
# insmod reads plain .ko files only).
fetch_kernel() {
  local scratch
  scratch="$(mktemp -d "$VM_DIR/fetch.XXXXXX")"
  cleanup+=("$scratch")
  echo "run-in-vm: downloading $kernel_pkg (about 70 MB, once; cached in $kernel_dir)"
  local apt_opts=()
  # As root apt-get drops to the _apt user, which cannot write to a private scratch folder.
  [ "$(id -u)" -eq 0 ] && apt_opts=(-o APT::Sandbox::User=root)
  if ! (cd "$scratch" && apt-get download -q "${apt_opts[@]}" "$kernel_pkg"); then
    die "apt-get download $kernel_pkg failed: the VM test needs Debian's kernel. Check that Debian's mirror (see /etc/apt/sources.list*) is reachable from this machine, or run apt-get download $kernel_pkg by hand to see why."
  fi
  dpkg -x "$scratch"/"$kernel_pkg"_*.deb "$scratch/root"
  local staging="$scratch/kernel" m found
  mkdir -p "$staging"
  set -- "$scratch"/root/boot/vmlinuz-*
  [ -f "$1" ] || die "$kernel_pkg holds no boot/vmlinuz-*"
  cp "$1" "$staging/vmlinuz"
  for m in "${VM_MODULES[@]}"; do
    found="$(find "$scratch/root/lib/modules" -name "$m.ko" -o -name "$m.ko.xz" -o -name "$m.ko.zst" | head -n 1)"
    [ -n "$found" ] || die "$kernel_pkg holds no module $m.ko: was CAN support dropped from Debian's kernel?"
    case "$found" in
      *.ko.xz) xz -dc "$found" >"$staging/$m.ko" ;;
      *.ko.zst) zstd -qdc "$found" >"$staging/$m.ko" ;;
      *) cp "$found" "$staging/$m.ko" ;;
    esac
  done
  rm -rf "$kernel_dir"
  mv -T "$staging" "$kernel_dir"
}

mkdir -p "$VM_DIR"
# Scratch folders removed on any exit, the failing ones included.
cleanup=()
trap 'rm -rf "${cleanup[@]}"' EXIT
if have_kernel; then
  echo "run-in-vm: kernel $kernel_pkg from cache $kernel_dir"
else
  fetch_kernel
fi

# --- initramfs ---------------------------------------------------------------------------------
run_dir="$(mktemp -d "$VM_DIR/run.XXXXXX")"
cleanup+=("$run_dir")
root="$run_dir/root"
mkdir -p "$root"/{bin,sbin,usr/bin,usr/sbin,proc,sys,dev,tmp,lib/modules,tests}
cp /bin/busybox "$root/bin/busybox"
cp "$kernel_dir"/*.ko "$root/lib/modules/"

# Copies a shared library or the dynamic loader to the same absolute path inside the VM, where the
# loader's default search finds it.
copy_to_root() {
  mkdir -p "$root$(dirname "$1")"
  cp -L "$1" "$root$1"
}

names=()
for bin in "$@"; do
  name="$(basename "$bin")"
  names+=("$name")
  # Debug info would make the initramfs many times larger and slower to unpack in the VM.
  strip -o "$root/tests/$name" "$bin" 2>/dev/null || cp "$bin" "$root/tests/$name"
  if ldd "$bin" >/dev/null 2>&1; then
    while read -r lib; do copy_to_root "$lib"; done < <(ldd "$bin" | grep -o '/[^ ]*' | sort -u)
  fi
done

cat >"$root/init" <<EOF
#!/bin/busybox sh
/bin/busybox --install -s
mount -t proc proc /proc
mount -t sysfs sys /sys
mount -t devtmpfs dev /dev
for m in ${VM_MODULES[*]}; do
  insmod /lib/modules/\$m.ko || echo "MGC-VM-ERROR insmod \$m failed"
done
ip link set lo up
for ifname in vcan0 vcan1; do
  ip link add dev \$ifname type vcan && ip link set up \$ifname || echo "MGC-VM-ERROR cannot bring up \$ifname"
done
cd /tmp
for name in ${names[*]}; do
  echo "MGC-VM-START \$name"
  # Through a pipe, so that test output is not a terminal and carries no colour codes.
  { /tests/\$name 2>&1; echo \$? >/tmp/\$name.status; } | cat
  # On a line of its own even when the test's last line had no newline.
  echo
  echo "MGC-VM-RESULT \$name \$(cat /tmp/\$name.status)"
done
echo "MGC-VM-DONE"
poweroff -f
EOF
chmod +x "$root/init"
(cd "$root" && find . | cpio -o -H newc --quiet | gzip -1) >"$run_dir/initrd.gz"

# --- boot --------------------------------------------------------------------------------------
console_raw="$run_dir/console.raw"
console="$run_dir/console.log"
# Boots the VM with the accelerator options given after the deadline, its serial console into
# $console_raw, and returns qemu's exit status (124: the VM timed out). With a boot deadline > 0
# it gives up (status 200) when init has not started the first test by then: a KVM that accepts
# the VM and then never runs it must not cost the whole timeout.
boot_vm() {
  local deadline_s=$1
  shift
  : >"$console_raw"
  # No network card: the tests need none, and its boot ROM only costs time.
  timeout "$VM_TIMEOUT_S" qemu-system-x86_64 "$@" -m 256 -display none -monitor none -serial "file:$console_raw" \
    -no-reboot -nic none -kernel "$kernel_dir/vmlinuz" -initrd "$run_dir/initrd.gz" \
    -append "console=ttyS0 quiet panic=-1" </dev/null >"$run_dir/qemu.log" 2>&1 &
  local pid=$! waited_s=0
  while kill -0 "$pid" 2>/dev/null; do
    if [ "$deadline_s" -gt 0 ] && [ "$waited_s" -ge "$deadline_s" ] && ! grep -q 'MGC-VM-START' "$console_raw"; then
      kill "$pid" 2>/dev/null
      wait "$pid" 2>/dev/null
      return 200
    fi
    sleep 1
    waited_s=$((waited_s + 1))
  done
  wait "$pid"
}

# KVM when it works, else emulation (MGC_VM_ACCEL=tcg forces it). Some hosts' KVM refuses a CPU
# model that passes the host's IA32_ARCH_CAPABILITIES MSR through ("failed to set MSR 0x10a", qemu
# aborts at once), and some accept a VM they then never run; each KVM candidate gets a boot
# deadline, and emulation is the last resort.
candidates=()
if [ "${MGC_VM_ACCEL:-}" != tcg ] && [ -r /dev/kvm ] && [ -w /dev/kvm ]; then
  candidates+=("-machine accel=kvm -cpu host" "-machine accel=kvm -cpu host,-arch-capabilities")
fi
candidates+=("-machine accel=tcg")
echo "run-in-vm: booting $kernel_pkg with ${names[*]} (timeout ${VM_TIMEOUT_S} s)"
start_s=$SECONDS
qemu_status=0
for i in "${!candidates[@]}"; do
  read -r -a accel <<<"${candidates[$i]}"
  deadline_s=0
  [ "$i" -lt $((${#candidates[@]} - 1)) ] && deadline_s=30
  set +e
  boot_vm "$deadline_s" "${accel[@]}"
  qemu_status=$?
  set -e
  if [ "$qemu_status" -eq 200 ] || { [ "$qemu_status" -ne 0 ] && ! grep -q 'MGC-VM-START' "$console_raw"; }; then
    echo "run-in-vm: qemu ${accel[*]} did not boot (status $qemu_status): $(tail -n 1 "$run_dir/qemu.log")"
    continue
  fi
  echo "run-in-vm: qemu ${accel[*]}"
  break
done
# The firmware's terminal control sequences are stripped so that the log reads as plain text.
tr -d '\r' <"$console_raw" | sed 's/\x1b\[[0-9;?]*[a-zA-Z]//g; s/\x1bc//g' >"$console"
cat "$console"
echo "run-in-vm: VM ran $((SECONDS - start_s)) s, qemu exit status $qemu_status"

failed=0
for name in "${names[@]}"; do
  status="$(sed -n "s/.*MGC-VM-RESULT $name \([0-9]*\)\$/\1/p" "$console" | tail -n 1)"
  if [ -z "$status" ]; then
    echo "run-in-vm: FAIL $name reported no result (VM timed out after ${VM_TIMEOUT_S} s, crashed, or the test hung)" >&2
    failed=1
  elif [ "$status" != 0 ]; then
    echo "run-in-vm: FAIL $name exited with status $status" >&2
    failed=1
  else
    echo "run-in-vm: PASS $name"
  fi
done
if grep -q 'MGC-VM-ERROR' "$console"; then
  echo "run-in-vm: FAIL the VM could not set up CAN:" >&2
  grep 'MGC-VM-ERROR' "$console" >&2
  failed=1
fi
if [ "$qemu_status" -ne 0 ]; then
  echo "run-in-vm: FAIL qemu exited with status $qemu_status (124: the VM timed out)" >&2
  failed=1
fi
exit "$failed"
