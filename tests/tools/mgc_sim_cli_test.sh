#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# mgc-sim as a process: bad input exits 2 with one line naming what is wrong; a real-time run over
# UDP on loopback answers a Hal client (mgc-busmon), writes the truth log with the truth monitor's
# columns and prints the monitor's line; an injected fault shows at the client; --monitor-period-ms 0
# turns the monitor off.
set -u
sim="$1"
busmon="$2"
root="$3"
cli="$sim"
source "$(dirname "$0")/cli_support.sh"
scenario="$root/scenarios/thesis-steel-frame.yaml"


"$sim" --help >/dev/null || fail "--help exits non-zero"
expect_bad "unknown fault" 'fault "encoder-melt:swing": unknown kind' --scenario "$scenario" --fault encoder-melt:swing --duration 1
expect_bad "fault on an unknown joint" 'unknown target "jib"' --scenario "$scenario" --fault encoder-stuck:jib --duration 1
expect_bad "no loop thread" '^mgc-sim: --loop-threads: .*0' --scenario "$scenario" --loop-threads 0 --duration 1
expect_bad "bad bus URL" '^mgc-sim: --bus: .*nowhere:1' --scenario "$scenario" --bus nowhere:1 --duration 1
expect_bad "missing scenario" 'does-not-exist.yaml' --scenario "$tmp/does-not-exist.yaml" --duration 1
sed "s|^machine: machines/|machine: $root/scenarios/machines/|" "$scenario" >"$tmp/bad-sim.yaml"
printf 'simulation:\n  uwb_rate_hz: 500\n' >>"$tmp/bad-sim.yaml"
expect_bad "simulation section out of range" "^$tmp/bad-sim.yaml:[0-9]+: simulation.uwb_rate_hz: expected a number in" \
  --scenario "$tmp/bad-sim.yaml" --duration 1
sed "s|^machine: machines/|machine: $root/scenarios/machines/|" "$scenario" >"$tmp/bad-fault.yaml"
printf 'simulation:\n  faults: [bus-off@soon]\n' >>"$tmp/bad-fault.yaml"
expect_bad "scenario fault that does not parse" "^$tmp/bad-fault.yaml:[0-9]+: simulation.faults\[0\]: fault \"bus-off@soon\": start time" \
  --scenario "$tmp/bad-fault.yaml" --duration 1

# Runs on loopback ports of their own: three pairs, then one pair again and again.
base=$(test_ports mgc_sim_cli 8)
run_pair() {  # run_pair <name> <busmon exit expected> <mgc-sim extra args...>
  local name="$1" want="$2"
  shift 2
  local sim_port=$base client_port=$((base + 1))
  base=$((base + 2))
  "$sim" --scenario "$scenario" --bus "udp:127.0.0.1:$sim_port,peer=127.0.0.1:$client_port" --duration 3.5 \
    --truth-csv "$tmp/$name.csv" "$@" >"$tmp/$name.sim" 2>&1 &
  local pid=$!
  sleep 0.3
  "$busmon" --scenario "$scenario" --bus "udp:127.0.0.1:$client_port,peer=127.0.0.1:$sim_port" --start \
    --duration 2.5 --require-valid >"$tmp/$name.out" 2>&1
  local code=$?
  wait "$pid" || fail "$name: mgc-sim exited $?: $(cat "$tmp/$name.sim")"
  [ "$code" -eq "$want" ] || fail "$name: mgc-busmon exit $code, expected $want: $(tail -12 "$tmp/$name.out")"
}

run_pair healthy 0
grep -q 'joint boom_length  *20.0000 m   alive' "$tmp/healthy.out" || fail "healthy: boom length not read as 20 m: $(tail -12 "$tmp/healthy.out")"
grep -Eq 'tag +1 .* valid' "$tmp/healthy.out" || fail "healthy: tag 1 not valid"
grep -q 'malformed=0 unknown=0' "$tmp/healthy.out" || fail "healthy: malformed or unknown frames"
head -1 "$tmp/healthy.csv" | grep -q '^t_s,swing_deg,swing_velocity_deg_s,swing_spool,.*,valve_state,valve_reason,crane-2_x_m,crane-2_y_m,crane-2_z_m,crane-2_yaw_deg,clearance_m,moving_clearance_m,dynamic_clearance_m,load_ground_m,hook_ground_m,chart_utilisation$' ||
  fail "truth CSV header: $(head -1 "$tmp/healthy.csv")"
rows=$(($(wc -l <"$tmp/healthy.csv") - 1))
[ "$rows" -ge 300 ] && [ "$rows" -le 360 ] || fail "truth CSV: $rows rows for 3.5 s at 10 ms"
grep -q 'stopped at 3.5' "$tmp/healthy.sim" || fail "no summary: $(cat "$tmp/healthy.sim")"
grep -q ' 0 malformed, 0 unknown ids' "$tmp/healthy.sim" || fail "mgc-sim saw malformed frames: $(cat "$tmp/healthy.sim")"
# The crane stands at its start: its carrier 1.30 m from the frame, crane 2 parked 24.2 m away, the
# load 0.50 m above the ground, the chart at 20,000 lb / 24,650 lb.
grep -Eq '^mgc-sim: truth: least clearance 1\.30 m at 0\.00 s \(carrier to frame/.*to the dynamic obstacles 24\.20 m .* 0 of (6[0-9]|7[0-9]) samples below 0\.50 m; ground: least clearance 0\.50 m at 0\.00 s \(load bottom\), of the hook 3\.50 m at 0\.00 s, 0 samples below; load chart: peak utilisation 81\.1 % at 0\.00 s \(boom 20\.00 m at 50\.0 deg\), 0 samples above 100 %, 0 outside the chart$' \
  "$tmp/healthy.sim" || fail "no truth line, or not the start's clearance: $(cat "$tmp/healthy.sim")"
tail -1 "$tmp/healthy.csv" | grep -Eq ',1\.3000,6\.5[0-9]+,24\.20[0-9]+,0\.50[0-9]+,3\.50[0-9]+,0\.811[0-9]+$' || fail "truth CSV clearance columns: $(tail -1 "$tmp/healthy.csv")"
grep -Eq '^mgc-sim: timing: [0-9]+ loop iterations, longest gap between two [0-9.]+ ms at [0-9.]+ s, [0-9]+ gaps over the 10 ms SYNC period, [0-9]+ over the 30 ms staleness limit, wake-up lateness max [0-9.]+ ms; [0-9]+ major and [0-9]+ minor page faults in the loop; step max [0-9.]+ ms at [0-9.]+ s; truth sample max [0-9.]+ ms at [0-9.]+ s \(the first, before the nodes boot, [0-9.]+ ms\); truth log row max [0-9.]+ ms; memory (locked|not locked)$' \
  "$tmp/healthy.sim" || fail "no timing line: $(cat "$tmp/healthy.sim")"

run_pair dropout 1 --fault encoder-dropout:cable_length@1 --monitor-period-ms 0
grep -q 'joint cable_length .* stale' "$tmp/dropout.out" || fail "dropout: cable_length not stale: $(tail -12 "$tmp/dropout.out")"
grep -q 'joint swing .* alive' "$tmp/dropout.out" || fail "dropout: swing should stay alive"
grep -q 'truth:' "$tmp/dropout.sim" && fail "--monitor-period-ms 0 still printed the truth line"
head -1 "$tmp/dropout.csv" | grep -q 'crane-2_yaw_deg$' || fail "--monitor-period-ms 0 still wrote clearance columns"

# --mlock runs whether or not the OS grants it; the timing line says which.
"$sim" --scenario "$scenario" --bus "udp:127.0.0.1:$base,peer=127.0.0.1:$((base + 1))" --duration 0.5 --mlock --quiet \
  >"$tmp/mlock.sim" 2>&1 || fail "--mlock: exit $?: $(cat "$tmp/mlock.sim")"
grep -Eq '^mgc-sim: timing: .*; memory (locked|not locked)$' "$tmp/mlock.sim" || fail "--mlock: $(cat "$tmp/mlock.sim")"
# --loop-threads 2: on a machine of two CPUs or more, a thread on each of two, each with its figures.
"$sim" --scenario "$scenario" --bus "udp:127.0.0.1:$base,peer=127.0.0.1:$((base + 1))" --duration 0.5 --loop-threads 2 --quiet \
  >"$tmp/threads.sim" 2>&1 || fail "--loop-threads 2: exit $?: $(cat "$tmp/threads.sim")"
if [ "$(nproc)" -ge 2 ]; then
  grep -Eq '^mgc-sim: timing: .*wake-up lateness max [0-9.]+ ms \(2 threads: on CPU [0-9]+ [0-9]+ iterations, lateness max [0-9.]+ ms, [0-9]+ wake-ups over the SYNC period, lock wait max [0-9.]+ ms, lock held [0-9.]+ % of the run \(max [0-9.]+ ms\); on CPU [0-9]+ [0-9]+ iterations, .*\); [0-9]+ major' \
    "$tmp/threads.sim" || fail "--loop-threads 2: $(cat "$tmp/threads.sim")"
fi
# A truth log that cannot be written to the end: exit 1, naming the file and the reason.
"$sim" --scenario "$scenario" --bus "udp:127.0.0.1:$base,peer=127.0.0.1:$((base + 1))" --duration 0.5 --quiet \
  --truth-csv /dev/full >"$tmp/full.sim" 2>&1
code=$?
[ "$code" -eq 1 ] || fail "truth log on /dev/full: exit $code, expected 1: $(cat "$tmp/full.sim")"
grep -q '^mgc-sim: cannot write the truth log /dev/full: No space left on device$' "$tmp/full.sim" ||
  fail "truth log on /dev/full: $(cat "$tmp/full.sim")"

finish "mgc-sim CLI"
