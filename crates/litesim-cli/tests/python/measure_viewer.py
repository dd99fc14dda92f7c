"""Measures the viewer on a large run (for BENCHMARKS.md, not a pass/fail
test): python3 measure_viewer.py URL
Prints the page load time, the time to show the last tick after a jump to
the end, the median time of 20 jumps to random places, and the frames per
second while playing at 16×."""
import os
import random
import statistics
import sys
import time

from playwright.sync_api import sync_playwright

url = sys.argv[1]
chromium = os.environ.get("LITESIM_CHROMIUM", "/usr/bin/chromium")
with sync_playwright() as p:
    browser = p.chromium.launch(executable_path=chromium, args=["--no-sandbox"])
    page = browser.new_page(viewport={"width": 1400, "height": 900})
    errors = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    t0 = time.perf_counter()
    page.goto(url)
    page.wait_for_selector("body[data-ready='1']", timeout=60000)
    ready = (time.perf_counter() - t0) * 1000
    load_ms = page.evaluate("window.litesimView.loadMs")
    n = int(page.evaluate("document.getElementById('slider').max")) + 1

    def jump(k):
        t = time.perf_counter()
        page.evaluate("k => window.litesimView.seek(k)", k)
        page.wait_for_function("k => window.litesimView.loadedChunk(k)", arg=k)
        page.evaluate("() => new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)))")
        return (time.perf_counter() - t) * 1000

    end_ms = jump(n - 1)
    rnd = random.Random(1)
    jumps = [jump(rnd.randrange(n)) for _ in range(20)]
    page.evaluate("window.litesimView.seek(0)")
    page.select_option("#speed", "16")
    page.click("#play")
    fps = page.evaluate(
        "() => new Promise(r => { let f = 0; const t0 = performance.now(); function c(t) { f++; if (t - t0 < 2000) requestAnimationFrame(c); else r(f / ((t - t0) / 1000)); } requestAnimationFrame(c); })"
    )
    page.click("#play")
    assert not errors, errors
    browser.close()
print(
    f"ticks {n}: load {load_ms:.0f} ms (ready after {ready:.0f} ms), jump to end {end_ms:.0f} ms, "
    f"random jump median {statistics.median(jumps):.0f} ms (max {max(jumps):.0f}), playing 16x at {fps:.0f} fps"
)
