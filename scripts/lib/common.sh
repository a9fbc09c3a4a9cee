# SPDX-License-Identifier: Apache-2.0
# Shared by the README's commands: installs the Debian packages mgc needs (only those missing,
# with one apt-get update first) and configures and builds into build/ (and build-release/, and
# the clang fuzz build build-fuzz/).

MGC_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
MGC_BUILD_DIR="${MGC_BUILD_DIR:-$MGC_ROOT/build}"
MGC_RELEASE_DIR="${MGC_RELEASE_DIR:-$MGC_ROOT/build-release}"
MGC_FUZZ_DIR="${MGC_FUZZ_DIR:-$MGC_ROOT/build-fuzz}"

MGC_PACKAGES=(
  g++ cmake make pkg-config
  libeigen3-dev libfcl-dev libccd-dev
  liblcm-dev liblcm-bin libglib2.0-dev
  catch2 libyaml-cpp-dev libcli11-dev libboost-dev libsodium-dev libompl-dev libcpp-httplib-dev
  chromium chromium-driver python3-selenium curl
  qemu-system-x86 busybox-static cpio
  clang libclang-rt-14-dev
)

mgc_install_packages() {
  local missing=() p
  for p in "${MGC_PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  echo "mgc: installing missing Debian packages: ${missing[*]}"
  local sudo=()
  if [ "$(id -u)" -ne 0 ]; then
    command -v sudo >/dev/null || { echo "mgc: need root (or sudo) to install: ${missing[*]}" >&2; return 1; }
    sudo=(sudo)
  fi
  "${sudo[@]}" apt-get update -qq
  DEBIAN_FRONTEND=noninteractive "${sudo[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
}

# mgc_can_interface [net folder]: prints the name of the first network interface that is a CAN
# interface (ARPHRD_CAN, type 280: a vcan or a real bus) and is up (IFF_UP); nothing when there is
# none. The folder defaults to /sys/class/net; tests point it at a made-up one.
mgc_can_interface() {
  local net="${1:-/sys/class/net}" dev type flags
  for dev in "$net"/*; do
    type="$(cat "$dev/type" 2>/dev/null)" || continue
    [ "$type" = 280 ] || continue
    flags="$(cat "$dev/flags" 2>/dev/null)" || continue
    [[ $flags =~ ^0x[0-9a-fA-F]+$ ]] || continue
    (( flags & 0x1 )) || continue
    basename "$dev"
    return 0
  done
}

# mgc_build [target...]: configures build/ (tests included) and builds the targets, or all.
mgc_build() {
  cmake -S "$MGC_ROOT" -B "$MGC_BUILD_DIR" -DCMAKE_BUILD_TYPE="${MGC_BUILD_TYPE:-RelWithDebInfo}" -DMGC_BUILD_TESTS=ON
  local targets=()
  [ $# -gt 0 ] && targets=(--target "$@")
  cmake --build "$MGC_BUILD_DIR" -j "$(nproc)" "${targets[@]}"
}

# mgc_build_release: configures build-release/ as a Release build (-O3) without the tests and builds
# the libraries and tools: the build type most users pick, kept free of -O3-only warnings.
mgc_build_release() {
  cmake -S "$MGC_ROOT" -B "$MGC_RELEASE_DIR" -DCMAKE_BUILD_TYPE=Release -DMGC_BUILD_TESTS=OFF
  cmake --build "$MGC_RELEASE_DIR" -j "$(nproc)"
}

# mgc_build_fuzz: configures build-fuzz/ with clang and MGC_FUZZ=ON and builds the libFuzzer
# targets and only the libraries they need (docs/fuzzing.md); `ctest -L fuzz` there runs them.
mgc_build_fuzz() {
  cmake -S "$MGC_ROOT" -B "$MGC_FUZZ_DIR" -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DMGC_BUILD_TESTS=OFF -DMGC_FUZZ=ON
  cmake --build "$MGC_FUZZ_DIR" -j "$(nproc)" --target mgc_fuzz
}
