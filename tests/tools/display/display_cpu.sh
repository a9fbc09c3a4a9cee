#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The CPU cost of mgc-display (docs/operator-display.md, "Cost"): the display fed by display_feeder
# with one machine's whole feed (MGC_MACHINE_STATE at 100 Hz, guidance and words, a plan), a
# tracked obstacle at 10 Hz and the site's second machine (MGC_SITE_STATE at 20 Hz), one page
# attached (curl reading the 20 Hz Server-Sent Events), for SECONDS (at least 30). The display's
# CPU is utime + stime from /proc/PID/stat over the run. A measurement, not a test (ctest does not
# run it): it prints the figure, and exits 1 when it is above the target of 5 % of one core.
#   display_cpu.sh MGC_DISPLAY DISPLAY_FEEDER SOURCE_DIR [SECONDS]
set -u
display_bin="$1"
feeder_bin="$2"
src="$3"
seconds="${4:-30}"
if [ "$seconds" -lt 30 ]; then
  echo "display_cpu.sh: SECONDS $seconds; expected at least 30" >&2
  exit 2
fi
target_pct=5

tmp="$(mktemp -d)"
lcm_url="udpm://239.255.76.67:$((7900 + $$ % 500))?ttl=0"
port=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])')
scenario="$src/scenarios/thesis-steel-frame.yaml"
site="$src/scenarios/sites/thesis-steel-frame.yaml"

mkfifo "$tmp/feeder.in"
"$feeder_bin" "$lcm_url" "$tmp/sent.txt" <"$tmp/feeder.in" >"$tmp/feeder.out" &
feeder_pid=$!
exec 3>"$tmp/feeder.in"
"$display_bin" --port "$port" --lcm-url "$lcm_url" --scenario "$scenario" --site "$site" --machine-id 1 --site-lcm-url "$lcm_url" >"$tmp/display.out" 2>&1 &
display_pid=$!
cleanup() {
  [ -n "${curl_pid:-}" ] && kill "$curl_pid" 2>/dev/null
  kill "$display_pid" 2>/dev/null
  printf 'quit\n' >&3
  exec 3>&-
  wait 2>/dev/null
  rm -rf "$tmp"
}
trap cleanup EXIT

{
  printf 'state 4 72 0.5 0.9 30 20\n'
  printf 'stream 10\n'
  printf 'plan 0.5,0.9,30,20;1.2,0.9,30,20;1.2,1.0,30,20;1.2,1.0,30,10\n'
  printf 'guidance 0 1.2 0.7 1 3\n'
  printf 'instruction 7.5 swing left 40 deg, then boom up 4 deg\n'
  printf 'obstacle 0 1 0 -30 -6 -90 1.25 4.2\n'
  printf 'site 2 1 2.5 20 20\n'
} >&3
sleep 1
curl -sN "http://127.0.0.1:$port/api/events" >"$tmp/events.txt" &
curl_pid=$!
sleep 2  # the page attached, the first pushes made

ticks() { awk '{print $14 + $15}' "/proc/$display_pid/stat"; }
hz=$(getconf CLK_TCK)
pushes_before=$(grep -c '^data: ' "$tmp/events.txt")
t0=$(date +%s.%N)
c0=$(ticks)
sleep "$seconds"
c1=$(ticks)
t1=$(date +%s.%N)
pushes_after=$(grep -c '^data: ' "$tmp/events.txt")
last=$(grep '^data: ' "$tmp/events.txt" | tail -1)

wall=$(echo "$t1 - $t0" | bc -l)
cpu_pct=$(echo "100 * ($c1 - $c0) / $hz / $wall" | bc -l)
push_hz=$(echo "($pushes_after - $pushes_before) / $wall" | bc -l)
# The pushed state must carry the three sources, or the figure measures less than it claims.
for part in '"state":{' '"obstacles":{"age_s"' '"joints":[2.5,20,20]'; do
  case "$last" in
    *"$part"*) ;;
    *) echo "display_cpu.sh: the last pushed state lacks $part: the display did not get every feed" >&2; exit 1 ;;
  esac
done
printf 'mgc-display CPU: %.2f %% of one core over %.1f s (%d ticks at %d Hz); %.1f pushes/s of %d bytes; load average %s\n' \
  "$cpu_pct" "$wall" $((c1 - c0)) "$hz" "$push_hz" "${#last}" "$(cut -d' ' -f1 /proc/loadavg)"
if [ "$(echo "$cpu_pct < $target_pct" | bc -l)" -ne 1 ]; then
  echo "above the target of $target_pct % of one core" >&2
  exit 1
fi
exit 0
