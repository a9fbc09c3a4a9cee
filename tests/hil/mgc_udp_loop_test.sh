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

base=$(test_ports mgc_udp_loop 2)
sim_port=$base
mgc_port=$((base + 1))

# One run: mgc-sim and mgc for 8 s, mgc with the arguments given; mgc's output in $tmp/mgc.out,
# mgc-sim's in $tmp/sim.out.
run_once() {
  "$sim" --scenario "$scenario" --bus "udp:127.0.0.1:$sim_port,peer=127.0.0.1:$mgc_port" --duration 12 --quiet \
    >"$tmp/sim.out" 2>&1 &
  sim_pid=$!
  sleep 0.3
  "$mgc" --scenario "$scenario" --bus "udp:127.0.0.1:$mgc_port,peer=127.0.0.1:$sim_port" --lcm-url memq:// \
    --goal-on-start --duration 8 "$@" >"$tmp/mgc.out" 2>&1
  code=$?
  kill "$sim_pid" 2>/dev/null
  wait "$sim_pid" 2>/dev/null
}

# A stall of either process beyond the 30 ms stale limit (or of mgc beyond the valve's 50 ms
# command timeout) faults the lift, as designed; on a shared VM that stalls a real-time thread for
# 30-150 ms now and then it can do so before the crane moves. Such a run (a FAULT with mgc's
# wake-up lateness or mgc-sim's longest loop gap at 30 ms or more) is run again, at most twice;
# a run that faults without a stall fails at once.
stalled() {
  grep -q -- '-> FAULT' "$tmp/mgc.out" || return 1
  local late_us gap_ms
  late_us=$(sed -nE 's/^mgc: loop: .*wake-up lateness p99 [0-9]+ us max ([0-9]+) us.*/\1/p' "$tmp/mgc.out")
  gap_ms=$(sed -nE 's/^mgc-sim: timing: .*longest gap between two ([0-9]+)\.[0-9]+ ms.*/\1/p' "$tmp/sim.out")
  [ "${late_us:-0}" -ge 30000 ] || [ "${gap_ms:-0}" -ge 30 ]
}
# The run, with mgc's arguments, and its checks.
run_and_check() {
  for attempt in 1 2 3; do
    run_once "$@"
    stalled || break
    echo "note: attempt $attempt faulted at a stall of this machine:"
    grep -E '^mgc: loop:|-> FAULT' "$tmp/mgc.out"
    grep -E '^mgc-sim: timing:' "$tmp/sim.out"
  done

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
}

run_and_check
# With the standby loop thread (docs/control-loop.md): the same lift and bounds, and the summary
# says how many cycles the standby ran.
run_and_check --loop-threads 2
grep -Eq '^mgc: loop: .*, [0-9]+ cycles run by the standby thread$' "$tmp/mgc.out" || fail "no standby count with --loop-threads 2"
finish "mgc over UDP loopback"
