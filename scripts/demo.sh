#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The main job: the controller at work. mgc-sim puts the Grove TMS870 of the thesis steel-frame
# site on a CAN bus (SocketCAN when a CAN interface is up, else UDP on loopback); mgc runs the
# control loop against it; an operator station (mgc-operator) requests the lift with a signed
# command and shows the guidance and alerts as they come over LCM, while the second crane swings
# its boom across the west route mid-way: the default planner turns the long way round the west
# side, the stop check stops the crane for crane 2, and the repair goes round it. At the end: mgc's transitions and summary (lift completed,
# duration, re-plans, stops, least clearance, alerts, loop timing), mgc-sim's truth line (the
# true crane's least clearance, measured by the simulator, not the controller), an SVG of what
# happened (build/demo/lift.svg), the LCM log (build/demo/mgc.lcmlog), the controller's trace and
# the true machine state (CSV). mgc-display serves the operator's screen during the lift (its URL
# is printed; MGC_DEMO_DISPLAY_PORT, default 8780), and a headless-Chromium picture of that screen
# at the end of the lift, played from the log, goes to build/demo/display.png.
# Then the coordinated site (docs/site.md; scripts/lib/site_demo.sh): the two cranes of
# scenarios/sites/crossing-cranes.yaml, the tower crane's lift crossing the TMS870's route, in one
# mgc-sim that simulates both, each on its own bus, and referees the true clearance between them;
# one mgc per machine, members of the site channel (signed with a site key); each lift requested
# with a signed command from the machine's own operator station (mgc-operator, its own key and
# feed). At the end: both mgc summaries' key lines and the simulator's truth lines, among them the
# least true clearance between the two machines; the outputs in build/demo/site/.
# Then, offline: every shipped scenario loaded, checked and planned (the default one-joint-at-a-time
# planner axis-connect; the two-crane lifts with multi-rrt; the excavator's work cycle with nonuniform), and the event
# scenarios executed with re-planning (mgc-bench's replan suite, two seeds). Installs missing
# Debian packages. MGC_DEMO_PART=site runs only the coordinated site (after the build).
# Exits non-zero when a step fails: a lift not completed, a true contact between the site's
# machines, a scenario that does not plan.
set -euo pipefail
source "$(dirname "$0")/lib/common.sh"
mgc_install_packages
mgc_build mgc mgc-operator mgc-plan mgc-sim mgc-bench mgc-display
bin="$MGC_BUILD_DIR/bin"
out="$MGC_BUILD_DIR/demo"
mkdir -p "$out"
status=0
source "$MGC_ROOT/scripts/lib/site_demo.sh"
case "${MGC_DEMO_PART:-all}" in
  all) ;;
  site) site_demo; exit ;;
  *) echo "demo: MGC_DEMO_PART must be all or site, not '$MGC_DEMO_PART'" >&2; exit 2 ;;
esac

site="$MGC_ROOT/scenarios/thesis-steel-frame.yaml"
# The default transport: SocketCAN when a CAN interface is up (a vcan; on a real bus the machine's
# own nodes must not be on it, since mgc-sim plays them), else UDP on loopback. MGC_DEMO_BUS=udp
# keeps UDP even then.
can_if=""
[ "${MGC_DEMO_BUS:-}" = udp ] || can_if="$(mgc_can_interface)"
sim_bus=()
mgc_bus=()
transport="UDP on loopback"
if [ -n "$can_if" ]; then
  sim_bus=(--bus "socketcan:$can_if")
  mgc_bus=(--bus "socketcan:$can_if")
  transport="SocketCAN on $can_if"
fi
lcm_url="udpm://239.255.76.67:7667?ttl=0"
key="$out/operator.key"
(umask 077 && head -c 32 /dev/urandom >"$key")
# Real-time scheduling where the OS permits it (root on a normal kernel): a stalled controller
# lets the valve node time out after 50 ms and neutralise, as it must. mgc-sim plays the devices,
# which answer each SYNC at once, so it locks its memory too: on a first run neither end may wait
# for a page to be read or allocated during the lift. And it runs its loop on two threads, one per
# CPU: on a shared virtual machine one CPU at a time is taken away for up to 100 ms (a vCPU the
# hypervisor deschedules, a CPU held by another process's kernel work), and the thread on the
# other answers meanwhile (docs/simulator.md, "Real time"). mgc does the same with a standby loop
# thread (--loop-threads 2, docs/control-loop.md): its valve commands must not stop for 50 ms.
sim_threads=(--loop-threads 2)
sim_rt=()
sim_lock=()
mgc_rt=()
if chrt -f 1 true 2>/dev/null; then
  sim_rt=(chrt -f 40)
  sim_lock=(--mlock)
  mgc_rt=(--fifo-priority 50 --mlock)
fi
echo "=== the lift on the thesis steel-frame site: mgc-sim ($transport) + mgc + mgc-operator over LCM"
echo "    crane 2 swings its boom across the west route 20-44 s into the lift (mgc-sim --scenario-time-offset 40)"
# CPU time the hypervisor took from this machine during the lift: on a shared virtual machine a
# controller that wakes 50 ms late faults the valve node, as it must, and this says why.
cpu_times() { awk '/^cpu /{print $9, $2+$3+$4+$5+$6+$7+$8+$9}' /proc/stat 2>/dev/null; }
read -r steal_before total_before < <(cpu_times || echo "0 0")
lcm-logger -q -f --lcm-url="$lcm_url" "$out/mgc.lcmlog" &
logger_pid=$!
# The operator's screen beside the lift (docs/operator-display.md); a busy port costs only the screen.
"$bin/mgc-display" --scenario "$site" --key "$key" --lcm-url "$lcm_url" --port "${MGC_DEMO_DISPLAY_PORT:-8780}" \
  >"$out/display.txt" 2>&1 &
display_pid=$!
for _ in $(seq 100); do
  grep -q '^mgc-display: http' "$out/display.txt" && break
  kill -0 "$display_pid" 2>/dev/null || break
  sleep 0.1
done
if grep -q '^mgc-display: http' "$out/display.txt"; then
  echo "    watch it live: $(head -1 "$out/display.txt" | sed 's/^mgc-display: \([^ ]*\).*/\1/')"
else
  echo "    no live display: $(head -1 "$out/display.txt")"
fi
"${sim_rt[@]}" "$bin/mgc-sim" --scenario "$site" "${sim_bus[@]}" --scenario-time-offset 40 --duration 620 --quiet \
  "${sim_threads[@]}" "${sim_lock[@]}" --truth-csv "$out/truth.csv" >"$out/sim.txt" &
sim_pid=$!
"$bin/mgc" --scenario "$site" "${mgc_bus[@]}" --key "$key" --lcm-url "$lcm_url" --exit-when-done --duration 600 \
  --trace-csv "$out/trace.csv" --black-box "$out/mgc.blackbox" --loop-threads 2 "${mgc_rt[@]}" >"$out/mgc.txt" 2>&1 &
mgc_pid=$!
"$bin/mgc-operator" --key "$key" --lcm-url "$lcm_url" --scenario "$site" --goal --watch 600 --until-done || status=$?
mgc_status=0
wait "$mgc_pid" || mgc_status=$?
kill "$sim_pid" "$logger_pid" "$display_pid" 2>/dev/null || true
wait "$sim_pid" "$logger_pid" "$display_pid" 2>/dev/null || true
cat "$out/mgc.txt"
cat "$out/sim.txt"
read -r steal_after total_after < <(cpu_times || echo "0 0")
if [ "${steal_after:-0}" -eq 0 ]; then
  # A counter that never moved since boot is one the hypervisor does not keep: 0 % would mislead.
  echo "host: the hypervisor reports no steal time on this machine (mgc-sim's timing line shows the stalls it saw)"
elif [ "${total_after:-0}" -gt "${total_before:-0}" ]; then
  echo "host: $(( 100 * (steal_after - steal_before) / (total_after - total_before) )) % of this machine's CPU time" \
    "taken by the hypervisor during the lift (steal)"
fi
[ "$mgc_status" -eq 0 ] || status=$mgc_status
"$bin/mgc-plan" --scenario "$site" --trace "$out/trace.csv" --svg "$out/lift.svg" || status=$?
echo "what happened: build/demo/lift.svg; LCM log: build/demo/mgc.lcmlog ($(wc -c <"$out/mgc.lcmlog") bytes);"
echo "controller trace: build/demo/trace.csv; true machine state: build/demo/truth.csv"
# The operator's screen at the end of the lift, played from the log in headless Chromium.
python=/usr/bin/python3
[ -x "$python" ] || python=python3
if "$python" "$MGC_ROOT/scripts/lib/display_screenshot.py" "$bin/mgc-display" "$site" "$out/mgc.lcmlog" "$out/display.png"; then
  echo "operator display at the end of the lift: build/demo/display.png"
fi
echo

site_demo || status=$?
echo

for scenario in "$MGC_ROOT"/scenarios/*.yaml; do
  rel="${scenario#"$MGC_ROOT"/}"
  name="$(basename "$scenario" .yaml)"
  echo "=== mgc-plan --scenario $rel --check"
  "$bin/mgc-plan" --scenario "$scenario" --check || status=$?
  # Two cranes on one girder move their joints together: one joint at a time would tip the
  # suspension, so those lifts take seed 004's multi-rrt. The rest take the default planner.
  planner=()
  if grep -q '^dual_crane:' "$scenario"; then planner=(--planner multi-rrt); fi
  echo "=== mgc-plan --scenario $rel ${planner[*]} --json build/demo/$name.json"
  "$bin/mgc-plan" --scenario "$scenario" "${planner[@]}" --json "$out/$name.json" || status=$?
  if grep -q '^work_cycle:' "$scenario"; then
    echo "=== mgc-plan --scenario $rel --planner nonuniform --cycle --json build/demo/$name-cycle.json"
    "$bin/mgc-plan" --scenario "$scenario" --planner nonuniform --cycle --json "$out/$name-cycle.json" || status=$?
  fi
  echo
done

echo "=== mgc-bench --suite replan --runs 2: the lifts executed while crane 2, tower crane 2 and truck 2 move in"
(cd "$MGC_ROOT" && "$bin/mgc-bench" --suite replan --runs 2 --out "$out/replan") || status=$?
echo

exit "$status"
