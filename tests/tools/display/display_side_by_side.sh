#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# mgc's cycle compute with and without the operator display attached (docs/operator-display.md,
# "Cost"): the thesis lift (mgc-sim + mgc over UDP on loopback, the goal requested by mgc-operator,
# real-time scheduling as in the demo where the OS permits it) for SECONDS of each run, ROUNDS times
# each way, alternating (without, with, without, ...), so that a change in the machine's load falls
# on both. "With": mgc-display on mgc's feed, one page attached (curl reading its 20 Hz
# Server-Sent Events). Each run's figures are mgc's own loop summary (compute p99 and max of its
# cycles, wake-up lateness p99). A measurement, not a test (ctest does not run it): it prints each
# run and the medians of both sides.
#   display_side_by_side.sh BIN_DIR SOURCE_DIR [SECONDS [ROUNDS]]
set -u
bin="$1"
src="$2"
seconds="${3:-40}"
rounds="${4:-3}"
if ! [ "$seconds" -ge 20 ] 2>/dev/null || ! [ "$rounds" -ge 1 ] 2>/dev/null; then
  echo "display_side_by_side.sh: SECONDS $seconds and ROUNDS $rounds; expected at least 20 and 1" >&2
  exit 2
fi
for tool in mgc mgc-sim mgc-operator mgc-display; do
  if [ ! -x "$bin/$tool" ]; then
    echo "display_side_by_side.sh: $bin/$tool: not found; build it first" >&2
    exit 2
  fi
done

tmp="$(mktemp -d)"
trap 'kill $(jobs -p) 2>/dev/null; wait 2>/dev/null; rm -rf "$tmp"' EXIT
site="$src/scenarios/thesis-steel-frame.yaml"
key="$tmp/operator.key"
(umask 077 && head -c 32 /dev/urandom >"$key")
sim_rt=()
sim_lock=()
mgc_rt=()
if chrt -f 1 true 2>/dev/null; then
  sim_rt=(chrt -f 40)
  sim_lock=(--mlock)
  mgc_rt=(--fifo-priority 50 --mlock)
fi

# One run: prints "compute_p99_us compute_max_us lateness_p99_us".
run() {
  local with_display="$1" n="$2"
  local lcm_url="udpm://239.255.76.67:$((7700 + n))?ttl=0"
  local display_pid="" curl_pid=""
  if [ "$with_display" = 1 ]; then
    local port
    port=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])')
    "$bin/mgc-display" --scenario "$site" --key "$key" --lcm-url "$lcm_url" --port "$port" >"$tmp/display$n.txt" 2>&1 &
    display_pid=$!
    for _ in $(seq 100); do
      grep -q '^mgc-display: http' "$tmp/display$n.txt" && break
      sleep 0.1
    done
    curl -sN "http://127.0.0.1:$port/api/events" >"$tmp/events$n.txt" &
    curl_pid=$!
  fi
  "${sim_rt[@]}" "$bin/mgc-sim" --scenario "$site" --scenario-time-offset 40 --duration $((seconds + 10)) --quiet \
    --loop-threads 2 "${sim_lock[@]}" >"$tmp/sim$n.txt" 2>&1 &
  local sim_pid=$!
  "$bin/mgc" --scenario "$site" --key "$key" --lcm-url "$lcm_url" --duration "$seconds" --loop-threads 2 "${mgc_rt[@]}" \
    >"$tmp/mgc$n.txt" 2>&1 &
  local mgc_pid=$!
  "$bin/mgc-operator" --key "$key" --lcm-url "$lcm_url" --scenario "$site" --goal --watch 10 >/dev/null 2>&1 || true
  wait "$mgc_pid"
  kill "$sim_pid" $display_pid $curl_pid 2>/dev/null
  wait "$sim_pid" $display_pid $curl_pid 2>/dev/null
  if [ "$with_display" = 1 ] && ! grep -q '^data: ' "$tmp/events$n.txt"; then
    echo "display_side_by_side.sh: run $n: the page received no update from mgc-display" >&2
    exit 1
  fi
  local line
  line=$(grep '^mgc: loop:' "$tmp/mgc$n.txt")
  if [ -z "$line" ]; then
    echo "display_side_by_side.sh: run $n: no loop summary from mgc:" >&2
    cat "$tmp/mgc$n.txt" >&2
    exit 1
  fi
  echo "$line" | sed -E 's/.*compute p99 ([0-9]+) us max ([0-9]+) us, wake-up lateness p99 ([0-9]+) us.*/\1 \2 \3/'
}

median() { sort -n | awk '{a[NR]=$1} END {print (NR % 2) ? a[(NR + 1) / 2] : (a[NR / 2] + a[NR / 2 + 1]) / 2}'; }

echo "mgc's cycle with and without mgc-display attached: the thesis lift, ${seconds} s a run, $rounds rounds, load average $(cut -d' ' -f1-3 /proc/loadavg)"
: >"$tmp/without.txt"
: >"$tmp/with.txt"
n=0
for round in $(seq "$rounds"); do
  for side in 0 1; do
    n=$((n + 1))
    figures=$(run "$side" "$n") || exit 1
    name=$([ "$side" = 1 ] && echo with || echo without)
    echo "$figures" >>"$tmp/$name.txt"
    read -r p99 max late <<<"$figures"
    echo "round $round, $name the display: compute p99 $p99 us, max $max us, wake-up lateness p99 $late us"
  done
done
for name in without with; do
  echo "$name the display, medians over $rounds runs: compute p99 $(cut -d' ' -f1 "$tmp/$name.txt" | median) us," \
       "max $(cut -d' ' -f2 "$tmp/$name.txt" | median) us, wake-up lateness p99 $(cut -d' ' -f3 "$tmp/$name.txt" | median) us"
done
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
