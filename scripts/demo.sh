#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The main job, as far as mgc goes today: build; load every shipped scenario, validate it, report
# start/goal feasibility, clearances and whether the straight joint-space line is blocked, and plan
# the lift with the thesis's planner (limcon; the two-crane lifts with multi-rrt) -- and the
# excavator's work cycle with nonuniform -- writing each plan to build/demo/; execute the lifts of
# the event scenarios with re-planning as the intruders move in (mgc-bench's replan suite, two
# seeds); then put the thesis site's crane on a CAN bus (mgc-sim, UDP on
# loopback) and read it through the controller's Hal (mgc-busmon) for a few seconds, with the true
# state logged to build/demo/truth.csv. Installs missing Debian packages.
set -euo pipefail
source "$(dirname "$0")/lib/common.sh"
mgc_install_packages
mgc_build mgc-plan mgc-sim mgc-busmon mgc-bench
bin="$MGC_BUILD_DIR/bin"
out="$MGC_BUILD_DIR/demo"
mkdir -p "$out"
status=0
for scenario in "$MGC_ROOT"/scenarios/*.yaml; do
  rel="${scenario#"$MGC_ROOT"/}"
  name="$(basename "$scenario" .yaml)"
  echo "=== mgc-plan --scenario $rel --check"
  "$bin/mgc-plan" --scenario "$scenario" --check || status=$?
  # Two cranes on one girder move their joints together: limcon's one joint at a time would tip
  # the suspension, so those lifts take seed 004's multi-rrt.
  planner=limcon
  if grep -q '^dual_crane:' "$scenario"; then planner=multi-rrt; fi
  echo "=== mgc-plan --scenario $rel --planner $planner --json build/demo/$name.json"
  "$bin/mgc-plan" --scenario "$scenario" --planner "$planner" --json "$out/$name.json" || status=$?
  if grep -q '^work_cycle:' "$scenario"; then
    echo "=== mgc-plan --scenario $rel --planner nonuniform --cycle --json build/demo/$name-cycle.json"
    "$bin/mgc-plan" --scenario "$scenario" --planner nonuniform --cycle --json "$out/$name-cycle.json" || status=$?
  fi
  echo
done

echo "=== mgc-bench --suite replan --runs 2: the lifts executed while crane 2, tower crane 2 and truck 2 move in"
(cd "$MGC_ROOT" && "$bin/mgc-bench" --suite replan --runs 2 --out "$out/replan") || status=$?
echo

site="$MGC_ROOT/scenarios/thesis-steel-frame.yaml"
echo "=== mgc-sim --scenario scenarios/thesis-steel-frame.yaml (UDP on loopback), read by mgc-busmon --start"
"$bin/mgc-sim" --scenario "$site" --duration 4 --truth-csv "$out/truth.csv" &
sim_pid=$!
sleep 0.3
"$bin/mgc-busmon" --scenario "$site" --start --duration 3 --require-valid || status=$?
wait "$sim_pid" || status=$?
echo "true machine state: build/demo/truth.csv ($(($(wc -l <"$out/truth.csv") - 1)) rows)"
exit "$status"
