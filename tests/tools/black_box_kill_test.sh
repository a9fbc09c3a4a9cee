#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The black box of a real process: mgc with --black-box against mgc-sim over UDP on loopback, killed
# with SIGKILL a few seconds into the lift; mgc-replay on what it left replays identically up to the
# kill, and the cycles lost with the kill span less than a second (and, sampled while mgc runs, the
# ring is never more than a second behind). Then the bad-input contract: not
# a recording, and a corrupt record in the middle named by its offset (exit 2, one line).
#   black_box_kill_test.sh MGC MGC_SIM MGC_REPLAY SOURCE_DIR
set -u
mgc="$1"
sim="$2"
replay="$3"
root="$4"
cli="$replay"
tools="$mgc $sim"
source "$root/tests/tools/cli_support.sh"
scenario="$root/scenarios/thesis-steel-frame.yaml"

base=$(test_ports black_box_kill 2)
sim_port=$base
mgc_port=$((base + 1))

# As on a cab computer, and as the demo runs them: both loops on two threads, so that a CPU taken
# away for a moment does not stall the bus, and real-time scheduling where the OS permits it, so
# that other tests' processes do not delay the loops past the 30 ms staleness limit.
rt=()
rt_mgc=()
if chrt -f 10 true 2>/dev/null; then
  rt=(chrt -f 40)
  rt_mgc=(--fifo-priority 50)
fi

# run_and_kill: mgc-sim and mgc with --black-box, the live ring read, mgc killed. Leaves
# $tmp/run.mgcbb, live.out, mgc.out and sim.out, the live reading's exit code in $live_rc and
# mgc's in $code.
run_and_kill() {
  rm -f "$tmp/run.mgcbb"
  "${rt[@]}" "$sim" --scenario "$scenario" --bus "udp:127.0.0.1:$sim_port,peer=127.0.0.1:$mgc_port" --duration 20 --quiet \
    --loop-threads 2 >"$tmp/sim.out" 2>&1 &
  sim_pid=$!
  sleep 0.3
  "$mgc" --scenario "$scenario" --bus "udp:127.0.0.1:$mgc_port,peer=127.0.0.1:$sim_port" --lcm-url memq:// --goal-on-start \
    --duration 20 --loop-threads 2 "${rt_mgc[@]}" --black-box "$tmp/run.mgcbb" >"$tmp/mgc.out" 2>&1 &
  mgc_pid=$!
  # The ring while mgc writes it, read every 0.1 s (mgc-replay --summary) for at least 3 s and at
  # least 10 reads, however long one read takes (under a sanitizer, a few tenths of a second), but
  # no longer than 12 s, well before mgc's 20 s end: its last cycle is never a second old. A
  # recorder that wrote only whole blocks (some 1.5 s of the lift each) would fall more than a
  # second behind for a third of the time.
  sleep 1.5
  python3 - "$replay" "$tmp/run.mgcbb" "$mgc_pid" >"$tmp/live.out" <<'PY'
import os, re, signal, subprocess, sys, time
worst_us, samples = -10**9, 0
start = time.monotonic()
while (samples < 10 or time.monotonic() < start + 3.0) and time.monotonic() < start + 12.0:
    now_us = time.monotonic_ns() // 1000
    out = subprocess.run([sys.argv[1], sys.argv[2], "--summary"], capture_output=True, text=True)
    m = re.search(r"recorded cycle times -?\d+ \.\. (-?\d+) us", out.stdout)
    if out.returncode != 0 or not m:
        print(f"exit {out.returncode}: {out.stdout}{out.stderr}")
        sys.exit(1)
    worst_us = max(worst_us, now_us - int(m.group(1)))
    samples += 1
    time.sleep(0.1)
# The kill, between two readings of the clock mgc records on (CLOCK_MONOTONIC), from this running
# process: a shell that started a program to read the clock would add its start-up, a second and
# more on a loaded machine, to the loss measured.
before_us = time.monotonic_ns() // 1000
os.kill(int(sys.argv[3]), signal.SIGKILL)
after_us = time.monotonic_ns() // 1000
print(f"{samples} {worst_us} {before_us} {after_us}")
PY
  live_rc=$?
  wait "$mgc_pid" 2>/dev/null
  code=$?
  kill "$sim_pid" 2>/dev/null
  wait "$sim_pid" 2>/dev/null
}

# A stall of this host beyond the 30 ms staleness limit (or mgc's loop watchdog) faults the lift,
# as designed: a shared virtual machine stalls every process at once for 70-150 ms now and then,
# which real-time scheduling does not prevent. A run that faulted at such a stall, seen in the
# simulator's longest loop gap or as a watchdog trip among the replayed transitions, is run again
# (twice at most); every check applies to the run judged, and a fault without a stall fails.
stalled() {
  local gap_ms
  gap_ms=$(sed -nE 's/^mgc-sim: timing: .*longest gap between two ([0-9]+)\.[0-9]+ ms.*/\1/p' "$tmp/sim.out")
  "$replay" "$tmp/run.mgcbb" >"$tmp/stall.out" 2>&1
  grep -q -- '-> FAULT' "$tmp/stall.out" || return 1
  [ "${gap_ms:-0}" -ge 30 ] && return 0
  grep -q -- '-> FAULT .*WatchdogTripped' "$tmp/stall.out"
}

for attempt in 1 2 3; do
  run_and_kill
  { [ "$live_rc" -eq 0 ] && [ "$code" -eq 137 ] && stalled; } || break
  echo "note: attempt $attempt faulted at a stall of this machine; run again:"
  grep -hE -- '-> |^mgc-sim: timing:' "$tmp/stall.out" "$tmp/sim.out"
done
[ "$live_rc" -eq 0 ] || fail "reading the live ring: $(cat "$tmp/live.out")"
read -r samples worst_lag_us kill_before_us kill_us <"$tmp/live.out"
echo "live: $samples samples, the ring's last cycle at most $worst_lag_us us old"
[ "${samples:-0}" -ge 10 ] || fail "$samples samples of the live ring in 12 s, expected at least 10"
[ "${worst_lag_us:-9999999}" -lt 1000000 ] || fail "the live ring fell $worst_lag_us us behind, expected under 1 s"
[ "$code" -eq 137 ] || fail "mgc exited $code, expected 137 (killed): $(cat "$tmp/mgc.out")"
grep -E '^mgc-sim: timing:' "$tmp/sim.out"

"$replay" "$tmp/run.mgcbb" >"$tmp/replay.out" 2>"$tmp/replay.err"
rc=$?
cat "$tmp/replay.out" "$tmp/replay.err"
[ "$rc" -eq 0 ] || fail "mgc-replay exited $rc, expected 0 (identical)"
line=$(grep -E '^mgc-replay: identical for [0-9]+ cycles' "$tmp/replay.out")
[ -n "$line" ] || fail "no 'identical for N cycles'"
read -r cycles transitions <<<"$(sed -E 's/^mgc-replay: identical for ([0-9]+) cycles \([0-9]+ frames, ([0-9]+) supervisor transitions\)/\1 \2/' <<<"$line")"
# Some 4.5 s at 100 Hz before the kill; the lift started (INIT -> HOLD -> PLANNING -> EXECUTING).
[ "${cycles:-0}" -ge 300 ] || fail "$cycles cycles replayed, expected at least 300"
[ "${transitions:-0}" -ge 3 ] || fail "$transitions supervisor transitions, expected the lift to start"
grep -q 'ends without its end record' "$tmp/replay.out" || fail "the kill was not reported"
last_us=$(sed -nE 's/.*recorded cycle times [0-9-]+ \.\. ([0-9-]+) us$/\1/p' "$tmp/replay.out")
lost_us=$((kill_us - ${last_us:-0}))
echo "parsed: cycles=$cycles transitions=$transitions kill_us=$kill_before_us..$kill_us last_recorded_us=$last_us lost_us=$lost_us"
[ "$lost_us" -ge 0 ] && [ "$lost_us" -lt 1000000 ] || fail "the recording ends $lost_us us before the kill, expected under 1 s"

# The transitions read off the recording alone (--summary) are the replayed ones.
"$replay" "$tmp/run.mgcbb" --summary >"$tmp/summary.out" 2>&1
sed -nE 's/^mgc-replay: recorded +([0-9]+\.[0-9]+ s .*) \(cycle [0-9]+\)$/\1/p' "$tmp/summary.out" | tr -s ' ' >"$tmp/recorded.txt"
sed -nE 's/^mgc-replay: +([0-9]+\.[0-9]+ s .*)$/\1/p' "$tmp/replay.out" | tr -s ' ' >"$tmp/replayed.txt"
[ -s "$tmp/recorded.txt" ] && cmp -s "$tmp/recorded.txt" "$tmp/replayed.txt" ||
  fail "the recorded transitions differ from the replayed: $(cat "$tmp/recorded.txt") / $(cat "$tmp/replayed.txt")"

expect_bad "not a recording" "^mgc-replay: .*scenario.*\(offset 0\): magic .*not a black box recording$" "$scenario"
python3 - "$tmp/run.mgcbb" "$tmp/corrupt.mgcbb" <<'PY'
import sys
data = bytearray(open(sys.argv[1], "rb").read())
data[4096 + 32 + 1000] ^= 0x40  # a byte inside the first block's records
open(sys.argv[2], "wb").write(data)
PY
expect_bad "a corrupt record in the middle" "^mgc-replay: .*corrupt\.mgcbb \(offset [0-9]+\): record CRC mismatch in the middle" "$tmp/corrupt.mgcbb"
# The scenario changed since the recording: a copy with one more line, beside the same machines.
mkdir -p "$tmp/site"
cp "$scenario" "$tmp/site/thesis-steel-frame.yaml"
echo "# edited" >>"$tmp/site/thesis-steel-frame.yaml"
ln -s "$root/scenarios/machines" "$tmp/site/machines"
expect_bad "an edited scenario" "^mgc-replay: .*run\.mgcbb: scenario .*site/thesis-steel-frame\.yaml \(hash [0-9a-f]+, .*changed since the recording$" \
  "$tmp/run.mgcbb" --scenario "$tmp/site/thesis-steel-frame.yaml"
finish "the black box of a killed mgc"
