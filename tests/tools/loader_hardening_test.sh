#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Hostile scenario and machine files (docs/scenario-format.md, "Limits") against the three programs
# that share the loader: mgc-plan --check, mgc-sim and mgc each exit 2 with exactly one line on
# stderr, of at most 300 characters, that names the file; none blocks, aborts or crashes.
set -u
plan="$1"
sim="$2"
mgc="$3"
root="$4"
cli="$plan"
source "$(dirname "$0")/cli_support.sh"
base="$root/scenarios/thesis-steel-frame.yaml"

# variant <name> <sed script>: the base scenario with its machine path made absolute, then edited.
variant() {
  sed -e "s|^machine: machines/|machine: $root/scenarios/machines/|" -e "$2" "$base" >"$tmp/$1.yaml"
}

mkdir "$tmp/a-directory"
mkfifo "$tmp/no-writer.fifo"
long_name="$(head -c 300 /dev/zero | tr '\0' m).yaml"
variant machine-dir "s|^machine: .*|machine: $tmp/a-directory|"
variant machine-long "s|^machine: .*|machine: $long_name|"
variant machine-proc "s|^machine: .*|machine: /proc/self/mem|"
variant machine-fifo "s|^machine: .*|machine: $tmp/no-writer.fifo|"
for value in 1e200 -1e308 1e100; do
  variant "coordinate$value" "s|^obstacles:|obstacles:\n  - {name: box, type: box, size_m: [1, 1, 1], position_m: [0, $value, 0]}|"
done
variant frame-origin "s|origin_m: \[10, -12, 0\]|origin_m: [10, 1e200, 0]|"
# fill <file> <placeholder> <character> <count>: in bash, since a megabyte exceeds an argument's limit.
fill() {
  local text filler
  text="$(<"$1")"
  filler="$(head -c "$4" /dev/zero | tr '\0' "$3")"
  printf '%s\n' "${text/$2/$filler}" >"$1"
}
variant big-name "s|^  - name: frame|  - name: BIG|"
fill "$tmp/big-name.yaml" BIG n $((2 << 20))
variant big-value "s|^  load_lb: 20000 |  load_lb: BIGx |"
fill "$tmp/big-value.yaml" BIG 9 $((1 << 20))
variant newline 's|^  - name: frame|  - name: "frame\\nrm -rf"|'

# bad <name> <file the line must begin with> <scenario> [regex the line must match]
bad() {
  local name="$1" named="$2" scenario="$3" pattern="${4:-}"
  local program
  for program in "$plan --check" "$sim --duration 1" "$mgc --duration 1"; do
    # timeout: a program that blocks on a FIFO fails here instead of hanging the suite.
    timeout 20 $program --scenario "$scenario" >"$tmp/out" 2>"$tmp/err"
    local code=$?
    local who="$name ($(basename "${program%% *}"))"
    [ "$code" -eq 2 ] || fail "$who: exit $code, expected 2: $(head -c 300 "$tmp/err")"
    [ "$(wc -l <"$tmp/err")" -eq 1 ] || fail "$who: expected one line on stderr, got $(wc -l <"$tmp/err")"
    [ "$(wc -c <"$tmp/err")" -le 301 ] || fail "$who: stderr line of $(wc -c <"$tmp/err") bytes, expected at most 300 characters"
    [ "$(head -c ${#named} "$tmp/err")" = "$named" ] || fail "$who: stderr '$(head -c 300 "$tmp/err")' does not begin with '$named'"
    if [ -n "$pattern" ]; then
      grep -Eq -- "$pattern" "$tmp/err" || fail "$who: stderr '$(head -c 300 "$tmp/err")' does not match '$pattern'"
    fi
  done
}

bad "a directory as the scenario" "$tmp/a-directory: " "$tmp/a-directory" "expected a regular file, got a directory"
bad "a FIFO without a writer as the scenario" "$tmp/no-writer.fifo: " "$tmp/no-writer.fifo" "got a FIFO"
bad "a device as the scenario" "/dev/zero: " /dev/zero "got a character device"
bad "/proc/self/mem as the scenario" "/proc/self/mem: " /proc/self/mem "cannot read the file"
bad "machine: a directory" "$tmp/machine-dir.yaml:15: machine: " "$tmp/machine-dir.yaml" "got a directory"
bad "machine: a 300-byte name" "$tmp/machine-long.yaml:15: machine: " "$tmp/machine-long.yaml" "the path name is too long"
bad "machine: /proc/self/mem" "/proc/self/mem: " "$tmp/machine-proc.yaml" "cannot read the file"
bad "machine: a FIFO" "$tmp/machine-fifo.yaml:15: machine: " "$tmp/machine-fifo.yaml" "got a FIFO"
for value in 1e200 -1e308 1e100; do
  bad "obstacle coordinate $value" "$tmp/coordinate$value.yaml:28: obstacles[0].position_m[1]: " "$tmp/coordinate$value.yaml" \
    "expected a coordinate within the site extent \[-10000, 10000\] m, got '$value'"
done
bad "steel frame origin 1e200" "$tmp/frame-origin.yaml:30: obstacles[0].origin_m[1]: " "$tmp/frame-origin.yaml" "site extent"
bad "a 2 MB steel frame name" "$tmp/big-name.yaml:28: obstacles[0].name: " "$tmp/big-name.yaml" \
  "expected a name of at most 64 characters, got 'n+\.\.\. \(2097152 characters\)'$"
bad "a 1 MB value" "$tmp/big-value.yaml:20: task.load_lb: " "$tmp/big-value.yaml" "got '9+\.\.\. \(1048577 characters\)'$"
bad "a newline in a name" "$tmp/newline.yaml:28: obstacles[0].name: " "$tmp/newline.yaml" "got 'frame\\\\nrm -rf'$"

finish "loader hardening"
