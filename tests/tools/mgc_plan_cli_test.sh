#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# mgc-plan's contract: exit 0 on success, 2 on bad input with exactly one line on stderr naming the
# file, the line and the field. --check exits 0 when start and goal are feasible (a blocked straight
# line between them included) and 2, as planning does, when either is not.
set -u
plan="$1"
root="$2"
cli="$plan"
source "$(dirname "$0")/cli_support.sh"

for scenario in "$root"/scenarios/*.yaml; do
  "$plan" --scenario "$scenario" --check >"$tmp/out" 2>"$tmp/err"
  code=$?
  [ "$code" -eq 0 ] || fail "$scenario: exit $code, expected 0: $(cat "$tmp/err")"
  [ -s "$tmp/err" ] && fail "$scenario: unexpected stderr: $(cat "$tmp/err")"
  grep -q "^start .*" "$tmp/out" && grep -q "feasible, clearance" "$tmp/out" || fail "$scenario: no feasibility report"
  grep -q "joint-space line from start to goal is blocked" "$tmp/out" || fail "$scenario: straight line not reported blocked"
done


sed 's/load_lb: 20000 /load_lb: 150000 /' "$root/scenarios/thesis-steel-frame.yaml" >"$tmp/heavy.yaml"
sed -i "s|^machine: machines/|machine: $root/scenarios/machines/|" "$tmp/heavy.yaml"
expect_bad "load above chart" "^$tmp/heavy.yaml:[0-9]+: task.load_lb: expected a load the chart rates" \
  --scenario "$tmp/heavy.yaml" --check

sed 's/  swing_deg: -80/  swing_deg: 10/' "$root/scenarios/thesis-steel-frame.yaml" >"$tmp/goal-in-frame.yaml"
sed -i "s|^machine: machines/|machine: $root/scenarios/machines/|" "$tmp/goal-in-frame.yaml"
expect_bad "goal in collision" "^$tmp/goal-in-frame.yaml:[0-9]+: goal: infeasible: collision: .* hits obstacle 'frame/" \
  --scenario "$tmp/goal-in-frame.yaml" --check
# The report on stdout still says why, pose by pose; the start stays feasible.
grep -Eq "^ +infeasible: collision: .* hits obstacle 'frame/" "$tmp/out" || fail "goal in collision: stdout does not say why"
grep -q "feasible, clearance" "$tmp/out" || fail "goal in collision: stdout lost the start's report"
sed '0,/  swing_deg: 80/s//  swing_deg: 10/' "$root/scenarios/thesis-steel-frame.yaml" >"$tmp/start-in-frame.yaml"
sed -i "s|^machine: machines/|machine: $root/scenarios/machines/|" "$tmp/start-in-frame.yaml"
expect_bad "start in collision" "^$tmp/start-in-frame.yaml:[0-9]+: start: infeasible: collision: .* hits obstacle 'frame/" \
  --scenario "$tmp/start-in-frame.yaml" --check
grep -Eq "^ +infeasible: collision: " "$tmp/out" || fail "start in collision: stdout does not say why"

expect_bad "missing file" "^$tmp/none.yaml: cannot open the file" --scenario "$tmp/none.yaml" --check
expect_bad "both modes" "give either --check or --planner NAME, not both" --scenario "$root/scenarios/thesis-steel-frame.yaml" --check --planner limcon
expect_bad "unknown planner" "^mgc-plan: --planner: expected one of axis-connect, limcon, rrt, rrt-connect, rrt-ext-con, rrt-ext-ext, con-con-mod, anytime, nonuniform, rrt-basic, cart-rrt, multi-rrt, got 'bogus'$" \
  --scenario "$root/scenarios/thesis-steel-frame.yaml" --planner bogus
expect_bad "zero iterations" "^mgc-plan: --max-iterations: expected a number above 0, got '0' \\(see --help\\)$" \
  --scenario "$root/scenarios/thesis-steel-frame.yaml" --planner limcon --max-iterations 0
expect_bad "planning from an infeasible goal" "^$tmp/goal-in-frame.yaml:[0-9]+: goal: infeasible" \
  --scenario "$tmp/goal-in-frame.yaml" --planner limcon

# Without --planner it plans with the default one-joint-at-a-time planner.
"$plan" --scenario "$root/scenarios/thesis-steel-frame.yaml" >"$tmp/out" 2>"$tmp/err" || fail "default planner: exit $?: $(cat "$tmp/err")"
grep -q "^axis-connect thesis-steel-frame seed 0: solved" "$tmp/out" || fail "default planner: not axis-connect: $(head -1 "$tmp/out")"

# Planning: exit 0 with the JSON's required keys; exit 1 when the limits are too tight.
"$plan" --scenario "$root/scenarios/thesis-steel-frame.yaml" --planner limcon --seed 3 --json "$tmp/plan.json" >"$tmp/out" 2>"$tmp/err"
code=$?
[ "$code" -eq 0 ] || fail "limcon: exit $code: $(cat "$tmp/err")"
for key in success planner seed joint_names joint_units path planning_time_ms iterations tree_nodes path_nodes \
           dof_switches exec_time_sequential_s exec_time_simultaneous_s min_clearance_m raw_path_nodes smoothed; do
  grep -q "\"$key\":" "$tmp/plan.json" || fail "plan JSON lacks key $key"
done
grep -q '"success":true' "$tmp/plan.json" || fail "plan JSON does not say success"
grep -q '"joint_units":\["deg","deg","m","m"\]' "$tmp/plan.json" || fail "plan JSON joint units wrong"
grep -q '"seed":3,' "$tmp/plan.json" || fail "plan JSON seed is not the one given"
"$plan" --scenario "$root/scenarios/excavator-pipelines.yaml" --planner nonuniform --svg "$tmp/plan.svg" --svg-tree >"$tmp/out" 2>"$tmp/err" \
  || fail "nonuniform with --svg: $(cat "$tmp/err")"
grep -q "^<svg " "$tmp/plan.svg" || fail "--svg did not write an SVG document"
[ "$(grep -c "<polyline" "$tmp/plan.svg")" -ge 3 ] || fail "--svg drew no path or tree"
grep -q "bucket-tip path" "$tmp/plan.svg" || fail "--svg legend does not name the excavator's tool point"
# The working envelope is drawn when the scenario has one (tests/tools/svg_view_test.cpp checks where).
"$plan" --scenario "$root/scenarios/thesis-steel-frame-road.yaml" --planner limcon --svg "$tmp/road.svg" >"$tmp/out" 2>"$tmp/err" \
  || fail "road with --svg: $(cat "$tmp/err")"
[ "$(grep -c 'class="envelope wall-0"' "$tmp/road.svg")" -eq 2 ] || fail "--svg did not draw the road's wall in both views"
grep -q "working envelope" "$tmp/road.svg" || fail "--svg legend does not name the working envelope"
"$plan" --scenario "$root/scenarios/thesis-steel-frame.yaml" --planner limcon --svg "$tmp/plain.svg" >/dev/null 2>&1 || fail "limcon with --svg failed"
grep -q "envelope" "$tmp/plain.svg" && fail "--svg drew an envelope for a scenario without one"
"$plan" --scenario "$root/scenarios/thesis-steel-frame.yaml" --planner anytime --json "$tmp/anytime.json" >"$tmp/out" 2>"$tmp/err" \
  || fail "anytime: $(cat "$tmp/err")"
grep -q '"anytime_history":\[{"time_ms":' "$tmp/anytime.json" || fail "anytime JSON has no improvement history"
"$plan" --scenario "$root/scenarios/thesis-steel-frame.yaml" --planner rrt --max-iterations 3 --json "$tmp/fail.json" >"$tmp/out" 2>"$tmp/err"
code=$?
[ "$code" -eq 1 ] || fail "rrt with 3 iterations: exit $code, expected 1"
grep -q '"success":false' "$tmp/fail.json" || fail "failed plan JSON does not say success false"
grep -q '"path":\[\]' "$tmp/fail.json" || fail "failed plan JSON has a path"
expect_bad "unknown option" "." --scenario "$root/scenarios/thesis-steel-frame.yaml" --check --frobnicate

"$plan" --help >"$tmp/out" 2>&1 || fail "--help exited non-zero"
grep -q -- "--check" "$tmp/out" || fail "--help does not mention --check"
grep -q -- "cart-rrt" "$tmp/out" || fail "--help does not list cart-rrt"

# cart-rrt keeps its own time-scaled spline: not smoothed, its trajectory reported.
"$plan" --scenario "$root/scenarios/excavator-pipelines.yaml" --planner cart-rrt --json "$tmp/cart.json" >/dev/null 2>&1 ||
  fail "cart-rrt on the excavator scenario failed"
grep -q '"smoothed":false' "$tmp/cart.json" || fail "cart-rrt path was shortcut-smoothed"
grep -Eq '"cart_rrt":\{"trajectory_duration_s":[0-9.]+,' "$tmp/cart.json" || fail "cart-rrt JSON lacks its trajectory"

finish "mgc-plan CLI"
