"""``leapfrog serve`` in a real browser: headless Chromium (Debian's ``chromium`` and
``chromium-driver``, which ``.ci/run`` installs) driven by Selenium against the command started
in a subprocess. Load the page, choose paper case 4, see the path and its cost; drag an obstacle
and see both change; type a bad value and see the error; download the scenario and plan it with
the command line to the cost the page showed."""

from __future__ import annotations

import io
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest
from tests.gated_worker import GATE, serve_command
from tests.serving import free_port, wait_ready

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
DRIVER = shutil.which("chromedriver")

pytestmark = pytest.mark.skipif(
    CHROMIUM is None or DRIVER is None,
    reason="needs Debian's chromium and chromium-driver (apt-get install chromium chromium-driver)",
)

webdriver = pytest.importorskip("selenium.webdriver")
pytest.importorskip("uvicorn")

from selenium.common.exceptions import WebDriverException  # noqa: E402
from selenium.webdriver.common.action_chains import ActionChains  # noqa: E402
from selenium.webdriver.common.by import By  # noqa: E402
from selenium.webdriver.support.ui import Select, WebDriverWait  # noqa: E402

READY_TIMEOUT = 120.0  # a fresh machine compiles the kernels first
WAIT = 20.0


@pytest.fixture(scope="module")
def server():
    port = free_port()
    argv = [sys.executable, "-m", "leapfrog_planner.cli", "serve", "--port", str(port)]
    proc = subprocess.Popen([*argv, "--workers", "1"], stdout=subprocess.DEVNULL)
    url = f"http://127.0.0.1:{port}"
    try:
        not_ready = wait_ready(proc, url, READY_TIMEOUT)
        if not_ready:
            pytest.fail(not_ready)
        yield url
    finally:
        proc.terminate()
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


@pytest.fixture(scope="module")
def downloads(tmp_path_factory):
    return tmp_path_factory.mktemp("downloads")


@pytest.fixture(scope="module")
def browser(downloads):
    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for arg in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage"):
        options.add_argument(arg)
    options.add_argument("--window-size=1400,1000")
    options.add_experimental_option("prefs", {"download.default_directory": str(downloads)})
    driver = webdriver.Chrome(service=webdriver.ChromeService(DRIVER), options=options)
    driver.execute_cdp_cmd(
        "Page.setDownloadBehavior", {"behavior": "allow", "downloadPath": str(downloads)}
    )
    yield driver
    driver.quit()


def _text(driver, element_id: str) -> str:
    return driver.find_element(By.ID, element_id).text


def _path_points(driver) -> str:
    lines = driver.find_elements(By.CSS_SELECTOR, "#path polyline")
    return " ".join(line.get_attribute("points") for line in lines)


def _case4(driver, url):
    driver.get(url)
    wait = WebDriverWait(driver, WAIT)
    wait.until(lambda d: _text(d, "cost") not in ("", "–"))  # paper case 1, planned on load
    Select(driver.find_element(By.ID, "scenario")).select_by_value("paper-case-4")
    wait.until(lambda d: _text(d, "cost") == "4.58525")


def test_paper_case_4_is_planned_and_drawn(server, browser):
    _case4(browser, server)
    assert len(browser.find_elements(By.CSS_SELECTOR, "#path polyline")) >= 1
    assert len(browser.find_elements(By.CSS_SELECTOR, "circle.obstacle")) == 7
    assert _text(browser, "status").startswith("converged")
    assert browser.find_element(By.ID, "error").is_displayed() is False


def test_dragging_an_obstacle_moves_the_path(server, browser, downloads):
    _case4(browser, server)
    before = _path_points(browser)
    obstacle = browser.find_element(By.CSS_SELECTOR, 'circle[data-obstacle="3"]')
    ActionChains(browser).click_and_hold(obstacle).move_by_offset(0, 15).move_by_offset(
        0, 15
    ).release().perform()
    wait = WebDriverWait(browser, WAIT)
    wait.until(
        lambda d: (
            _text(d, "cost") not in ("4.58525", "–")
            and not d.find_element(By.ID, "busy").is_displayed()
        )
    )
    assert _path_points(browser) != before
    assert _text(browser, "status").startswith("converged")
    cost = float(_text(browser, "cost"))
    # the page's scenario file, planned by the command line, gives the cost the page shows
    browser.find_element(By.ID, "dl-toml").click()
    toml = downloads / "paper-case-4.toml"
    wait.until(lambda d: toml.exists() and toml.stat().st_size > 0)
    out = downloads / "result.json"
    cmd = [sys.executable, "-m", "leapfrog_planner.cli", "solve", str(toml), "--quiet"]
    subprocess.run([*cmd, "--json", str(out)], check=True, timeout=120)
    assert json.loads(out.read_text())["cost"] == pytest.approx(cost, rel=2e-6)
    assert "center = [1.3, -0.1]" not in toml.read_text()  # the dragged obstacle moved


def test_a_bad_value_shows_the_error(server, browser):
    _case4(browser, server)
    browser.find_element(By.CSS_SELECTOR, 'circle[data-obstacle="2"]').click()
    field = browser.find_element(By.ID, "ob-r")
    field.clear()
    field.send_keys("-0.1")
    error = browser.find_element(By.ID, "error")
    WebDriverWait(browser, WAIT).until(lambda d: error.is_displayed())
    assert error.text == "scenario: obstacles[2].radius: must be > 0, got -0.1"
    field.clear()
    field.send_keys("0.1")
    WebDriverWait(browser, WAIT).until(lambda d: not error.is_displayed())
    WebDriverWait(browser, WAIT).until(lambda d: _text(d, "cost") == "4.58525")


def test_a_free_final_time_is_chosen_on_the_page(server, browser, downloads):
    """Tick "free time": the planner chooses T at the cruise speed, the page shows it, and the
    scenario downloaded plans to the same cost from the command line."""
    browser.get(server)
    wait = WebDriverWait(browser, WAIT)
    wait.until(lambda d: _text(d, "cost") not in ("", "–"))  # paper case 1, planned on load
    assert not browser.find_element(By.ID, "chosen-row").is_displayed()
    browser.find_element(By.ID, "free-time").click()
    assert not browser.find_element(By.ID, "horizon").is_enabled()
    wait.until(lambda d: d.find_element(By.ID, "chosen-row").is_displayed())
    wait.until(lambda d: not d.find_element(By.ID, "busy").is_displayed())
    # paper case 1 at a cruise speed of 1 (k = 1/2): free space, so T and J are those of k = 1
    # (3.212974 and 6.425948) times sqrt(2) and divided by it
    T = float(_text(browser, "chosen").split()[0])
    assert T == pytest.approx(3.212974 * 2**0.5, rel=1e-5)
    assert float(_text(browser, "cost")) == pytest.approx(6.425948 / 2**0.5, rel=1e-5)
    browser.find_element(By.ID, "dl-toml").click()
    toml = downloads / "paper-case-1.toml"
    wait.until(lambda d: toml.exists() and 'horizon = "free"' in toml.read_text())
    browser.find_element(By.ID, "free-time").click()  # back to the fixed horizon
    wait.until(lambda d: not d.find_element(By.ID, "chosen-row").is_displayed())
    assert browser.find_element(By.ID, "horizon").get_attribute("value") == "1"


def test_downloads_of_the_result_and_the_view(server, browser, downloads):
    _case4(browser, server)
    for button, name in (("dl-json", "paper-case-4.json"), ("dl-csv", "paper-case-4.csv")):
        browser.find_element(By.ID, button).click()
        WebDriverWait(browser, WAIT).until(lambda d, n=name: (downloads / n).exists())
    browser.find_element(By.ID, "dl-png").click()
    png = downloads / "paper-case-4.png"
    WebDriverWait(browser, WAIT).until(lambda d: png.exists() and png.stat().st_size > 1000)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    time.sleep(0.2)
    d = json.loads(Path(downloads / "paper-case-4.json").read_text())
    assert d["cost"] == pytest.approx(4.585248, abs=1e-6)


MAPS = Path(__file__).parent / "data" / "maps"
#: The TurtleBot3 arena: its nine pillars stand 1.1 m apart about (0, 0); between two rows of
#: them, a straight run of 3.2 m (the horizon the page sets: 6.4 s at 0.5 m/s).
ARENA_START, ARENA_GOAL = (-1.6, -0.55), (1.6, -0.55)


def _click_world(driver, x: float, y: float) -> None:
    """A click on the view at the world point (x, y) (the page's own transform)."""
    view = driver.find_element(By.ID, "view")
    px, py, w, h = driver.execute_script(
        "const T = transform($('view')); return [T.X(arguments[0]), T.Y(arguments[1]), T.w, T.h];",
        x,
        y,
    )
    ActionChains(driver).move_to_element_with_offset(view, px - w / 2, py - h / 2).click().perform()


def _pixels(png: bytes, box) -> set:
    from PIL import Image

    image = Image.open(io.BytesIO(png)).convert("RGB").crop(box)
    return {c for _, c in image.getcolors(image.width * image.height)}


def test_a_map_is_opened_and_planned_on(server, browser, tmp_path):
    browser.get(server)
    wait = WebDriverWait(browser, WAIT)
    wait.until(lambda d: _text(d, "cost") not in ("", "–"))  # paper case 1, planned on load
    t0 = time.perf_counter()
    browser.find_element(By.ID, "map-yaml").send_keys(str(MAPS / "tb3_sandbox.yaml"))
    browser.find_element(By.ID, "map-image").send_keys(str(MAPS / "tb3_sandbox.pgm"))
    image = wait.until(lambda d: d.find_elements(By.CSS_SELECTOR, "#view image#map"))[0]
    assert image.get_attribute("href").startswith("data:image/png;base64,")
    assert "robot radius 0.2 m, weight W 1" in _text(browser, "map-info")
    assert browser.find_element(By.ID, "radius").get_attribute("value") == "0.2"
    assert browser.find_element(By.ID, "weight").get_attribute("value") == "1"
    assert not browser.find_element(By.ID, "error").is_displayed()
    # the view fits the arena (the known cells), not the whole 19.2 m square of the map
    box = image.rect
    view = browser.find_element(By.ID, "view").rect
    assert box["width"] > 1.3 * view["width"] and box["height"] > 1.3 * view["height"]

    _click_world(browser, *ARENA_START)  # a click places the start, the next the goal
    time.sleep(0.4)
    _click_world(browser, *ARENA_GOAL)

    def placed(d):
        got = [float(d.find_element(By.ID, f"{k}-{i}").get_attribute("value")) for k in
               ("start", "goal") for i in (0, 1)]  # fmt: skip
        return all(abs(a - b) < 0.05 for a, b in zip(got, ARENA_START + ARENA_GOAL, strict=True))

    wait.until(placed)
    wait.until(
        lambda d: (
            _text(d, "status").startswith("converged")
            and not d.find_element(By.ID, "busy").is_displayed()
        )
    )
    elapsed = time.perf_counter() - t0
    assert float(browser.find_element(By.ID, "horizon").get_attribute("value")) == 6.4
    assert len(browser.find_elements(By.CSS_SELECTOR, "#path polyline")) >= 1
    assert float(_text(browser, "clearance")) > 0
    shot = browser.find_element(By.ID, "view").screenshot_as_png
    (tmp_path / "map-view.png").write_bytes(shot)
    colors = _pixels(shot, (0, 0, int(view["width"]), int(view["height"])))
    assert (205, 205, 205) in colors  # the map's unknown cells, as ROS shows them
    assert (0, 0, 0) in colors  # its occupied cells
    assert (0x15, 0x65, 0xC0) in colors  # the path over it
    assert elapsed < 15.0


@pytest.fixture
def preparing_server(tmp_path):
    """``leapfrog serve`` whose solver waits at each model until its gate is opened (a fresh
    machine compiling the kernels): see :mod:`tests.gated_worker`."""
    port = free_port()
    root = str(Path(__file__).resolve().parent.parent)
    env = {**os.environ, GATE: str(tmp_path), "PYTHONPATH": os.pathsep.join([root + "/src", root])}
    proc = subprocess.Popen(serve_command(port), stdout=subprocess.DEVNULL, env=env)
    try:
        yield f"http://127.0.0.1:{port}", tmp_path
    finally:
        proc.terminate()
        proc.wait(10)


def test_the_page_shows_the_solver_being_prepared_then_plans(preparing_server, browser):
    url, gate = preparing_server
    wait = WebDriverWait(browser, WAIT)
    for _ in range(100):  # the server answers within moments of its start
        try:
            browser.get(url)
            break
        except WebDriverException:
            time.sleep(0.1)
    banner = browser.find_element(By.ID, "preparing")
    wait.until(lambda d: banner.is_displayed())
    assert _text(browser, "preparing-text").startswith(
        "Preparing the solver: the unicycle kernels (model 1 of 3)"
    )
    bar = browser.find_element(By.ID, "preparing-bar")
    assert (bar.get_attribute("value"), bar.get_attribute("max")) == ("0", "3")
    (gate / "unicycle").touch()
    wait.until(lambda d: "(model 2 of 3)" in _text(d, "preparing-text"))
    assert bar.get_attribute("value") == "1"
    assert _text(browser, "cost") == "–"  # paper case 1 waits for the solver
    assert not browser.find_element(By.ID, "error").is_displayed()
    for model in ("diff-drive", "car"):
        (gate / model).touch()
    WebDriverWait(browser, 60).until(lambda d: not banner.is_displayed())
    wait.until(lambda d: _text(d, "status").startswith("converged"))  # planned once it was ready
    assert not browser.find_element(By.ID, "error").is_displayed()
