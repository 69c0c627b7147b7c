"""Headless Chromium for looking at reports (the browser test, the README picture).

Needs the ``selenium`` package (in the ``test`` extra) and Chromium with chromedriver from
the system (Debian: ``apt-get install chromium chromium-driver``).
"""

from __future__ import annotations

import shutil
import tempfile

__all__ = ["CHROMIUM_FLAGS", "find_chromium", "headless_chromium", "wait_for_plots"]

#: Flags for a quiet, offline, throw-away headless Chromium (a fresh profile is added).
CHROMIUM_FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--enable-unsafe-swiftshader",  # software WebGL for the 3D views
)


def find_chromium() -> tuple[str, str] | None:
    """Paths of Chromium and chromedriver, or None when either is missing."""
    binary = shutil.which("chromium") or shutil.which("chromium-browser")
    driver = shutil.which("chromedriver")
    return (binary, driver) if binary and driver else None


def headless_chromium(width: int = 1300, height: int = 1800):
    """A selenium WebDriver on headless Chromium with a fresh profile; the caller quits it.

    Quitting it removes the profile's temporary folder.

    Parameters
    ----------
    width, height : int
        Window size (CSS pixels).

    Raises
    ------
    RuntimeError
        If selenium, Chromium or chromedriver is not installed.
    """
    found = find_chromium()
    if found is None:
        raise RuntimeError("no browser: install chromium and chromium-driver")
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.options import Options
        from selenium.webdriver.chrome.service import Service
    except ImportError:
        raise RuntimeError("selenium is not installed: pip install 'handarm[test]'") from None
    opts = Options()
    opts.binary_location = found[0]
    for flag in CHROMIUM_FLAGS:
        opts.add_argument(flag)
    opts.add_argument(f"--window-size={width},{height}")
    profile = tempfile.mkdtemp(prefix="handarm-chromium-")
    opts.add_argument(f"--user-data-dir={profile}")
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    try:
        drv = webdriver.Chrome(options=opts, service=Service(found[1]))
    except BaseException:
        shutil.rmtree(profile, ignore_errors=True)
        raise
    drv.set_script_timeout(120)  # software WebGL on a busy machine
    quit_browser = drv.quit

    def quit_and_remove_profile() -> None:
        # the profile (2.5 MB) was left in /tmp after every screenshot and test run
        try:
            quit_browser()
        finally:
            shutil.rmtree(profile, ignore_errors=True)

    drv.quit = quit_and_remove_profile
    return drv


def wait_for_plots(drv, settle_ms: int = 500) -> None:
    """Wait until every plot div of the loaded page is laid out, then ``settle_ms`` more."""
    drv.execute_async_script(
        "const done = arguments[arguments.length - 1], ms = arguments[0];"
        "const wait = () => [...document.querySelectorAll('.plot')].every(d => d._fullLayout)"
        " ? setTimeout(done, ms) : setTimeout(wait, 100); wait();",
        settle_ms,
    )
