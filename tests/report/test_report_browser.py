"""The report in a real browser: headless Chromium opens report.html over file:// with the
network-off flags, and the page must load without console errors, show every picture (the GIF
included), run no script, and make no request that leaves the machine.

Needs the Debian packages ``chromium`` and ``chromium-driver`` and ``selenium`` from PyPI. When
they are absent the test skips, except under CI (``$CI`` set), where it fails: CI must run it.
"""

from __future__ import annotations

import json
import os
import shutil
import time
from collections.abc import Iterator
from pathlib import Path
from urllib.parse import urlsplit

import pytest
from report_runs import HOSTILE, incomplete, make_scenario, verified  # tests/report (see conftest)

from regen.report import write_report

pytestmark = [pytest.mark.browser, pytest.mark.slow]

CHROMIUM_FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                  "--disable-background-networking", "--disable-component-update", "--disable-sync",
                  "--disable-default-apps", "--disable-extensions", "--window-size=1280,2000",
                  # belt and braces: no host name resolves, so nothing could reach the internet
                  "--host-resolver-rules=MAP * ~NOTFOUND , EXCLUDE localhost")
LOAD_TIMEOUT = 20.0  # [s] for the page and its pictures on a slow CI machine
# chrome:// and about: are resources built into the browser (its start page loads some while the
# report loads); they never touch the network.
# the browser's own pages (a new tab, devtools) are not requests that leave the machine
LOCAL_SCHEMES = {"file", "data", "chrome", "chrome-untrusted", "devtools", "about"}


def _unavailable(reason: str) -> None:
    msg = (f"browser test cannot run: {reason}. Install with `apt-get install -y chromium "
           "chromium-driver` and `pip install selenium`.")
    if os.environ.get("CI"):
        pytest.fail(msg)
    pytest.skip(msg)


def _find(*names: str) -> str | None:
    for name in names:
        path = shutil.which(name)
        if path:
            return path
    return None


@pytest.fixture(scope="module")
def browser(tmp_path_factory: pytest.TempPathFactory) -> Iterator[object]:
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
    except ImportError:
        _unavailable("the Python package selenium is not installed")
    chromium = _find("chromium", "chromium-browser", "google-chrome")
    driver_path = _find("chromedriver")
    if chromium is None:
        _unavailable("no chromium executable on PATH")
    if driver_path is None:
        _unavailable("no chromedriver executable on PATH")
    opts = webdriver.ChromeOptions()
    opts.binary_location = chromium
    for flag in CHROMIUM_FLAGS:
        opts.add_argument(flag)
    opts.add_argument(f"--user-data-dir={tmp_path_factory.mktemp('chromium-profile')}")
    # console messages and every network event of the page, read back after loading
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL", "performance": "ALL"})
    # explicit driver path: Selenium Manager (which would download drivers) is never started
    driver = webdriver.Chrome(options=opts, service=Service(executable_path=driver_path))
    driver.set_page_load_timeout(LOAD_TIMEOUT)
    try:
        yield driver
    finally:
        driver.quit()


def _open(driver, page: Path) -> tuple[list[dict], list[str]]:
    """Load ``page`` and its pictures; return (console entries, requested URLs)."""
    driver.get_log("browser")  # drop what earlier pages left
    driver.get_log("performance")
    driver.get(page.as_uri())
    # pictures are lazy-loaded: bring each into view, then wait until all have finished
    driver.execute_script("for (const i of document.images) { i.loading = 'eager'; i.scrollIntoView(); }")
    deadline = time.monotonic() + LOAD_TIMEOUT
    while time.monotonic() < deadline:
        if driver.execute_script("return document.readyState === 'complete' && "
                                 "Array.from(document.images).every(i => i.complete)"):
            break
        time.sleep(0.1)
    console = driver.get_log("browser")
    urls = []
    for entry in driver.get_log("performance"):
        msg = json.loads(entry["message"])["message"]
        if msg.get("method") == "Network.requestWillBeSent":
            urls.append(msg["params"]["request"]["url"])
    return console, urls


def test_report_loads_offline_with_all_pictures(browser, make_run) -> None:
    run = make_run([{"scenario": make_scenario(1, narrative=HOSTILE), "scenic": True},
                    {"verdict": incomplete()},
                    {"verdict": verified(), "error": HOSTILE}], behavior_text=HOSTILE)
    report = write_report(run)
    console, urls = _open(browser, report)

    errors = [e for e in console if e.get("level") == "SEVERE"]
    assert errors == [], f"console errors: {errors}"
    images = browser.execute_script(
        "return Array.from(document.images).map(i => [i.getAttribute('src'), i.complete, i.naturalWidth])")
    assert len(images) == 1 + 3 * 3  # graph + GIF, key frames and its gallery card per scenario
    broken = [src for src, complete, width in images if not (complete and width > 0)]
    assert broken == [], f"pictures that did not load: {broken}"
    assert any(src.endswith("bird_eye.gif") for src, _, _ in images)
    # escaping held: the hostile text is on the page as text, and no script exists or ran
    assert browser.execute_script("return document.scripts.length") == 0
    assert HOSTILE in browser.find_element("css selector", "p.narrative").text
    # every request stayed on this machine; the log did see the page and the GIFs
    remote = [u for u in urls if urlsplit(u).scheme not in LOCAL_SCHEMES]
    assert remote == [], f"requests left the machine: {remote}"
    assert any(u.endswith("/report.html") for u in urls)
    assert sum(u.endswith("/bird_eye.gif") for u in urls) == 3


def test_the_checks_can_fail(browser, tmp_path: Path) -> None:
    """The same checks on a bad page do see a broken picture and a remote request."""
    page = tmp_path / "bad.html"
    page.write_text('<!DOCTYPE html><link rel="icon" href="data:,"><img src="nothing-here.gif">'
                    '<img src="http://127.0.0.1:9/x.png">')  # discard port: stays local, fails
    console, urls = _open(browser, page)
    assert any(e.get("level") == "SEVERE" for e in console)
    widths = browser.execute_script("return Array.from(document.images).map(i => i.naturalWidth)")
    assert widths == [0, 0]
    assert "http://127.0.0.1:9/x.png" in urls
