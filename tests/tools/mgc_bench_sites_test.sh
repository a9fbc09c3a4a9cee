#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# mgc-bench --suite sites on a few families: the tables and the generated sites are written, a
# generated site is an ordinary scenario mgc-plan loads, the walled-in site ends with exit 1 at its
# cap, the chart-infeasible one with exit 2 naming the chart row, and the same seed writes the
# same site byte for byte.
set -u
cli="$1"
plan="$2"
root="$3"
tools="$plan"
source "$(dirname "$0")/cli_support.sh"
cd "$root" || exit 1

families=crane-walled-in,crane-chart-infeasible,tower-trolley-slew,exc-hopper
expect_bad "unknown family" "^mgc-bench: --families: expected names among crane-l-frame, .*, got 'bogus'$" \
  --suite sites --runs 1 --families crane-l-frame,bogus
expect_bad "families without the sites suite" "^mgc-bench: --families: expected --suite sites, got --suite 'thesis'$" \
  --suite thesis --runs 1 --families crane-l-frame
expect_bad "sites without the machine files" "^mgc-bench: $tmp/none/machines/grove-tms870\\.yaml: cannot open the file$" \
  --suite sites --runs 1 --families crane-l-frame --scenarios "$tmp/none"

"$cli" --suite sites --runs 1 --families "$families" --out "$tmp/a" >"$tmp/out" 2>"$tmp/err"
code=$?
[ "$code" -eq 0 ] || fail "--suite sites: exit $code: $(tail -3 "$tmp/err")"
for ext in md csv json; do
  [ -s "$tmp/a/sites.$ext" ] || fail "--suite sites wrote no sites.$ext"
done
grep -q "^### sites" "$tmp/a/sites.md" || fail "sites.md does not start the suite's section"
grep -q "^#### tower-trolley-slew" "$tmp/a/sites.md" || fail "sites.md has no table for tower-trolley-slew"
grep -q "^#### crane-l-frame" "$tmp/a/sites.md" && fail "sites.md has a table for a family not asked for"
grep -q "^| crane-walled-in | rrt-connect | 3 | 3 |" "$tmp/a/sites.md" || fail "the walled-in family's rrt-connect queries did not all end without a path"
grep -q "naming the load-chart row (mgc-plan exits 2 with it): 3/3" "$tmp/a/sites.md" || fail "the chart rows are not named"
grep -q "^Targets\\|^#### Targets of the default one-joint-at-a-time planner \`axis-connect\`" "$tmp/a/sites.md" ||
  fail "sites.md has no target block for axis-connect"
[ "$(ls "$tmp/a/sites"/*-s[0-2].yaml | wc -l)" -eq 12 ] || fail "expected 12 generated sites, got $(ls "$tmp/a/sites")"
# One intruder site per solvable family, for the re-planning table.
[ "$(ls "$tmp/a/sites"/*-intruder.yaml | wc -l)" -eq 2 ] || fail "expected 2 intruder sites, got $(ls "$tmp/a/sites")"
grep -q "^#### Re-planning on generated sites with a second machine intruding" "$tmp/a/sites.md" || fail "sites.md has no re-planning table"
grep -q "^| drrt-con-con-mod | excavator | [0-9]*/1 |" "$tmp/a/sites.md" || fail "the re-planning table has no drrt-con-con-mod excavator row"
[ -s "$tmp/a/sites/machines/grove-tms870.yaml" ] || fail "the machine files are not beside the sites"
# Every CSV row names a generated file, a planner and a seed: enough to replay it.
[ "$(grep -c '^sites,tower-trolley-slew-s[0-2]\.yaml,rrt-connect,0,' "$tmp/a/sites.csv")" -eq 3 ] ||
  fail "sites.csv does not hold one rrt-connect row per tower-trolley-slew site"

# A generated site is an ordinary scenario.
"$plan" --check --scenario "$tmp/a/sites/tower-trolley-slew-s0.yaml" >"$tmp/out" 2>"$tmp/err" ||
  fail "mgc-plan --check on a generated site: exit $?: $(cat "$tmp/err")"
[ "$(grep -c "feasible, clearance" "$tmp/out")" -eq 2 ] || fail "--check does not find start and goal feasible: $(cat "$tmp/out")"
"$plan" --scenario "$tmp/a/sites/tower-trolley-slew-s0.yaml" --planner rrt-connect --seed 3 >"$tmp/out" 2>"$tmp/err" ||
  fail "rrt-connect on a generated solvable site: exit $?: $(cat "$tmp/out" "$tmp/err")"

"$plan" --check --scenario "$tmp/a/sites/exc-hopper-s0-intruder.yaml" >"$tmp/out" 2>"$tmp/err" ||
  fail "mgc-plan --check on an intruder site: exit $?: $(cat "$tmp/err")"
grep -q "^obstacles .* 1 dynamic" "$tmp/out" || fail "the intruder site has no dynamic obstacle: $(cat "$tmp/out")"

# The walled-in site: no path, exit 1 once the file's iteration cap is spent.
"$plan" --scenario "$tmp/a/sites/crane-walled-in-s0.yaml" --planner rrt-connect --seed 0 >"$tmp/out" 2>"$tmp/err"
code=$?
[ "$code" -eq 1 ] || fail "walled-in: exit $code, expected 1: $(cat "$tmp/out" "$tmp/err")"
grep -q "iteration limit reached" "$tmp/out" || fail "walled-in: not ended by the iteration cap: $(cat "$tmp/out")"

# The chart-infeasible site: exit 2, one line naming the file, the goal and the chart row.
for mode in "--planner rrt-connect" "--check"; do
  # shellcheck disable=SC2086
  "$plan" --scenario "$tmp/a/sites/crane-chart-infeasible-s1.yaml" $mode >"$tmp/out" 2>"$tmp/err"
  code=$?
  [ "$code" -eq 2 ] || fail "chart-infeasible, $mode: exit $code, expected 2"
  grep -Eq "^$tmp/a/sites/crane-chart-infeasible-s1\\.yaml:[0-9]+: goal: infeasible: .*load-chart row 110 ft boom" "$tmp/err" ||
    fail "chart-infeasible, $mode: stderr does not name the goal and the chart row: $(cat "$tmp/err")"
  [ "$(wc -l <"$tmp/err")" -eq 1 ] || fail "chart-infeasible, $mode: expected one line on stderr: $(cat "$tmp/err")"
done

# The same seed writes the same sites, byte for byte; a first seed of 1 draws site seeds 1..3,
# whose 1 and 2 are the sites above.
"$cli" --suite sites --runs 1 --families "$families" --out "$tmp/b" >/dev/null 2>"$tmp/err" ||
  fail "second run: exit $?: $(tail -3 "$tmp/err")"
"$cli" --suite sites --runs 1 --seed 1 --families exc-hopper --out "$tmp/c" >/dev/null 2>"$tmp/err" ||
  fail "run at seed 1: exit $?: $(tail -3 "$tmp/err")"
for f in "$tmp/a/sites"/*.yaml; do
  cmp -s "$f" "$tmp/b/sites/$(basename "$f")" || fail "$(basename "$f") differs between two runs with the same seed"
done
cmp -s "$tmp/a/sites/exc-hopper-s2.yaml" "$tmp/c/sites/exc-hopper-s2.yaml" || fail "exc-hopper-s2.yaml depends on the first seed"
cmp -s "$tmp/a/sites/exc-hopper-s1.yaml" "$tmp/a/sites/exc-hopper-s2.yaml" && fail "two seeds gave the same site"

finish "mgc-bench --suite sites"
