"""Screenshots of the ``leapfrog serve`` page in headless Chromium: ``docs/serve.png`` (paper
case 4, as the README shows it) and, with ``--all DIR``, one of each of the page's controls in
use (a car with bounds, a footprint and two waypoints; a differential drive with bounded
wheels; a robot with a footprint among paper case 4's obstacles; the ticks of paper case 3;
paper case 4's six initial paths and their labels).

    python benchmarks/page_screenshots.py [--out docs/serve.png] [--all /tmp/page-shots]

Needs Debian's chromium and chromium-driver and selenium (as tests/test_serve_browser.py).
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import time
from pathlib import Path

from selenium import webdriver
from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.by import By
from selenium.webdriver.common.keys import Keys
from selenium.webdriver.support.ui import Select, WebDriverWait

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from tests.serving import free_port, wait_ready  # noqa: E402

WAIT = 60.0


def browser(width: int, height: int):
    options = webdriver.ChromeOptions()
    options.binary_location = shutil.which("chromium") or shutil.which("chromium-browser")
    for arg in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage"):
        options.add_argument(arg)
    options.add_argument(f"--window-size={width},{height}")
    service = webdriver.ChromeService(shutil.which("chromedriver"))
    return webdriver.Chrome(service=service, options=options)


class Page:
    """The page in a browser, with the edits a user makes."""

    def __init__(self, driver, url: str):
        self.d = driver
        driver.get(url)
        self.wait_plan()

    def text(self, element_id: str) -> str:
        return self.d.find_element(By.ID, element_id).text

    def wait_plan(self) -> None:
        """Until the last edit is planned and drawn."""
        time.sleep(0.6)
        WebDriverWait(self.d, WAIT).until(
            lambda d: (
                self.text("cost") not in ("", "–")
                and not d.find_element(By.ID, "busy").is_displayed()
            )
        )
        time.sleep(0.3)

    def choose(self, element_id: str, value: str) -> None:
        Select(self.d.find_element(By.ID, element_id)).select_by_value(value)
        self.wait_plan()

    def type(self, **fields) -> None:
        for element_id, value in fields.items():
            field = self.d.find_element(By.ID, element_id.replace("__", "-"))
            field.clear()
            field.send_keys(str(value))
        self.wait_plan()

    def shift_click(self, x: float, y: float) -> None:
        view = self.d.find_element(By.ID, "view")
        px, py, w, h = self.d.execute_script(
            "const T = transform($('view')); return [T.X(arguments[0]), T.Y(arguments[1]),"
            " T.w, T.h];",
            x,
            y,
        )
        chain = ActionChains(self.d).key_down(Keys.SHIFT)
        chain.move_to_element_with_offset(view, px - w / 2, py - h / 2).click()
        chain.key_up(Keys.SHIFT).perform()
        self.wait_plan()

    def scroll_to(self, element_id: str) -> None:
        self.d.execute_script(f"document.getElementById('{element_id}').scrollIntoView()")

    def shot(self, path: Path) -> None:
        self.d.save_screenshot(str(path))
        print(f"{path}: {self.text('status')[:70]!r}, cost {self.text('cost')}")


def all_controls(url: str, folder: Path) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    driver = browser(1400, 1250)
    try:
        page = Page(driver, url)
        page.choose("scenario", "paper-case-3")
        page.shot(folder / "ticks-paper-case-3.png")
        page.choose("scenario", "paper-case-4")
        page.type(initial_paths=6)
        page.shot(folder / "labels-paper-case-4-six-paths.png")
        page.type(initial_paths=3, radius=0.02, margin=0.005)
        page.shot(folder / "footprint-paper-case-4.png")
        page.type(radius=0, margin=0)
        page.choose("model", "diff-drive")
        page.type(horizon=1.5, **{"bound__omega_R__min": -3, "bound__omega_R__max": 3})
        page.type(**{"bound__omega_L__min": -3, "bound__omega_L__max": 3})
        page.shot(folder / "diff-drive-bounded-wheels.png")
        page.choose("scenario", "paper-case-1")
        page.choose("model", "car")
        page.type(horizon=3, bound__v__min=-1, bound__v__max=1.2)
        driver.find_element(By.ID, "add").click()
        page.type(ob__cx=0, ob__cy=2, ob__r=0.15, radius=0.05, margin=0.01)
        page.shift_click(-0.4, 2.4)
        page.shift_click(0.4, 2.4)
        page.shot(folder / "car-bounds-footprint-waypoints.png")
        page.scroll_to("robot-panel")
        page.shot(folder / "car-panels.png")
    finally:
        driver.quit()


def readme_shot(url: str, out: Path) -> None:
    driver = browser(1400, 1000)
    try:
        page = Page(driver, url)
        page.choose("scenario", "paper-case-4")
        page.shot(out)
    finally:
        driver.quit()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("docs/serve.png"))
    parser.add_argument("--all", type=Path, help="also a screenshot of each control, here")
    args = parser.parse_args()
    port = free_port()
    argv = [sys.executable, "-m", "leapfrog_planner.cli", "serve", "--port", str(port)]
    proc = subprocess.Popen([*argv, "--workers", "1"], stdout=subprocess.DEVNULL)
    url = f"http://127.0.0.1:{port}"
    try:
        not_ready = wait_ready(proc, url, 600)
        if not_ready:
            sys.exit(not_ready)
        readme_shot(url, args.out)
        if args.all:
            all_controls(url, args.all)
    finally:
        proc.terminate()
        proc.wait(10)


if __name__ == "__main__":
    main()
