#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# mgc-display's command line: bad inputs exit 2 with one line (port in use, key file of the wrong
# size or mode, unreadable scenario, bad site options, logs that are not whole LCM logs), and a recorded log plays
# with pause, seek and speed from the served origin only.
#   display_cli_test.sh MGC_DISPLAY DISPLAY_FEEDER SOURCE_DIR
set -u
cli="$1"
feeder="$2"
src="$3"
source "$src/tests/tools/cli_support.sh"

port_free() { python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'; }
scenario="$src/scenarios/thesis-steel-frame.yaml"
lcm_url="udpm://239.255.76.67:$((7400 + $$ % 300))?ttl=0"

# Key files: the right 32 bytes but readable by others; 31 bytes.
head -c 32 /dev/urandom >"$tmp/open.key"
chmod 644 "$tmp/open.key"
head -c 31 /dev/urandom >"$tmp/short.key"
chmod 600 "$tmp/short.key"
expect_bad "key readable by others" '^mgc-display: --key: command key file .*open.key: mode 0644; expected no access for group and others' \
  --key "$tmp/open.key" --lcm-url "$lcm_url"
expect_bad "short key" '^mgc-display: --key: .*short.key.*31 bytes; expected exactly 32 raw bytes' --key "$tmp/short.key" --lcm-url "$lcm_url"
expect_bad "missing key" '^mgc-display: --key: command key file .*none.key: No such file' --key "$tmp/none.key" --lcm-url "$lcm_url"

# Scenarios: missing, and not YAML.
expect_bad "missing scenario" '^mgc-display: --scenario: .*none.yaml' --scenario "$tmp/none.yaml" --lcm-url "$lcm_url"
printf 'name: [unclosed\n' >"$tmp/bad.yaml"
expect_bad "malformed scenario" '^mgc-display: --scenario: .*bad.yaml' --scenario "$tmp/bad.yaml" --lcm-url "$lcm_url"
expect_bad "port out of range" '^mgc-display: --port' --port 70000

# The site: a missing file, a machine id it lacks, a site key without a machine id or open to
# others, the site options without --site, a site without a scenario or a machine id.
site="$src/scenarios/sites/thesis-steel-frame.yaml"
head -c 32 /dev/urandom >"$tmp/site.key"
chmod 600 "$tmp/site.key"
expect_bad "missing site" '^mgc-display: --site: .*none-site.yaml' --scenario "$scenario" --site "$tmp/none-site.yaml" --lcm-url "$lcm_url"
expect_bad "machine id not on the site" '^mgc-display: --site: .*thesis-steel-frame.yaml.*9' --scenario "$scenario" --site "$site" \
  --machine-id 9 --lcm-url "$lcm_url"
expect_bad "site key without machine id" '^mgc-display: --site-key: needs --machine-id' --scenario "$scenario" --site "$site" \
  --site-key "$tmp/site.key" --lcm-url "$lcm_url"
expect_bad "site key readable by others" '^mgc-display: --site-key: site key file .*open.key: mode 0644' --scenario "$scenario" \
  --site "$site" --machine-id 1 --site-key "$tmp/open.key" --lcm-url "$lcm_url"
expect_bad "site options without a site" '^mgc-display: --site-key, --machine-id and --site-lcm-url need --site' --machine-id 1
expect_bad "site without a scenario or a machine" '^mgc-display: --site: needs --machine-id or --scenario' --site "$site" --lcm-url "$lcm_url"
expect_bad "site machine it lacks, drawn from the site" '^mgc-display: --site: .*no machine with id 7; expected one of 1, 2$' \
  --site "$site" --machine-id 7 --lcm-url "$lcm_url"

# Logs: a good one of 2 s, then cut, then text, then empty.
printf 'state 4 55 0.3 0.9 30 20\nwrite-log %s 2\nquit\n' "$tmp/lift.lcmlog" | "$feeder" "$lcm_url" "$tmp/sent.txt" >/dev/null
size=$(stat -c %s "$tmp/lift.lcmlog")
[ "$size" -gt 1000 ] || fail "the recorded log has $size bytes"
head -c $((size - 7)) "$tmp/lift.lcmlog" >"$tmp/cut.lcmlog"
expect_bad "truncated log" "^mgc-display: --log: .*cut.lcmlog: $((size - 7)) bytes, the last whole event ends at byte [0-9]+; expected whole events \(truncated log\)" \
  --log "$tmp/cut.lcmlog"
printf 'these are not LCM events\n' >"$tmp/text.lcmlog"
expect_bad "text as a log" '^mgc-display: --log: .*text.lcmlog: no LCM log event' --log "$tmp/text.lcmlog"
{ printf 'junk'; cat "$tmp/lift.lcmlog"; } >"$tmp/prefixed.lcmlog"
expect_bad "junk before the first event" '^mgc-display: --log: .*prefixed.lcmlog: byte 0: expected an LCM log event' --log "$tmp/prefixed.lcmlog"
: >"$tmp/empty.lcmlog"
expect_bad "empty log" '^mgc-display: --log: .*empty.lcmlog: no LCM log event' --log "$tmp/empty.lcmlog"

# Playback of the good log, and the port then in use for a second display.
port=$(port_free)
"$cli" --port "$port" --log "$tmp/lift.lcmlog" --scenario "$scenario" >"$tmp/play.out" 2>&1 &
pid=$!
for _ in $(seq 100); do grep -q "^mgc-display: http://127.0.0.1:$port/" "$tmp/play.out" && break; sleep 0.05; done
grep -q "^mgc-display: http://127.0.0.1:$port/ (playback of " "$tmp/play.out" || fail "playback did not start: $(cat "$tmp/play.out")"
expect_bad "port in use" "^mgc-display: --port $port: cannot listen on 127.0.0.1:$port" --port "$port" --lcm-url "$lcm_url"

base="http://127.0.0.1:$port"
post() { curl -s -o "$tmp/post.out" -w '%{http_code}' -X POST -H "Origin: $base" --data "$2" "$base$1"; }
event() { timeout 1 curl -sN "$base/api/events" | grep -m1 '^data: ' | sed 's/^data: //'; }
sleep 0.5
event >"$tmp/e1"
grep -q '"supervisor":4' "$tmp/e1" || fail "playback: no EXECUTING state on the page: $(head -c 300 "$tmp/e1")"
grep -q '"machine":{"bodies"' "$tmp/e1" || fail "playback: the machine is not drawn from the model"
[ "$(post /api/playback 'action=pause')" = 200 ] || fail "pause refused: $(cat "$tmp/post.out")"
[ "$(post /api/playback 'action=seek&value=1.5')" = 200 ] || fail "seek refused: $(cat "$tmp/post.out")"
sleep 0.2
event >"$tmp/e2"
grep -q '"playback":{"position_s":1.5,"duration_s":1.99,"playing":false' "$tmp/e2" || fail "seek: $(grep -o '"playback".*' "$tmp/e2")"
# The log's joint 0 runs 0.01 rad per 10 ms: at 1.5 s it reads 1.5 rad.
grep -q '"joints":\[1.5,' "$tmp/e2" || fail "seek: joint 0 is not 1.5 rad at 1.5 s: $(grep -o '"joints":[^]]*' "$tmp/e2")"
grep -q '"alive":true' "$tmp/e2" || fail "a paused log counts as stale"
[ "$(post /api/playback 'action=speed&value=50')" = 400 ] || fail "speed 50 accepted"
[ "$(post /api/playback 'action=rewind')" = 400 ] || fail "an unknown action accepted"
code=$(curl -s -o /dev/null -w '%{http_code}' -X POST -H "Origin: http://evil.example" --data 'action=play' "$base/api/playback")
[ "$code" = 403 ] || fail "playback control from another origin: HTTP $code"
[ "$(post /api/playback 'action=speed&value=4')" = 200 ] || fail "speed 4 refused"
[ "$(post /api/playback 'action=play')" = 200 ] || fail "play refused"
sleep 0.6
event >"$tmp/e3"
grep -q '"position_s":1.99' "$tmp/e3" || fail "play at 4x did not reach the end: $(grep -o '"playback".*' "$tmp/e3")"
[ "$(post /api/ack '')" = 403 ] || fail "acknowledge without a key was not refused"
kill "$pid"
wait "$pid"
code=$?
[ "$code" -eq 0 ] || fail "mgc-display exited $code on SIGTERM"
# Every event at least once (a seek back plays the start again: how often depends on how fast this
# machine ran the steps above), none malformed.
summary="$(tail -1 "$tmp/play.out")"
[[ $summary =~ ^mgc-display:\ ([0-9]+)\ messages\ received,\ 0\ malformed$ ]] && [ "${BASH_REMATCH[1]}" -ge 200 ] ||
  fail "summary: $summary"

finish "mgc-display command line"
