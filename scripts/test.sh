#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Builds mgc into build/, builds the libraries and tools as a Release build into build-release/
# and the fuzz targets with clang into build-fuzz/, then runs every test through ctest, and each
# fuzz target for a bounded time (ctest -L fuzz in build-fuzz/; its summary closes the output).
# Installs missing Debian packages.
set -euo pipefail
source "$(dirname "$0")/lib/common.sh"
mgc_install_packages
mgc_build
mgc_build_release
mgc_build_fuzz
status=0
(cd "$MGC_BUILD_DIR" && ctest --output-on-failure -j "$(nproc)" --timeout 600) || status=$?
(cd "$MGC_FUZZ_DIR" && ctest --output-on-failure -j "$(nproc)" -L fuzz) || status=$?
exit "$status"
