"""Opens a litesim report in headless Chromium (Debian's chromium driven by
Playwright) and checks what a reader sees:
python3 check_report.py REPORT.html ROWS FAILED ITEM BUCKETS HOLES
(ITEM "-" for none: an empty batch)."""
import os
import sys

from playwright.sync_api import sync_playwright

path, rows, failed, item, buckets, holes = sys.argv[1:7]
rows, failed, buckets, holes = int(rows), int(failed), int(buckets), int(holes)
chromium = os.environ.get("LITESIM_CHROMIUM", "/usr/bin/chromium")
with sync_playwright() as p:
    browser = p.chromium.launch(executable_path=chromium, args=["--no-sandbox"])
    page = browser.new_page()
    errors = []
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: errors.append(str(e)))
    # No network: any request but the file itself is a defect.
    requests = []
    page.on("request", lambda r: requests.append(r.url))
    page.goto("file://" + os.path.abspath(path))
    if item == "-":
        assert page.locator("#empty").count() == 1, "an empty batch must say so"
        assert page.locator("#runs tbody tr").count() == 0
    else:
        n = page.locator("#runs tbody tr").count()
        assert n == rows, f"table has {n} rows, expected {rows}"
        page.select_option("#show", "fail")
        n = page.locator("#runs tbody tr").count()
        assert n == failed, f"filter 'fail' shows {n} rows, expected {failed}"
        verdicts = page.locator("#runs tbody tr td:nth-child(3)").all_inner_texts()
        assert all(v == "FAIL" for v in verdicts), verdicts[:5]
        page.select_option("#show", "all")
        page.fill("#filter", "collision")
        shown = page.locator("#runs tbody tr").count()
        assert 0 < shown <= failed, f"text filter shows {shown}"
        page.fill("#filter", "")
        # Rows start sorted by seed; a click on the header turns the order:
        # the first row has the largest seed.
        page.click("th[data-k='1']")
        first = int(page.locator("#runs tbody tr:first-child td:nth-child(2)").inner_text())
        assert first == max(int(t) for t in page.locator("#runs tbody tr td:nth-child(2)").all_inner_texts())
        chart = page.locator(f".chart.cover[data-item='{item}']")
        assert chart.count() == 1, f"no coverage chart for {item}"
        nb = chart.locator("rect.bucket").count()
        assert nb == buckets, f"{item}: {nb} buckets drawn, expected {buckets}"
        nh = chart.locator("rect.hole").count()
        assert nh == holes, f"{item}: {nh} holes marked, expected {holes}"
        assert page.locator(".chart.crossed rect.cell").count() > 0, "no cross coverage"
        # TTC, gap, deceleration, time headway, DRAC, PET.
        assert page.locator(".chart.kpi").count() == 6
        links = page.locator("a.replay")
        if failed:
            assert links.count() > 0, "failed runs link to their replay"
    assert not errors, errors
    assert all(u.startswith("file://") for u in requests), requests
    browser.close()
print("report ok")
