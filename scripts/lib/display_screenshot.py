# SPDX-License-Identifier: Apache-2.0
"""Plays a recorded lift in mgc-display and saves a headless-Chromium screenshot of its page.

    display_screenshot.py MGC_DISPLAY SCENARIO LOG OUT.png [SECONDS_BEFORE_END]

The log is shown paused SECONDS_BEFORE_END (default 0.3) before its end. Exits 1 when the screenshot
could not be taken (no Chromium, driver or selenium, or the page did not show the log)."""
import socket
import subprocess
import sys
import time
import urllib.request

display_bin, scenario, log, out = sys.argv[1:5]
before_end_s = float(sys.argv[5]) if len(sys.argv) > 5 else 0.3
try:
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    from selenium.webdriver.common.by import By
except ImportError:
    print("display screenshot: python3-selenium is not installed")
    sys.exit(1)

with socket.socket() as s:
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
url = "http://127.0.0.1:%d/" % port
display = subprocess.Popen([display_bin, "--port", str(port), "--scenario", scenario, "--log", log],
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
line = display.stdout.readline().strip()
if not line.startswith("mgc-display: " + url):
    print("display screenshot: " + line)
    sys.exit(1)


def playback(data):
    req = urllib.request.Request(url + "api/playback", data=data.encode(), headers={"Origin": url.rstrip("/")}, method="POST")
    with urllib.request.urlopen(req, timeout=5) as r:
        return r.read().decode()


status = 1
browser = None
try:
    import json
    duration_s = json.loads(playback("action=pause"))["duration_s"]
    playback("action=seek&value=%.3f" % max(0.0, duration_s - before_end_s))
    options = webdriver.ChromeOptions()
    options.binary_location = "/usr/bin/chromium"
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--window-size=1500,1000"):
        options.add_argument(arg)
    browser = webdriver.Chrome(service=Service("/usr/bin/chromedriver"), options=options)
    browser.get(url)
    end = time.monotonic() + 10
    while time.monotonic() < end and browser.find_element(By.ID, "feed-status").text != "PLAYBACK":
        time.sleep(0.1)
    time.sleep(0.3)
    browser.save_screenshot(out)
    status = 0 if browser.find_element(By.ID, "feed-status").text == "PLAYBACK" else 1
    if status:
        print("display screenshot: the page did not show the log")
except Exception as e:  # any failure here costs the demo its picture, not its result
    print("display screenshot: %s" % str(e).splitlines()[0] if str(e) else type(e).__name__)
finally:
    if browser:
        browser.quit()
    display.terminate()
    display.wait(timeout=5)
sys.exit(status)
