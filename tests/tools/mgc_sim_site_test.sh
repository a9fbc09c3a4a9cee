#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# mgc-sim --site without --machine-id (docs/simulator.md, "A whole site"): every machine of a site
# in one process, each on its own bus, with one referee. The two machines of crossing-cranes.yaml
# stand at rest (no controller) at three placements, and the truth line between the machines must
# give the clearance that the geometry gives, computed here independently: the TMS870's carrier
# (its machine file's box, fixed to its base) against the tower crane's load (the lift's box, hung
# below the trolley at the start's radius and hook height, turned with the slew). Both are upright
# boxes turned about the vertical only, so their distance is that of their footprints in plan and
# of their height ranges. Then one placement in contact. Also the bad-input lines of the new form.
#   mgc_sim_site_test.sh MGC_SIM SOURCE_DIR
set -u
sim="$1"
root="$2"
cli="$sim"
source "$root/tests/tools/cli_support.sh"
machines="$root/scenarios/machines"
crossing="$root/scenarios/sites/crossing-cranes.yaml"

expect_bad "machine id without a site" 'machine-id goes with --site' --scenario "$root/scenarios/thesis-steel-frame.yaml" --machine-id 1
expect_bad "one bus for the whole site" 'bus takes one machine' --site "$crossing" --bus loop:x
expect_bad "truth log of the whole site" 'truth-csv takes one machine' --site "$crossing" --truth-csv "$tmp/t.csv"
expect_bad "fault on the whole site" 'fault takes one machine' --site "$crossing" --fault encoder-stuck:swing@1+1
printf 'name: broken\nmachines: 3\n' >"$tmp/broken.yaml"
expect_bad "bad site file" 'broken.yaml' --site "$tmp/broken.yaml"

# The carrier's box in its machine file (base frame: the carrier does not swing).
vec() { sed -nE "s/^ *$1: *\[([^]]*)\].*/\1/p" "$machines/grove-tms870.yaml" | tr -d ' '; }
carrier_size=$(vec carrier_size_m)
carrier_centre=$(vec carrier_centre_m)
[ -n "$carrier_size" ] && [ -n "$carrier_centre" ] || fail "no carrier geometry in grove-tms870.yaml"

# This test's ports: two per machine.
base=$(test_ports mgc_sim_site 4)
load_size="2.0, 2.0, 2.0"
sling_m=2.0

# site_file TOWER_X TOWER_Y SLEW_DEG TROLLEY_M HOOK_M: crossing-cranes.yaml's machines with the
# tower crane's base and start as given, on this test's ports.
site_file() {
  cat >"$tmp/site.yaml" <<EOF
name: at-rest
obstacles: []
planner:
  seed: 0
machines:
  - id: 1
    machine: $machines/grove-tms870.yaml
    base: {position_m: [0, 0, 0], yaw_deg: 0}
    priority: 2
    bus: {udp_ports: [$base, $((base + 1))]}
    lifts:
      - name: north
        task: {load_lb: 20000, capacity_reduction_pct: 0, outriggers: fully_extended, counterweight_lb: 18000,
               constraint: load_chart, load_size_m: [3.0, 2.0, 1.0], sling_length_m: 2.0}
        start: {swing_deg: 80, boom_elevation_deg: 50, boom_length_m: 20, cable_length_m: 14.82}
        goal: {swing_deg: -80, boom_elevation_deg: 50, boom_length_m: 20, cable_length_m: 14.82}
  - id: 2
    machine: $machines/pecco-sk180.yaml
    base: {position_m: [$1, $2, 0], yaw_deg: 0}
    priority: 1
    bus: {udp_ports: [$((base + 2)), $((base + 3))]}
    lifts:
      - name: across
        task: {load_size_m: [$load_size], sling_length_m: $sling_m}
        start: {slew_deg: $3, trolley_radius_m: $4, hook_height_m: $5}
        goal: {slew_deg: 140, trolley_radius_m: 45, hook_height_m: 4.5}
EOF
}

# expected TOWER_X TOWER_Y SLEW_DEG TROLLEY_M HOOK_M: the carrier-to-load distance [m].
expected() {
  python3 - "$carrier_size" "$carrier_centre" "$load_size" "$sling_m" "$@" <<'EOF'
import math, sys
cs = [float(v) for v in sys.argv[1].split(",")]
cc = [float(v) for v in sys.argv[2].split(",")]
ls = [float(v) for v in sys.argv[3].split(",")]
sling = float(sys.argv[4])
tx, ty, slew_deg, trolley, hook = (float(v) for v in sys.argv[5:10])
def rect(cx, cy, sx, sy, yaw):
    c, s = math.cos(yaw), math.sin(yaw)
    return [(cx + c * dx - s * dy, cy + s * dx + c * dy)
            for dx, dy in ((-sx / 2, -sy / 2), (sx / 2, -sy / 2), (sx / 2, sy / 2), (-sx / 2, sy / 2))]
def separated(a, b):
    for poly, other in ((a, b), (b, a)):
        for i in range(4):
            (x0, y0), (x1, y1) = poly[i], poly[(i + 1) % 4]
            n = (y1 - y0, x0 - x1)
            pa = [n[0] * x + n[1] * y for x, y in poly]
            pb = [n[0] * x + n[1] * y for x, y in other]
            if max(pa) < min(pb) or max(pb) < min(pa):
                return True
    return False
def point_segment(p, a, b):
    ab = (b[0] - a[0], b[1] - a[1])
    t = max(0.0, min(1.0, ((p[0] - a[0]) * ab[0] + (p[1] - a[1]) * ab[1]) / (ab[0] ** 2 + ab[1] ** 2)))
    return math.hypot(p[0] - a[0] - t * ab[0], p[1] - a[1] - t * ab[1])
def plan_distance(a, b):
    if not separated(a, b):
        return 0.0
    return min(point_segment(p, poly[i], poly[(i + 1) % 4])
               for p_set, poly in ((a, b), (b, a)) for p in p_set for i in range(4))
carrier = rect(cc[0], cc[1], cs[0], cs[1], 0.0)
slew = math.radians(slew_deg)
load = rect(tx + trolley * math.cos(slew), ty + trolley * math.sin(slew), ls[0], ls[1], slew)
carrier_z = (cc[2] - cs[2] / 2, cc[2] + cs[2] / 2)
load_z = (hook - sling - ls[2], hook - sling)
dz = max(0.0, load_z[0] - carrier_z[1], carrier_z[0] - load_z[1])
print(f"{math.hypot(plan_distance(carrier, load), dz):.2f}")
EOF
}

# between TOWER_X TOWER_Y SLEW_DEG TROLLEY_M HOOK_M: runs the site at rest and prints the truth line
# between the machines.
between() {
  site_file "$@"
  "$sim" --site "$tmp/site.yaml" --duration 1.5 --quiet >"$tmp/out" 2>"$tmp/err" || fail "exit $? at $*: $(cat "$tmp/err")"
  sed -n 's/^mgc-sim: truth: between the machines: //p' "$tmp/out"
}

# check_at NAME TOWER_X TOWER_Y SLEW_DEG TROLLEY_M HOOK_M
check_at() {
  local name="$1" want line got samples
  shift
  want=$(expected "$@")
  line=$(between "$@")
  echo "$name: expected $want m; $line"
  got=$(sed -nE 's/^least clearance ([0-9.]+) m at .*/\1/p' <<<"$line")
  [ "$got" = "$want" ] || fail "$name: least clearance between the machines '$got' m, expected $want m"
  grep -q '(machine 1 carrier to machine 2 load)' <<<"$line" || fail "$name: not the carrier and the load: $line"
  samples=$(sed -nE 's/.*, ([0-9]+) of ([0-9]+) samples in contact.*/\2/p' <<<"$line")
  # 1.5 s at one sample per 50 ms, on a loaded machine at least half of them.
  [ "${samples:-0}" -ge 15 ] || fail "$name: $samples samples"
  grep -Eq ', 0 of [0-9]+ samples in contact' <<<"$line" || fail "$name: contact counted at rest apart: $line"
  # The machines against the site too: one line each.
  [ "$(grep -c '^mgc-sim: truth: machine [12]: least clearance' "$tmp/out")" -eq 2 ] || fail "$name: not a truth line per machine"
}

# crossing-cranes.yaml's start: the load south-east of the TMS870, 23 m off its carrier's corner.
check_at "crossing-cranes start" 40 -10 -150 30 4.5
# Slewed to the west, the load beside the carrier's east end: plan gap 2.5 m by 7.7 m.
check_at "load beside the carrier" 40 -10 180 28 4.5
# The same, the load hoisted above the carrier's roof.
check_at "load above the carrier's height" 40 -10 180 28 12

# The load standing in the carrier: every sample in contact, at 0.
line=$(between 40 0 180 33 4.5)
echo "in contact: $line"
grep -Eq '^least clearance 0\.00 m at 0\.00 s \(machine 1 carrier to machine 2 load\), ([0-9]+) of \1 samples in contact' <<<"$line" ||
  fail "in contact: every sample should be in contact: $line"

finish "mgc-sim --site, every machine"
