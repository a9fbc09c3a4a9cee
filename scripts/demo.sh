#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The main job, as far as mgc goes today: build, then load every shipped scenario, validate it,
# report start/goal feasibility, clearances and whether the straight joint-space line is blocked,
# and plan the lift with the thesis's planner (limcon), writing each plan to build/demo/.
# Installs missing Debian packages.
set -euo pipefail
source "$(dirname "$0")/lib/common.sh"
mgc_install_packages
mgc_build mgc-plan
status=0
for scenario in "$MGC_ROOT"/scenarios/*.yaml; do
  echo "=== mgc-plan --scenario ${scenario#"$MGC_ROOT"/} --check"
  "$MGC_BUILD_DIR/bin/mgc-plan" --scenario "$scenario" --check || status=$?
  name="$(basename "$scenario" .yaml)"
  mkdir -p "$MGC_BUILD_DIR/demo"
  echo "=== mgc-plan --scenario ${scenario#"$MGC_ROOT"/} --planner limcon --json build/demo/$name.json"
  "$MGC_BUILD_DIR/bin/mgc-plan" --scenario "$scenario" --planner limcon --json "$MGC_BUILD_DIR/demo/$name.json" || status=$?
  echo
done
exit "$status"
