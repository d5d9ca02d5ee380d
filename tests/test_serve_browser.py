"""``leapfrog serve`` in a real browser: headless Chromium (Debian's ``chromium`` and
``chromium-driver``, which ``.ci/run`` installs) driven by Selenium against the command started
in a subprocess. Load the page, choose paper case 4, see the path and its cost; drag an obstacle
and see both change; type a bad value and see the error; download the scenario and plan it with
the command line to the cost the page showed."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest
from tests.serving import free_port, wait_ready

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
DRIVER = shutil.which("chromedriver")

pytestmark = pytest.mark.skipif(
    CHROMIUM is None or DRIVER is None,
    reason="needs Debian's chromium and chromium-driver (apt-get install chromium chromium-driver)",
)

webdriver = pytest.importorskip("selenium.webdriver")
pytest.importorskip("uvicorn")

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
