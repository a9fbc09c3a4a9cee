#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# mgc-plan --cycle: seed 003's excavator work cycle planned as three subtasks, reported per subtask
# and as a whole; exit 1 when a subtask finds no path, 2 on bad input with one line on stderr.
set -u
plan="$1"
root="$2"
cli="$plan"
source "$(dirname "$0")/cli_support.sh"
cycle="$root/scenarios/excavator-cycle.yaml"

"$plan" --scenario "$cycle" --check >"$tmp/out" 2>"$tmp/err" || fail "--check: $(cat "$tmp/err")"
grep -q "^dumped .*arm -80 deg, bucket -15 deg" "$tmp/out" || fail "--check does not report the dumped pose"
grep -q "^next dig " "$tmp/out" || fail "--check does not report the next dig"

"$plan" --scenario "$cycle" --planner nonuniform --cycle --seed 2 --json "$tmp/cycle.json" --svg "$tmp/cycle.svg" \
  >"$tmp/out" 2>"$tmp/err"
code=$?
[ "$code" -eq 0 ] || fail "--cycle: exit $code: $(cat "$tmp/err")"
grep -q "work cycle solved in .* (move_to_dump solved .* ms, dump solved .* ms, return solved .* ms)" "$tmp/out" \
  || fail "--cycle summary line: $(cat "$tmp/out")"
for key in success status planner seed work_cycle joint_names joint_units path moving_joint planning_time_ms iterations \
           tree_nodes collision_checks path_nodes raw_path_nodes smoothed min_clearance_m subtasks parameters; do
  grep -q "\"$key\":" "$tmp/cycle.json" || fail "cycle JSON lacks key $key"
done
grep -q '"success":true' "$tmp/cycle.json" || fail "cycle JSON does not say success"
grep -q '"work_cycle":true' "$tmp/cycle.json" || fail "cycle JSON does not say work_cycle"
grep -q '"seed":2,' "$tmp/cycle.json" || fail "cycle JSON seed is not the one given"
grep -q '{"name":"move_to_dump","held":\["bucket_ground_angle"\],"bucket_ground_angle_deg":-180,"success":true' "$tmp/cycle.json" \
  || fail "cycle JSON: move_to_dump entry"
grep -q '{"name":"dump","held":\["swing","boom"\],"success":true' "$tmp/cycle.json" || fail "cycle JSON: dump entry"
grep -q '{"name":"return","held":\[\],"success":true' "$tmp/cycle.json" || fail "cycle JSON: return entry"
[ "$(grep -o '"name":"' "$tmp/cycle.json" | wc -l)" -eq 3 ] || fail "cycle JSON: not three subtasks"
# The whole path starts at the dig and ends at the next dig.
grep -q '"path":\[\[0,-10,-80,-90\],' "$tmp/cycle.json" || fail "cycle path does not start at the dig pose"
grep -q ',\[0,25,-62,-53\]\],"moving_joint":\[[-0-9,]*\],"planning_time_ms"' "$tmp/cycle.json" \
  || fail "cycle path does not end at the next dig"
grep -q "^<svg " "$tmp/cycle.svg" || fail "--cycle --svg did not write an SVG document"

# One iteration per subtask cannot reach the dump pose: exit 1, the later subtasks not planned.
"$plan" --scenario "$cycle" --planner nonuniform --cycle --max-iterations 1 --json "$tmp/fail.json" >"$tmp/out" 2>"$tmp/err"
code=$?
[ "$code" -eq 1 ] || fail "--cycle --max-iterations 1: exit $code, expected 1"
grep -q '"success":false' "$tmp/fail.json" || fail "failed cycle JSON does not say success false"
grep -q '"path":\[\],"moving_joint":\[\],"planning_time_ms"' "$tmp/fail.json" || fail "failed cycle JSON has a path"
grep -q '"name":"dump","held":\["swing","boom"\],"success":false,"status":"not planned"' "$tmp/fail.json" \
  || fail "failed cycle JSON: dump not marked not planned"

expect_bad "--cycle without a work_cycle" "^.*excavator-pipelines.yaml: work_cycle: expected a work_cycle section for --cycle" \
  --scenario "$root/scenarios/excavator-pipelines.yaml" --planner nonuniform --cycle
expect_bad "--cycle with another planner" "^mgc-plan: --cycle: expected --planner nonuniform .*, got --planner limcon$" \
  --scenario "$cycle" --planner limcon --cycle
sed -e "s|^machine: machines/|machine: $root/scenarios/machines/|" -e 's/bucket_deg: -15 /bucket_deg: -160 /' "$cycle" >"$tmp/no-dump.yaml"
expect_bad "dump that does not open the bucket" "^$tmp/no-dump.yaml:[0-9]+: work_cycle.dump.bucket_deg: expected a bucket curled out" \
  --scenario "$tmp/no-dump.yaml" --planner nonuniform --cycle

finish "mgc-plan --cycle"
