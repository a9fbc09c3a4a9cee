# SPDX-License-Identifier: Apache-2.0
"""mgc-display in headless Chromium, fed by display_feeder on a private LCM URL.

    display_browser_test.py MGC_DISPLAY DISPLAY_FEEDER SOURCE_DIR OUT_DIR

Checks, in order: the page loads without console errors and shows the machine state; an alert
appears on the page after it is published and not before; STOP, ACKNOWLEDGE and a goal reach the
bus (the goal and acknowledge signed with the key, which display_feeder verifies); a command posted
from another origin is refused; a malformed message is counted; the LCM message -> DOM latency over
>= 200 updates (median and p99, written to OUT_DIR/latency.txt); a stopped feed is shown as stale
within its rule; a screenshot is written to OUT_DIR/display.png. Exits 77 (skipped) only when
Chromium, its driver or selenium is not installed.
"""
import bisect
import os
import shutil
import socket
import statistics
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request

display_bin, feeder_bin, source_dir, out_dir = sys.argv[1:5]

try:
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    from selenium.webdriver.common.by import By
except ImportError:
    print("SKIP: python3-selenium is not installed (scripts/lib/common.sh installs it)")
    sys.exit(77)
chromium = shutil.which("chromium")
driver_bin = shutil.which("chromedriver")
if not chromium or not driver_bin:
    print("SKIP: chromium or chromium-driver is not installed (scripts/lib/common.sh installs them)")
    sys.exit(77)

os.makedirs(out_dir, exist_ok=True)
tmp = tempfile.mkdtemp(prefix="mgc-display-test-")
failures = []
passes = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what, flush=True)
    (passes if ok else failures).append(what)


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_for(predicate, timeout_s, step_s=0.02):
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        value = predicate()
        if value:
            return value
        time.sleep(step_s)
    return predicate()


# A private LCM group port per run, ttl=0: parallel runs and the demo do not hear each other.
lcm_url = "udpm://239.255.76.67:%d?ttl=0" % (7900 + os.getpid() % 500)
http_port = free_port()
key_file = os.path.join(tmp, "operator.key")
with open(key_file, "wb") as f:
    f.write(os.urandom(32))
os.chmod(key_file, 0o600)
sent_log = os.path.join(tmp, "sent.txt")
scenario = os.path.join(source_dir, "scenarios", "thesis-steel-frame.yaml")

feeder = subprocess.Popen([feeder_bin, lcm_url, sent_log, key_file], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                          text=True, bufsize=1)


def step(line):
    feeder.stdin.write(line + "\n")
    feeder.stdin.flush()
    return feeder.stdout.readline().strip()


site_file = os.path.join(source_dir, "scenarios", "sites", "thesis-steel-frame.yaml")
display = subprocess.Popen([display_bin, "--port", str(http_port), "--lcm-url", lcm_url, "--scenario", scenario,
                            "--key", key_file, "--site", site_file, "--machine-id", "1", "--site-lcm-url", lcm_url], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
url = "http://127.0.0.1:%d/" % http_port
first = display.stdout.readline().strip()
check(first == "mgc-display: " + url + " (feed " + lcm_url + ")", "mgc-display prints its URL: " + first)

options = webdriver.ChromeOptions()
options.binary_location = chromium
for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--window-size=1500,1000",
            "--user-data-dir=" + os.path.join(tmp, "chromium")):
    options.add_argument(arg)
options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
browser = webdriver.Chrome(service=Service(driver_bin), options=options)
status = 1
try:
    text = lambda id_: browser.find_element(By.ID, id_).text

    # The machine state: the crane at known joint values, executing, at 72 % of the chart.
    q = [0.5, 0.9, 30.0, 20.0]
    step("state 4 72 " + " ".join(map(str, q)))
    step("stream 10")
    browser.get(url)
    check(wait_for(lambda: text("feed-status") == "LIVE", 5), "the page says LIVE while the state streams")
    check(wait_for(lambda: text("supervisor") == "EXECUTING", 2), "supervisor state shown: " + text("supervisor"))
    check(wait_for(lambda: text("load-value") == "72 %", 2), "load moment shown: " + text("load-value"))
    joints = text("joints")
    check("28.6 deg" in joints and "30.00 m" in joints, "joint values shown in deg and m: " + joints.replace("\n", " | "))
    step("guidance 0 1.2 0.7 1 3")
    step("instruction 7.5 swing left 40 deg, then boom up 4 deg")
    check(wait_for(lambda: text("instruction-text") == "swing left 40 deg, then boom up 4 deg", 2),
          "the next instruction in words: " + text("instruction-text"))
    check(wait_for(lambda: text("move-target") == "68.8 deg", 2) and text("move-joint") == "swing" and
          text("move-remaining") == "40.1 deg" and text("plan-progress") == "segment 2 of 3" and text("time-remaining") == "12.5 s",
          "which joint to move, how far, and the progress: %s to %s, %s to go, %s, %s" % (
              text("move-joint"), text("move-target"), text("move-remaining"), text("plan-progress"), text("time-remaining")))
    check(text("obstacle-distance").startswith("7.5 m"), "nearest obstacle: " + text("obstacle-distance"))
    step("plan 0.5,0.9,30,20;1.2,0.9,30,20;1.2,1.0,30,20;1.2,1.0,30,10")
    check(wait_for(lambda: browser.execute_script("return plan && plan.tool_path.length > 10"), 2),
          "the plan arrives as a tool path for the views")

    # A tracked obstacle: crane 2 (the scenario's dynamic obstacle 0) at (-30, -6), yawed -90 deg.
    # Its parts must be drawn where the plan view maps its frame (the carrier's middle is 2 m
    # along its x, so 2 m south of the origin), in the colour of its state.
    obstacle_li = "const li = document.querySelector(\"#tracked-obstacles li[data-obstacle-index='0']\"); " \
                  "return li ? [li.dataset.status, li.textContent, li.dataset.planPx || ''] : null"
    def obstacle():
        return browser.execute_script(obstacle_li) or ["", "", ""]
    check(not browser.find_elements(By.CSS_SELECTOR, "#tracked-obstacles li[data-obstacle-index]"),
          "no tracked obstacle listed before one is published")
    step("obstacle 0 1 0 -30 -6 -90 1.25 4.2")
    shown = wait_for(lambda: obstacle()[0] == "moving" and obstacle()[2], 3)
    status_, words, px = obstacle()
    check(bool(shown) and words.startswith("crane-2: moving 1.3 m/s, turning 4.2 deg/s at (-30.0, -6.0) m"), "the obstacle listed as moving: " + words)
    # The colour of the plan view at the carrier's middle: (-30, -8, 1) in the site frame.
    pixel_at = """
      const p = planView.map(arguments[0]);
      const d = planView.ctx.getImageData(Math.round(p[0]), Math.round(p[1]), 1, 1).data;
      return [d[0], d[1], d[2], d[3], p[0], p[1]];"""
    def colour(point):
        return browser.execute_script(pixel_at, point)
    # By hue, so that whatever lies under the translucent fill (the site, nothing) does not matter.
    def magenta(c):
        return c[3] > 0 and c[0] - c[1] > 60 and c[2] - c[1] > 60
    def blue(c):
        return c[3] > 0 and c[2] - c[0] > 60 and c[2] - c[1] > 30
    c = wait_for(lambda: (lambda c: c if magenta(c) else None)(colour([-30, -8, 1])), 2) or colour([-30, -8, 1])
    ox, oy = (float(v) for v in px.split(",")) if px else (float("nan"), float("nan"))
    origin = browser.execute_script("return planView.map([-30, -6, 0])")
    check(magenta(c) and abs(ox - origin[0]) < 0.2 and abs(oy - origin[1]) < 0.2,
          "the moving obstacle drawn magenta at its pose in the plan view: rgba%s at px (%.0f, %.0f), origin at %s" % (
              tuple(c[:4]), c[4], c[5], px))
    # Away from the pose (the same point on the far side of the origin): not the obstacle's colour.
    check(not magenta(colour([-30, 6, 1])) and not blue(colour([-30, 6, 1])), "nothing drawn where the obstacle is not")
    side = browser.execute_script("""
      const p = sideView.map([-30, -8, 1]);
      const d = sideView.ctx.getImageData(Math.round(p[0]), Math.round(p[1]), 1, 1).data;
      return [d[0], d[1], d[2], d[3]];""")
    check(magenta(side), "the moving obstacle drawn in the side view: rgba%s" % (tuple(side),))
    step("obstacle 0 1 1 -30 -6 -90 0 0")
    check(wait_for(lambda: obstacle()[0] == "still" and blue(colour([-30, -8, 1])), 2),
          "a still obstacle drawn blue: %s, rgba%s" % (obstacle()[1], tuple(colour([-30, -8, 1])[:4])))
    step("obstacle 0 0 1 -30 -6 -90 0 0")
    check(wait_for(lambda: obstacle()[0] == "pose unknown" and not blue(colour([-30, -8, 1])), 2) and
          "pose unknown, last fix" in obstacle()[1], "a lost obstacle: dashed, unfilled, 'pose unknown': " + obstacle()[1])
    step("obstacle 0 1 0 -30 -6 -90 1.25 4.2")
    check(wait_for(lambda: obstacle()[0] == "moving", 2), "the obstacle moving again")

    # The site's other machine: the tower crane (machine 2, base at (-40, -10)) at its reported
    # joints, through its own model, marked unverified (no site key).
    member_li = "const li = document.querySelector(\"#site-members li[data-machine-id='2']\"); " \
                "return li ? [li.dataset.status, li.textContent] : ['', '']"
    def teal(c):
        return c[3] > 0 and c[1] - c[0] > 60 and c[2] - c[0] > 60
    check(wait_for(lambda: browser.execute_script(member_li)[1].endswith("not heard from"), 2),
          "the site's other machine listed, not heard from: " + browser.execute_script(member_li)[1])
    step("site 2 1 2.5 20 20")
    check(wait_for(lambda: browser.execute_script(member_li)[0] == "current" and teal(colour([-40, -10, 5])), 3),
          "the tower crane drawn teal at its base in the plan view: %s, rgba%s" % (
              browser.execute_script(member_li)[1], tuple(colour([-40, -10, 5])[:4])))
    check("EXECUTING" in browser.execute_script(member_li)[1] and "UNVERIFIED" in text("site-note"),
          "listed as executing, the site's states unverified: " + text("site-note"))
    tower_side = browser.execute_script("""
      const p = sideView.map([-40, -10, 5]);
      const d = sideView.ctx.getImageData(Math.round(p[0]), Math.round(p[1]), 1, 1).data;
      return [d[0], d[1], d[2], d[3]];""")
    check(teal(tower_side), "its mast in the side view: rgba%s" % (tuple(tower_side),))

    # An alert: absent until published, then shown within the push period and the draw.
    check(not browser.find_elements(By.CSS_SELECTOR, "#alerts li[data-alert-id='7']"), "no alert before it is raised")
    step("alert 7 4 1 1 5 3.5 2")
    raised_at = time.monotonic()
    alert_text = "const a = document.querySelector(\"#alerts li[data-alert-id='7']\"); return a ? a.textContent : ''"
    shown = wait_for(lambda: browser.execute_script(alert_text), 2, 0.005)
    shown_s = time.monotonic() - raised_at
    check("RAISED stop collision" in shown and shown_s < 1.0, "the alert shown %.0f ms after it was raised: %s" % (shown_s * 1e3, shown))
    check(wait_for(lambda: text("approach-countdown").endswith("s (obstacle 2)"), 2),
          "the approach countdown: " + text("approach-countdown"))
    step("alert 7 4 1 0 5 3.5 2")
    alert_class = "const a = document.querySelector(\"#alerts li[data-alert-id='7']\"); return a ? a.className : ''"
    check(wait_for(lambda: "cleared" in browser.execute_script(alert_class), 2),
          "the alert shown as cleared")

    # Commands: STOP, then a signed acknowledge and goal, all as display_feeder hears them.
    browser.find_element(By.ID, "stop").click()
    heard = step("command 2000")
    check(heard.startswith("command 2 2 "), "STOP reaches MGC_COMMAND as a stop from sender 2: " + heard)
    browser.find_element(By.ID, "ack").click()
    heard = step("command 2000")
    check(heard == "command 3 2 accepted", "ACKNOWLEDGE reaches MGC_COMMAND, signed with the key: " + heard)
    browser.find_element(By.ID, "goal").click()
    heard = step("command 2000")
    check(heard == "command 1 2 accepted", "the goal request reaches MGC_COMMAND, signed with the key: " + heard)

    def post(path, headers):
        req = urllib.request.Request("http://127.0.0.1:%d%s" % (http_port, path), data=b"", headers=headers, method="POST")
        try:
            with urllib.request.urlopen(req, timeout=5) as r:
                return r.status
        except urllib.error.HTTPError as e:
            return e.code
    check(post("/api/stop", {"Origin": "http://evil.example"}) == 403, "a command from another origin is refused")
    check(post("/api/goal", {}) == 403, "a command without an Origin is refused")
    check(post("/api/stop", {"Host": "evil.example:%d" % http_port, "Origin": "http://evil.example:%d" % http_port}) == 403,
          "a command through a DNS name (rebinding) is refused")
    check(step("command 300") == "command none", "no refused request reached the bus")

    # A malformed message is counted and shown; the page carries on.
    step("junk MGC_MACHINE_STATE")
    check(wait_for(lambda: "MGC_MACHINE_STATE 1" in text("feed-counters"), 2), "malformed message counted: " + text("feed-counters"))
    step("bad-plan")
    check(wait_for(lambda: "MGC_OPERATOR_INSTRUCTION 1" in text("feed-counters") and "MGC_PLAN 1" in text("feed-counters"), 2),
          "a plan with forged counts and an instruction with a forged text length counted as malformed: " + text("feed-counters"))
    check(display.poll() is None and text("feed-status") == "LIVE", "still live after malformed messages")

    # Latency: every change of the displayed state's utime, stamped in the page, against the time
    # display_feeder published that state.
    browser.execute_script("""
      window.__seen = [];
      const el = document.getElementById('feed-status');
      new MutationObserver(() => window.__seen.push([el.dataset.utime, performance.timeOrigin + performance.now()]))
        .observe(el, {attributes: true, attributeFilter: ['data-utime']});""")
    wait_for(lambda: browser.execute_script("return window.__seen.length") >= 230, 60, 0.2)
    seen = browser.execute_script("return window.__seen")
    sent = {}
    with open(sent_log) as f:
        for row in f:
            parts = row.split()
            if len(parts) == 2:
                sent[parts[0]] = int(parts[1])
    def stats(name, values):
        values = sorted(values)
        n = len(values)
        if not n:
            return 0, float("nan"), float("nan"), name + ": no samples"
        median, p99 = statistics.median(values), values[min(n - 1, int(0.99 * n))]
        return n, median, p99, "%s over %d: median %.1f ms, p99 %.1f ms, max %.1f ms" % (name, n, median, p99, values[-1])
    # (1) Each DOM update against the publication of the state it shows.
    shown = stats("LCM message -> DOM, the message shown", [t_ms - sent[u] / 1e3 for u, t_ms in seen if u in sent])
    # (2) Every published state against the first DOM update that shows it or a newer one: the
    # latency of any change, the wait for the next push included.
    seen_u = [int(u) for u, _ in seen]
    any_message = []
    for u, t_us in sent.items():
        k = bisect.bisect_left(seen_u, int(u))
        if seen_u and seen_u[0] <= int(u) and k < len(seen):
            any_message.append(seen[k][1] - t_us / 1e3)
    every = stats("LCM message -> DOM, every message", any_message)
    for line in (shown[3], every[3]):
        print(line)
    with open(os.path.join(out_dir, "latency.txt"), "w") as f:
        f.write(shown[3] + "\n" + every[3] + "\n")
    # Generous bounds only (a loaded 2-core machine must meet them); the figures go to the docs.
    check(shown[0] >= 200 and shown[1] < 250 and shown[2] < 1000, "latency of the message shown within generous bounds")
    check(every[0] >= 200 and every[1] < 250 and every[2] < 1000, "latency of every message within generous bounds")

    # Stale: the state stops; within the rule (0.5 s) plus a push period and a draw, the page says so.
    shot = os.path.join(out_dir, "display.png")
    browser.save_screenshot(shot)
    check(os.path.getsize(shot) > 10000, "screenshot written: " + shot)
    step("obstacle none")
    step("site none")
    step("stream 0")
    stopped_at = time.monotonic()
    became_stale = wait_for(lambda: text("feed-status") == "FEED STALE", 3, 0.01)
    stale_s = time.monotonic() - stopped_at
    # Not before the rule's 0.5 s (less the stop step's own wait); the upper bound is generous for a
    # loaded machine, where the browser may lag by a second.
    check(bool(became_stale) and 0.4 < stale_s < 3.0, "stale shown %.2f s after the last state" % stale_s)
    check(text("supervisor") == "—" and text("load-value") == "—" and text("instruction-text") == "—",
          "no value shown as current while stale")
    check(browser.find_element(By.ID, "stale-banner").is_displayed() and "FEED STALE" in text("stale-banner"),
          "the red banner: " + text("stale-banner"))
    check(obstacle()[0] == "stale" and "as last reported (not current)" in obstacle()[1] and
          not magenta(colour([-30, -8, 1])), "the obstacle not shown as current while stale: " + obstacle()[1])
    check(browser.execute_script(member_li)[0] == "stale" and not teal(colour([-40, -10, 5])),
          "the site's machine not shown as current while stale: " + browser.execute_script(member_li)[1])
    browser.save_screenshot(os.path.join(out_dir, "display-stale.png"))

    errors = [e for e in browser.get_log("browser") if e.get("level") == "SEVERE"]
    check(not errors, "no console errors: %s" % errors)
    status = 1 if failures else 0
finally:
    browser.quit()
    display.terminate()
    try:
        rest = display.communicate(timeout=5)[0]
        print(rest.strip())
    except subprocess.TimeoutExpired:
        display.kill()
    check(display.returncode == 0, "mgc-display exits 0 on SIGTERM (got %s)" % display.returncode)
    step("quit")
    feeder.wait(timeout=5)
    shutil.rmtree(tmp, ignore_errors=True)

print("%d passed, %d failed" % (len(passes), len(failures)))
sys.exit(1 if failures else status)
