"""Drives the litesim viewer in headless Chromium (Debian's chromium via
Playwright) as a user would, and checks what it shows against the log:
python3 check_viewer.py URL LOG.json [--max-load-ms N]

URL is the server's address or a file:// URL of an exported viewer.
Prints `viewer ok: loaded in N ms`.
"""
import json
import os
import sys
import time

from playwright.sync_api import sync_playwright

url, log_path = sys.argv[1:3]
max_load_ms = None
if "--max-load-ms" in sys.argv:
    max_load_ms = float(sys.argv[sys.argv.index("--max-load-ms") + 1])
log = json.load(open(log_path))
ticks, tracks = log["tick"], log["tracks"]
n = len(ticks)


def truth(k, aid):
    """(x, y, speed) of actor aid at the log's k-th tick, or None."""
    t = next(t for t in tracks if t["id"] == aid)
    try:
        i = t["tick"].index(ticks[k])
    except ValueError:
        return None
    s = t["state"]
    return s["x"][i], s["y"][i], s["speed"][i]


chromium = os.environ.get("LITESIM_CHROMIUM", "/usr/bin/chromium")
with sync_playwright() as p:
    browser = p.chromium.launch(executable_path=chromium, args=["--no-sandbox"])
    page = browser.new_page(viewport={"width": 1400, "height": 900})
    errors, requests = [], []
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.on("request", lambda r: requests.append(r.url))
    t0 = time.perf_counter()
    page.goto(url)
    page.wait_for_selector("body[data-ready='1']", timeout=20000)
    wall_ms = (time.perf_counter() - t0) * 1000
    load_ms = page.evaluate("window.litesimView.loadMs")
    rows = page.locator("#actors tbody tr")
    assert rows.count() == len(tracks), (rows.count(), len(tracks))

    def seek(k):
        page.evaluate(
            "k => { const s = document.getElementById('slider'); s.value = String(k); s.dispatchEvent(new Event('input')); }",
            k,
        )
        page.wait_for_function(
            "k => document.getElementById('time').dataset.tick === String(k) && window.litesimView.loadedChunk(k)",
            arg=k,
        )
        page.wait_for_timeout(60)  # one animation frame draws the panel

    def check_positions(k):
        for r in range(rows.count()):
            row = rows.nth(r)
            aid = row.get_attribute("data-id")
            want = truth(k, aid)
            x, y = row.get_attribute("data-x"), row.get_attribute("data-y")
            if want is None:
                assert x == "" and y == "", (k, aid, x, y)
                continue
            assert abs(float(x) - want[0]) <= 0.01 and abs(float(y) - want[1]) <= 0.01, (k, aid, x, y, want)

    # The slider moves the actors: positions on the page match the log.
    for k in sorted({0, n // 3, (2 * n) // 3, n - 1}):
        seek(k)
        check_positions(k)

    # Play advances time.
    seek(0)
    page.click("#play")
    page.wait_for_timeout(700)
    moved = page.evaluate("window.litesimView.tick()")
    assert page.evaluate("window.litesimView.playing()") or moved == n - 1
    page.click("#play")
    assert moved > 0, "play did not advance time"
    k = page.evaluate("window.litesimView.tick()")
    page.wait_for_timeout(60)
    check_positions(k)

    # Clicking an actor shows its state (speed from the log).
    ego = tracks[0]["id"]
    k = n // 2
    seek(k)
    x, y = page.evaluate("id => window.litesimView.screenOf(id)", ego)
    page.mouse.click(x, y)
    page.wait_for_timeout(60)
    speed = page.locator("#info dd[data-k='speed']").inner_text()
    assert abs(float(speed) - truth(k, ego)[2]) <= 1e-3, (speed, truth(k, ego))
    assert page.locator("#info dd[data-k='id']").inner_text() == ego

    # Zoom (wheel) changes the scale; follow keeps the actor centred.
    a = page.evaluate("id => window.litesimView.screenOf(id)", ego)
    page.mouse.move(700, 300)
    page.mouse.wheel(0, -600)
    page.wait_for_timeout(60)
    page.select_option("#follow", index=1)
    page.wait_for_timeout(60)
    box = page.locator("#view").bounding_box()
    fx, fy = page.evaluate("id => window.litesimView.screenOf(id)", ego)
    assert abs(fx - (box["x"] + box["width"] / 2)) < 2 and abs(fy - (box["y"] + box["height"] / 2)) < 2, (fx, fy, box)

    # Failures and phases are on the timeline; plots are drawn.
    markers = page.locator("#timeline .marker").count()
    assert page.locator("#plot-speed").count() == 1
    # The ego's acceleration beside what was commanded of it.
    assert page.locator("#plot-accel").count() == 1
    # Whose command it is: the log's (sut, planned, …), else "commanded".
    assert page.locator("#cmd-label").inner_text(), "no command label"

    assert not errors, errors
    if url.startswith("file://"):
        assert all(u.startswith("file://") or u.startswith("data:") for u in requests), requests
    else:
        origin = url.rstrip("/")
        assert all(u.startswith(origin) for u in requests), requests
    browser.close()

if max_load_ms is not None:
    assert load_ms <= max_load_ms, f"loaded in {load_ms:.0f} ms, more than {max_load_ms:.0f} ms"
print(f"viewer ok: loaded in {load_ms:.0f} ms (page ready after {wall_ms:.0f} ms), {markers} markers")
