# SPDX-License-Identifier: Apache-2.0
# The demo's coordinated site (scripts/demo.sh, docs/site.md): the two cranes of
# scenarios/sites/crossing-cranes.yaml on real processes. One mgc-sim simulates both machines,
# each on the UDP bus the site file gives it, and referees the true clearance between them; one mgc
# per machine drives it as a member of the site channel (LCM, signed with the site key); each lift
# is requested with a signed command from the machine's own operator station (mgc-operator, its
# own command key and feed). Sourced by demo.sh, which sets $bin and $out.
#
# site_demo: runs both lifts and prints the key lines; returns 1 when a lift did not complete or
# the simulator saw a true contact (between the machines, or a load below the ground).

site_demo() {
  local site="$MGC_ROOT/scenarios/sites/crossing-cranes.yaml"
  local dir="$out/site"
  local ids=(1 2)
  local result=0 id
  mkdir -p "$dir"
  rm -f "$dir"/*.txt
  (umask 077 && head -c 32 /dev/urandom >"$dir/site.key")
  for id in "${ids[@]}"; do
    (umask 077 && head -c 32 /dev/urandom >"$dir/operator-$id.key")
  done
  # The site channel on a group of its own; each machine's operator feed on its own port, apart
  # from the single lift's feed (7667).
  local site_url="udpm://239.255.76.68:7668?ttl=0"
  feed_url() { echo "udpm://239.255.76.67:$((7670 + $1))?ttl=0"; }

  # Real time where permitted, as for the single lift: the simulator under SCHED_FIFO 40 with its
  # loop on 2 threads, one per CPU, and each controller at 50 with a standby loop thread
  # (--loop-threads 2), so 6 real-time loop threads on this host's 2 shared vCPUs. Measured here
  # (3 runs each): with one loop thread per controller, controller wake-ups up to 9.9 ms late and
  # the simulator's longest gap 20-53 ms (one run with a valve fault at 7.6 s, beside a build);
  # with two, wake-ups up to 7.9 ms late (the standby threads ran 8-320 cycles), the simulator's
  # longest gap 11-34 ms: the standby threads did not hold up the simulator, and covered the
  # controllers' late wake-ups. MGC_DEMO_SITE_LOOP_THREADS=1 repeats the comparison.
  local sim_rt=() sim_lock=() mgc_rt=()
  if chrt -f 1 true 2>/dev/null; then
    sim_rt=(chrt -f 40)
    sim_lock=(--mlock)
    mgc_rt=(--fifo-priority 50 --mlock)
  fi
  local mgc_threads="${MGC_DEMO_SITE_LOOP_THREADS:-2}"

  echo "=== the coordinated site: crossing-cranes.yaml, the tower crane's lift (priority 1) across the TMS870's (priority 2)"
  echo "    one mgc-sim for both machines (UDP buses of the site file) + one mgc and one mgc-operator per machine"
  read -r steal_before total_before < <(site_cpu_times || echo "0 0")
  "${sim_rt[@]}" "$bin/mgc-sim" --site "$site" --duration 210 --quiet --loop-threads 2 "${sim_lock[@]}" \
    >"$dir/sim.txt" 2>&1 &
  local sim_pid=$!
  local mgc_pids=() op_pids=()
  for id in "${ids[@]}"; do
    "$bin/mgc" --site "$site" --machine-id "$id" --site-key "$dir/site.key" --site-lcm-url "$site_url" \
      --key "$dir/operator-$id.key" --lcm-url "$(feed_url "$id")" --duration 200 --loop-threads "$mgc_threads" \
      "${mgc_rt[@]}" >"$dir/mgc-$id.txt" 2>&1 &
    mgc_pids+=($!)
  done
  # Each machine's operator screen (docs/operator-display.md), read-only (no key: the operator
  # stations below send the commands): its own feed, the other machine drawn from the verified
  # site channel. A busy port costs only the screen.
  local display_pids=() port
  for id in "${ids[@]}"; do
    port=$(( ${MGC_DEMO_DISPLAY_PORT:-8780} + id ))
    "$bin/mgc-display" --site "$site" --machine-id "$id" --site-key "$dir/site.key" --site-lcm-url "$site_url" \
      --lcm-url "$(feed_url "$id")" --port "$port" >"$dir/display-$id.txt" 2>&1 &
    display_pids+=($!)
  done
  for id in "${ids[@]}"; do
    for _ in $(seq 50); do
      grep -q '^mgc-display: http' "$dir/display-$id.txt" && break
      sleep 0.1
    done
    if grep -q '^mgc-display: http' "$dir/display-$id.txt"; then
      echo "    machine $id's screen, live: $(head -1 "$dir/display-$id.txt" | sed 's/^mgc-display: \([^ ]*\).*/\1/')"
    else
      echo "    machine $id: no live screen: $(head -1 "$dir/display-$id.txt")"
    fi
  done
  # Each operator station requests its machine's lift once the controller is in HOLD and watches
  # it to its end, for at most 180 s (the TMS870's lift takes 83-88 s when it completes; one whose
  # repair went the long way, docs/site.md "Limits", took 4 minutes and more): the tower crane's
  # (priority 1) first, the TMS870's 2 s later, when the tower crane's plan is on the site channel,
  # so that it plans round it from the start instead of stopping for a machine not yet heard. A
  # member stays on the site channel after its own lift: a machine that goes silent is posed by its
  # frozen pose, grown with its speed bound, and would stop the other.
  for id in 2 1; do
    "$bin/mgc-operator" --key "$dir/operator-$id.key" --lcm-url "$(feed_url "$id")" --site "$site" --machine-id "$id" \
      --goal --watch 180 --until-done >"$dir/operator-$id.txt" 2>&1 &
    op_pids+=($!)
    sleep 2
  done
  for id in "${!op_pids[@]}"; do
    wait "${op_pids[$id]}" || result=1
  done
  kill -TERM "${mgc_pids[@]}" 2>/dev/null || true
  wait "${mgc_pids[@]}" 2>/dev/null || true
  kill -TERM "$sim_pid" "${display_pids[@]}" 2>/dev/null || true
  wait "$sim_pid" "${display_pids[@]}" 2>/dev/null || true

  for id in "${ids[@]}"; do
    echo "--- machine $id: mgc"
    grep -E '^mgc: ( +[0-9.]+ s |summary|site|site rules|loop|real-time)' "$dir/mgc-$id.txt" || true
  done
  echo "--- mgc-sim"
  grep -E '^mgc-sim: (timing|truth)' "$dir/sim.txt" || cat "$dir/sim.txt"
  read -r steal_after total_after < <(site_cpu_times || echo "0 0")
  if [ "${steal_after:-0}" -gt 0 ] && [ "${total_after:-0}" -gt "${total_before:-0}" ]; then
    echo "host: $(( 100 * (steal_after - steal_before) / (total_after - total_before) )) % of this machine's CPU time" \
      "taken by the hypervisor during the site's lifts (steal)"
  fi

  for id in "${ids[@]}"; do
    if ! grep -q '^mgc: summary: lift completed' "$dir/mgc-$id.txt"; then
      echo "site: machine $id's lift did not complete"
      result=1
    fi
  done
  local between
  between=$(sed -n 's/^mgc-sim: truth: between the machines: //p' "$dir/sim.txt")
  if [ -z "$between" ]; then
    echo "site: no truth line between the machines from mgc-sim"
    result=1
  elif ! grep -Eq ', 0 of [0-9]+ samples in contact' <<<"$between"; then
    echo "site: the machines touched: $between"
    result=1
  fi
  if grep -E '^mgc-sim: truth: machine' "$dir/sim.txt" | grep -Eqv ' 0 samples below'; then
    echo "site: a load went below the ground"
    result=1
  fi
  echo "site: least true clearance between the machines: ${between:-none}"
  echo "site: outputs in build/demo/site/ (mgc-N.txt, operator-N.txt, display-N.txt, sim.txt)"
  return "$result"
}

# The hypervisor's steal time and the total, in ticks since boot.
site_cpu_times() { awk '/^cpu /{print $9, $2+$3+$4+$5+$6+$7+$8+$9}' /proc/stat 2>/dev/null; }
