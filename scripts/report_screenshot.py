"""Make docs/images/report.png: the top of a build's report.html in headless Chromium.

    python scripts/report_screenshot.py BUILD_DIR [OUT_PNG]

BUILD_DIR is a folder `handarm build` wrote (its report.html is rewritten first, from its
files). Needs Chromium, chromedriver and selenium (the test extra). The picture is shrunk and
reduced to a palette so the committed file stays small.
"""

import io
import sys
import tempfile
from pathlib import Path
from shutil import which

from PIL import Image
from selenium import webdriver
from selenium.webdriver.chrome.options import Options
from selenium.webdriver.chrome.service import Service

from handarm.report import write_report

FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--enable-unsafe-swiftshader",
    "--window-size=1240,900",
)


def main(build_dir: str, out: str = "docs/images/report.png") -> None:
    """Rewrite BUILD_DIR/report.html, photograph its top, save a small PNG at ``out``."""
    page = write_report(build_dir)
    opts = Options()
    opts.binary_location = which("chromium") or which("chromium-browser")
    for flag in FLAGS:
        opts.add_argument(flag)
    opts.add_argument(f"--user-data-dir={tempfile.mkdtemp(prefix='handarm-shot-')}")
    drv = webdriver.Chrome(options=opts, service=Service(which("chromedriver")))
    try:
        drv.set_script_timeout(120)
        drv.get(page.resolve().as_uri())
        drv.execute_async_script(
            "const done = arguments[0];"
            "const wait = () => [...document.querySelectorAll('.plot')].every(d => d._fullLayout)"
            " ? setTimeout(done, 1000) : setTimeout(wait, 100); wait();"
        )
        # a pose that shows the arm bent in both planes
        drv.execute_script("window.handarmReport.setPose([30, 60, -40, 45, 60, -30]);")
        drv.execute_async_script("setTimeout(arguments[0], 1000);")
        png = drv.get_screenshot_as_png()
    finally:
        drv.quit()
    img = Image.open(io.BytesIO(png)).convert("RGB")
    img = img.resize((img.width * 3 // 4, img.height * 3 // 4), Image.LANCZOS)
    img = img.quantize(colors=160, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE)
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    img.save(out, optimize=True)
    print(f"{out}: {Path(out).stat().st_size / 1e3:.0f} kB")


if __name__ == "__main__":
    main(*sys.argv[1:])
