#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Builds mgc into build/ and runs every test through ctest, then builds the libraries and tools as
# a Release build into build-release/. Installs missing Debian packages.
set -euo pipefail
source "$(dirname "$0")/lib/common.sh"
mgc_install_packages
mgc_build
(cd "$MGC_BUILD_DIR" && ctest --output-on-failure -j "$(nproc)" --timeout 600)
mgc_build_release
