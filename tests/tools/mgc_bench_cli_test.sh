#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# mgc-bench's contract, on a few seeds per suite: each seed paper's suite writes its markdown
# tables, a CSV row per run and a JSON file; --runs and --seed choose the runs; the same seed gives
# the same runs; every path passes the dense re-check; bad options exit 2 with one line.
set -u
cli="$1"
root="$2"
source "$(dirname "$0")/cli_support.sh"
cd "$root" || exit 1

expect_bad "unknown suite" "^mgc-bench: --suite: expected one of thesis, zhang, replan, langari, sites, kim, campaign, all, .*got 'bogus'$" \
  --suite bogus
expect_bad "zero runs" "^mgc-bench: --runs: expected a number above 0, got '0'" --suite langari --runs 0
expect_bad "negative sweep step" "^mgc-bench: --sweep-step: expected a number of 0 or more, got '-1'" --suite loop --sweep-step -1
touch "$tmp/a-file"
expect_bad "--out names a file" "^mgc-bench: --out: cannot write to the folder '$tmp/a-file'" --suite langari --out "$tmp/a-file"
[ -e "$tmp/bogus-out" ] && fail "a refused suite created its --out folder"
expect_bad "unknown suite leaves --out alone" "got 'bogus'" --suite bogus --out "$tmp/bogus-out"
[ -e "$tmp/bogus-out" ] && fail "a refused suite created its --out folder"

for suite in thesis zhang langari kim safety; do
  expect_bad "$suite without its scenario" "^mgc-bench: (.*: )?$tmp/none/[a-z0-9-]+\\.yaml: cannot open the file$" \
    --suite "$suite" --runs 1 --scenarios "$tmp/none"
done

# run <suite> <runs> <seed> <folder>
run() {
  "$cli" --suite "$1" --runs "$2" --seed "$3" --out "$4" >"$tmp/out" 2>"$tmp/err"
  local code=$?
  [ "$code" -eq 0 ] || fail "--suite $1: exit $code: $(tail -3 "$tmp/err")"
  for ext in md csv json; do
    [ -s "$4/$1.$ext" ] || fail "--suite $1 wrote no $1.$ext"
  done
  grep -q "^### $1" "$4/$1.md" || fail "$1.md does not start the suite's section"
  grep -q "^| " "$4/$1.md" || fail "$1.md holds no table"
  grep -q "\"suite\":\"$1\"" "$4/$1.json" || fail "$1.json does not name its suite"
  grep -q "\"command\":\"mgc-bench --suite $1 --runs $2 --seed $3 --out $4\"" "$4/$1.json" || fail "$1.json does not record the command"
}

# column <csv> <name>: the values of one column, header excluded.
column() {
  local n
  n=$(head -1 "$1" | tr ',' '\n' | grep -nx "$2" | cut -d: -f1)
  [ -n "$n" ] || { fail "$1 has no column $2"; return; }
  tail -n +2 "$1" | cut -d, -f"$n"
}

# The planning suites' runs: one row each, seeds from --seed, every path re-checked densely.
run thesis 3 4 "$tmp/a"
[ "$(column "$tmp/a/thesis.csv" seed | sort -u | tr '\n' ' ')" = "4 5 6 " ] || fail "thesis.csv seeds are not 4, 5, 6"
[ "$(column "$tmp/a/thesis.csv" planner | grep -cx limcon)" -eq 6 ] || fail "thesis.csv: not 3 limcon runs on each of 2 sites"
column "$tmp/a/thesis.csv" success | grep -qvx 1 && fail "thesis.csv: a run failed"
column "$tmp/a/thesis.csv" recheck_failures | grep -qvx 0 && fail "thesis.csv: a path failed the dense re-check"
grep -q "| thesis RRTBiasedLimCon |" "$tmp/a/thesis.md" || fail "thesis.md has no column of the thesis's figures"
if grep -q "OMPL RRTConnect" "$tmp/a/thesis.md" && ! grep -q "OMPL not built" "$tmp/a/thesis.md"; then
  [ "$(column "$tmp/a/thesis.csv" planner | grep -cx ompl-rrtconnect)" -eq 3 ] || fail "thesis.csv: not 3 OMPL RRTConnect runs"
  grep -q '"paired"' "$tmp/a/thesis.json" || fail "thesis.json has no paired timing"
  grep -Eq "^Speed targets against OMPL, .*target >= 3 in both\): \*\*(met|not met)\*\*" "$tmp/a/thesis.md" ||
    fail "thesis.md gives no verdict on the speed target"
fi

run langari 3 4 "$tmp/a"
[ "$(column "$tmp/a/langari.csv" seed | sort -u | tr '\n' ' ')" = "4 5 6 " ] || fail "langari.csv seeds are not 4, 5, 6"
column "$tmp/a/langari.csv" recheck_failures | grep -qvx 0 && fail "langari.csv: a path failed the dense re-check"

run zhang 2 0 "$tmp/a"
[ -s "$tmp/a/zhang-replan.csv" ] || fail "zhang wrote no re-planning CSV (Table 5)"
[ -s "$tmp/a/zhang-anytime.csv" ] || fail "zhang wrote no anytime CSV (Tables 3 and 4)"
for replanner in drrt drrt-con-con-mod; do
  column "$tmp/a/zhang-replan.csv" replanner | grep -qx "$replanner" || fail "zhang-replan.csv has no $replanner runs"
done

run kim 2 1 "$tmp/a"
# Table 2's comparison (3 scenarios x 3 planners) and Table 3's tilt sweep (3 x 3), each over 2 seeds.
[ "$(tail -n +2 "$tmp/a/kim.csv" | wc -l)" -eq 36 ] || fail "kim.csv: expected 36 runs, got $(tail -n +2 "$tmp/a/kim.csv" | wc -l)"
[ "$(column "$tmp/a/kim.csv" seed | sort -u | tr '\n' ' ')" = "1 2 " ] || fail "kim.csv seeds are not 1, 2"
[ "$(grep -o '"planner":' "$tmp/a/kim.json" | wc -l)" -eq 36 ] || fail "kim.json does not hold the 36 runs"

# The same seeds again: the same runs, all but the times.
run thesis 3 4 "$tmp/b"
run langari 3 4 "$tmp/b"
for suite in thesis langari; do
  cols=$(head -1 "$tmp/a/$suite.csv" | tr ',' '\n' | grep -nvE '_ms$' | cut -d: -f1 | paste -sd,)
  diff <(cut -d, -f"$cols" "$tmp/a/$suite.csv") <(cut -d, -f"$cols" "$tmp/b/$suite.csv") >/dev/null ||
    fail "$suite: the same seeds gave other runs"
done

finish "mgc-bench command line"
