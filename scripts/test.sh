#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Builds mgc into build/, builds the libraries and tools as a Release build into build-release/,
# then runs every test through ctest (its summary closes the output). Installs missing Debian
# packages.
set -euo pipefail
source "$(dirname "$0")/lib/common.sh"
mgc_install_packages
mgc_build
mgc_build_release
cd "$MGC_BUILD_DIR"
ctest --output-on-failure -j "$(nproc)" --timeout 600
