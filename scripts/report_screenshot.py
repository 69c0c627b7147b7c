"""Make docs/images/report.png: the top of a build's report.html in headless Chromium.

    python scripts/report_screenshot.py BUILD_DIR [OUT_PNG]

BUILD_DIR is a folder `handarm build` wrote (its report.html is rewritten first, from its
files). Needs Chromium, chromedriver and selenium (the test extra). The picture is shrunk and
reduced to a palette so the committed file stays small.
"""

import io
import sys
from pathlib import Path

from PIL import Image

from handarm.report import write_report
from handarm.report.browser import headless_chromium, wait_for_plots


def main(build_dir: str, out: str = "docs/images/report.png") -> None:
    """Rewrite BUILD_DIR/report.html, photograph its top, save a small PNG at ``out``."""
    page = write_report(build_dir)
    drv = headless_chromium(1240, 900)
    try:
        drv.get(page.resolve().as_uri())
        wait_for_plots(drv, 1000)
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
