#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The mgc binary against mgc-sim over UDP on loopback, on ports of its own, for a few seconds of
# real time: the machine starts, the lift is planned and the crane moves (EXECUTING), and the loop
# timing mgc prints stays within bounds generous enough for a loaded 2-core CI machine
# (docs/benchmarks.md §Control loop has the figures).
set -u
mgc="$1"
sim="$2"
root="$3"
cli="$mgc"
source "$root/tests/tools/cli_support.sh"
scenario="$root/scenarios/thesis-steel-frame.yaml"

# Ports of this test: apart from mgc_sim_cli's 41000..48999 range would not be enough, so 49000 up.
base=$((49000 + ($$ % 3000) * 2))
sim_port=$base
mgc_port=$((base + 1))
"$sim" --scenario "$scenario" --bus "udp:127.0.0.1:$sim_port,peer=127.0.0.1:$mgc_port" --duration 12 --quiet \
  >"$tmp/sim.out" 2>&1 &
sim_pid=$!
sleep 0.3
"$mgc" --scenario "$scenario" --bus "udp:127.0.0.1:$mgc_port,peer=127.0.0.1:$sim_port" --lcm-url memq:// \
  --goal-on-start --duration 8 >"$tmp/mgc.out" 2>&1
code=$?
kill "$sim_pid" 2>/dev/null
wait "$sim_pid" 2>/dev/null

cat "$tmp/mgc.out"
[ "$code" -eq 0 ] || fail "mgc exited $code"
grep -Eq -- '-> EXECUTING +PlanSolved' "$tmp/mgc.out" || fail "the run never reached EXECUTING"
# Not asserted: a stall of either process beyond the 30 ms stale limit on a loaded machine stops
# the lift and faults it, as designed.
grep -q -- '-> FAULT' "$tmp/mgc.out" && echo "note: the run faulted (a stall on this machine?)"
loop=$(grep '^mgc: loop:' "$tmp/mgc.out")
[ -n "$loop" ] || fail "no loop summary"
# mgc: loop: N cycles at P us, compute p99 A us max B us, wake-up lateness p99 C us max D us, E deadline misses, ...
read -r cycles p99 lateness_p99 misses <<<"$(sed -E 's/^mgc: loop: ([0-9]+) cycles at [0-9]+ us, compute p99 ([0-9]+) us max [0-9]+ us, wake-up lateness p99 ([0-9]+) us max [0-9]+ us, ([0-9]+) deadline misses.*/\1 \2 \3 \4/' <<<"$loop")"
echo "parsed: cycles=$cycles compute_p99_us=$p99 lateness_p99_us=$lateness_p99 deadline_misses=$misses"
# 8 s at 100 Hz: 800 cycles, fewer only when periods were skipped.
[ "${cycles:-0}" -ge 600 ] || fail "$cycles cycles in 8 s at 100 Hz"
[ "${p99:-999999}" -lt 20000 ] || fail "compute p99 $p99 us, bound 20 ms"
[ "${lateness_p99:-999999}" -lt 20000 ] || fail "wake-up lateness p99 $lateness_p99 us, bound 20 ms"
[ "${misses:-999999}" -le 80 ] || fail "$misses deadline misses in 8 s, bound 10 %"
finish "mgc over UDP loopback"
