# SPDX-License-Identifier: Apache-2.0
# Shared by the command-line tests: a scratch folder, failure counting, and the bad-input contract
# (exit 2, exactly one line on stderr matching a pattern). Source it after setting $cli to the
# program under test; with $tools set to every program the test runs, it first checks they are built.
# A test run alone (ctest -R) needs every program it starts, not only the one it is named after.
for tool in ${tools:-} "$cli"; do
  if [ ! -x "$tool" ]; then
    echo "FAIL: $tool is not built; build its target ($(basename "$tool")) first" >&2
    exit 1
  fi
done
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }

# test_ports <test> <count>: the first of <count> loopback UDP ports for this test. Each end-to-end
# test has a block of 900 ports of its own, so tests that ctest runs side by side never share one,
# and every block lies above the kernel's ephemeral range (32768-60999 by default), so a port the
# kernel hands to another program (a browser, an LCM sender, a free-port probe) is never one of
# them. Within its block a test's ports follow its process id, for two checkouts tested at once.
test_ports() {
  local first
  case "$1" in
    mgc_sim_cli) first=61000 ;;
    mgc_sim_site) first=61900 ;;
    mgc_udp_loop) first=62800 ;;
    black_box_kill) first=63700 ;;
    mgc_site_process) first=64600 ;;
    *) echo "test_ports: no port block for $1" >&2; exit 1 ;;
  esac
  echo $((first + ($$ % (900 / $2)) * $2))
}

# expect_bad <name> <regex for the single stderr line> <args...>
expect_bad() {
  local name="$1" pattern="$2"
  shift 2
  "$cli" "$@" >"$tmp/out" 2>"$tmp/err"
  local code=$?
  [ "$code" -eq 2 ] || fail "$name: exit $code, expected 2"
  [ "$(wc -l <"$tmp/err")" -eq 1 ] || fail "$name: expected one line on stderr, got: $(cat "$tmp/err")"
  grep -Eq "$pattern" "$tmp/err" || fail "$name: stderr '$(cat "$tmp/err")' does not match '$pattern'"
}

# finish <what>: prints the verdict and exits 0 when nothing failed.
finish() {
  if [ "$failures" -eq 0 ]; then
    echo "$1: all checks passed"
    exit 0
  fi
  exit 1
}
