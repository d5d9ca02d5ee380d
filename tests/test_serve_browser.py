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


def _settled(driver) -> bool:
    """The last edit planned and drawn (the page plans a moment after an edit)."""
    return not driver.find_element(By.ID, "busy").is_displayed()


def _type(driver, element_id: str, text) -> None:
    field = driver.find_element(By.ID, element_id)
    field.clear()
    field.send_keys(str(text))


def _numbers(driver, selector: str) -> list[str]:
    """The texts of ``selector`` that are numbers (the tick labels)."""
    out = []
    for e in driver.find_elements(By.CSS_SELECTOR, selector):
        try:
            float(e.text)
        except ValueError:
            continue
        out.append(e.text)
    return out


def test_a_motion_that_is_not_optimal_is_labelled_so_in_a_legend_that_holds_it(server, browser):
    """A failed result's motion: its legend entry says what it is and that it is not optimal
    (an old file's "extremal" too), inside the legend's box; a result without a motion (start
    and goal not connected, a free final time without k + H) draws no entry, and no script
    error (execute_script would raise)."""
    import dataclasses

    from tests.test_cli import ENCLOSED

    from leapfrog_planner import plan
    from leapfrog_planner.planning.scenario import load_scenario_text
    from leapfrog_planner.planning.status import PlanStatus
    from leapfrog_planner.web.view import result_view

    _case4(browser, server)
    r = plan("paper-case-1", initial_paths=1)
    inject = "state.scenario = arguments[0]; state.result = arguments[1]; render();"
    for source, says in (
        ("extremal", "extremal, not optimal"),
        ("extremal of the fixed horizon T = 4.295, not optimal", None),
    ):
        failed = dataclasses.replace(
            r, status=PlanStatus.FAILED, optimal=False, trajectory_source=source
        )
        view = json.loads(json.dumps(result_view(failed)))
        browser.execute_script(inject, r.task.to_dict(), view)
        legend = browser.find_element(By.ID, "legend")
        assert (says or source) in legend.text.splitlines()
        box = legend.find_element(By.TAG_NAME, "rect").rect
        for text in legend.find_elements(By.TAG_NAME, "text"):
            assert text.rect["x"] + text.rect["width"] <= box["x"] + box["width"]
    enclosed = plan(
        load_scenario_text(ENCLOSED.replace("5.0", '"free"') + "[cost]\ncruise_speed = 1.0\n")
    )
    view = json.loads(json.dumps(result_view(enclosed)))
    browser.execute_script(inject, enclosed.task.to_dict(), view)
    assert "not optimal" not in browser.find_element(By.ID, "legend").text
    assert _text(browser, "clearance") == "–" and "no extremal there" in _text(browser, "chosen")


def test_polygons_and_walls_are_drawn(server, browser):
    """A scenario's polygons and walls are drawn as its discs are (the page drew neither: a
    path kept clear of shapes nobody saw), in view, a wall as thick as it is."""
    from tests.test_cli import ENCLOSED

    from leapfrog_planner import plan
    from leapfrog_planner.planning.scenario import load_scenario_text
    from leapfrog_planner.web.view import result_view

    _case4(browser, server)
    text = ENCLOSED + "[[polygons]]\npoints = [[1.0, -0.5], [1.5, -0.5], [1.2, -0.2]]\n"
    r = plan(load_scenario_text(text))  # start and goal not connected: planned at once
    view = json.loads(json.dumps(result_view(r)))
    inject = "state.scenario = arguments[0]; state.result = arguments[1]; fitBounds(); render();"
    browser.execute_script(inject, r.task.to_dict(), view)
    polygons = browser.find_elements(By.CSS_SELECTOR, "#shapes polygon.polygon")
    walls = browser.find_elements(By.CSS_SELECTOR, "#shapes polyline.wall")
    assert len(polygons) == 1 and len(walls) == 1
    room = browser.find_element(By.ID, "view").rect
    wall = walls[0].rect  # the square of walls about the goal, inside the drawing
    assert room["x"] <= wall["x"] and wall["x"] + wall["width"] <= room["x"] + room["width"]
    assert 0 < wall["width"] < room["width"] and wall["height"] > 0
    scale = browser.execute_script("return transform(document.getElementById('view')).s;")
    width = float(walls[0].get_attribute("stroke-width"))
    assert width == pytest.approx(max(0.1 * scale, 1.0), rel=1e-6)


def test_ticks_are_round_numbers(server, browser):
    """Paper case 3's view has a grid line at x = 0 reached from -0.6 in steps of 0.2: its
    label reads 0 (it read -5.551e-17), and every tick of the room and the plots is a short
    round number."""
    browser.get(server)
    wait = WebDriverWait(browser, WAIT)
    wait.until(lambda d: _text(d, "cost") not in ("", "–"))
    case1 = _text(browser, "cost")
    Select(browser.find_element(By.ID, "scenario")).select_by_value("paper-case-3")
    wait.until(lambda d: _text(d, "cost") not in (case1, "–") and _settled(d))
    room = _numbers(browser, "#view text")
    plots = _numbers(browser, "#plots text")
    assert "0" in room and len(room) >= 8 and len(plots) >= 8
    for label in room + plots:
        assert "e" not in label and len(label.lstrip("-").split(".")[-1]) <= 3, label
        assert not label.startswith("-0") or float(label) != 0, label


def _boxes_overlap(a: dict, b: dict) -> bool:
    return (
        a["x"] < b["x"] + b["width"]
        and b["x"] < a["x"] + a["width"]
        and a["y"] < b["y"] + b["height"]
        and b["y"] < a["y"] + a["height"]
    )


def test_the_alternatives_labels_do_not_overlap(server, browser):
    """Paper case 4 with six initial paths: six other extremals (seven paths: two found one
    extremal, listed once), two of them close together in the middle (their labels overlapped
    there); their labels ("converged 5.66387") are drawn, and no two of their boxes overlap."""
    _case4(browser, server)
    planned = browser.execute_script("return seq")  # the page's count of plans asked for
    _type(browser, "initial_paths", 6)
    wait = WebDriverWait(browser, WAIT)
    wait.until(lambda d: d.execute_script("return seq") > planned and _settled(d))
    assert len(browser.find_elements(By.CSS_SELECTOR, "#alternatives-layer polyline")) >= 6
    texts = [
        e
        for e in browser.find_elements(By.CSS_SELECTOR, "#view text")
        if e.text.split(" ")[0] in ("converged", "collides", "failed", "max-iterations")
    ]
    assert len(texts) >= 6
    boxes = [e.rect for e in texts]
    for i, a in enumerate(boxes):
        for b in boxes[:i]:
            assert not _boxes_overlap(a, b), (a, b)


def _shift_click_world(driver, x: float, y: float) -> None:
    from selenium.webdriver.common.keys import Keys

    view = driver.find_element(By.ID, "view")
    px, py, w, h = driver.execute_script(
        "const T = transform($('view')); return [T.X(arguments[0]), T.Y(arguments[1]), T.w, T.h];",
        x,
        y,
    )
    chain = ActionChains(driver).key_down(Keys.SHIFT)
    chain.move_to_element_with_offset(view, px - w / 2, py - h / 2).click().key_up(Keys.SHIFT)
    chain.perform()


def _plotted(driver) -> list[str]:
    return [
        e.get_attribute("data-control") for e in driver.find_elements(By.CSS_SELECTOR, "#plots svg")
    ]


def test_the_robot_bounds_footprint_and_waypoints_are_planned_and_downloaded(
    server, browser, downloads
):
    """A car with a bound on its speed, a footprint and two waypoints set on the page: each
    change plans again, the plots follow the car's controls, and the scenario file the page
    gives plans from the command line to the cost the page shows."""
    browser.get(server)
    wait = WebDriverWait(browser, WAIT)
    wait.until(lambda d: _text(d, "cost") not in ("", "–"))  # paper case 1, planned on load
    assert _plotted(browser) == ["v", "omega"]
    Select(browser.find_element(By.ID, "model")).select_by_value("diff-drive")
    wait.until(lambda d: _plotted(d) == ["omega_R", "omega_L"] and _settled(d))
    assert browser.find_element(By.ID, "param-wheel_radius").get_attribute("placeholder") == "1"
    assert browser.find_element(By.ID, "bound-omega_R-max").is_displayed()
    assert _text(browser, "status").startswith("converged")

    Select(browser.find_element(By.ID, "model")).select_by_value("car")
    wait.until(lambda d: _plotted(d) == ["v", "sigma", "omega"] and _settled(d))
    assert browser.find_element(By.ID, "start-3").is_displayed()  # the steering angle
    _type(browser, "horizon", 3)
    wait.until(lambda d: _settled(d) and _text(d, "status").startswith("converged"))
    free = _text(browser, "cost")
    _type(browser, "bound-v-min", -1)
    _type(browser, "bound-v-max", 1.2)
    wait.until(lambda d: _settled(d) and _text(d, "cost") not in (free, "–"))
    assert "in [-1, 1.2]" in browser.find_element(By.CSS_SELECTOR, "#plot-0 .plot-title").text
    assert len(browser.find_elements(By.CSS_SELECTOR, "#plot-0 line.bound")) == 2
    browser.find_element(By.ID, "add").click()  # an obstacle on the straight way
    for field, value in (("ob-cx", 0), ("ob-cy", 2), ("ob-r", 0.15)):
        _type(browser, field, value)
    _type(browser, "radius", 0.05)
    _type(browser, "margin", 0.01)
    wait.until(lambda d: len(d.find_elements(By.CSS_SELECTOR, "#footprint circle.grown")) == 1)
    for x in (-0.4, 0.4):
        _shift_click_world(browser, x, 2.4)
        time.sleep(0.3)
    wait.until(lambda d: len(d.find_elements(By.CSS_SELECTOR, "#waypoints rect.waypoint")) == 2)
    assert [
        round(float(browser.find_element(By.ID, f"wp-{i}-x").get_attribute("value")), 1)
        for i in (0, 1)
    ] == [-0.4, 0.4]  # in order along the way

    def y0(d) -> float:
        return float(d.find_element(By.ID, "wp-0-y").get_attribute("value"))

    before = y0(browser)
    first = browser.find_element(By.CSS_SELECTOR, 'rect.waypoint[data-waypoint="0"]')
    ActionChains(browser).click_and_hold(first).move_by_offset(0, 10).move_by_offset(
        0, 10
    ).release().perform()  # dragged down
    WebDriverWait(browser, WAIT).until(lambda d: y0(d) < before - 0.01)
    time.sleep(0.5)
    wait.until(lambda d: _settled(d) and _text(d, "status").startswith("converged"))
    assert not browser.find_element(By.ID, "error").is_displayed()
    shown = _text(browser, "cost")
    cost = float(shown)

    toml = downloads / "paper-case-1.toml"
    toml.unlink(missing_ok=True)  # (another test's download of paper case 1)
    browser.find_element(By.ID, "dl-toml").click()
    wait.until(lambda d: toml.exists() and 'model = "car"' in toml.read_text())
    text = toml.read_text()
    assert "v = [-1.0, 1.2]" in text and "radius = 0.05" in text and "margin = 0.01" in text
    assert "waypoints = [[-0.4" in text
    out = downloads / "car.json"
    cmd = [sys.executable, "-m", "leapfrog_planner.cli", "solve", str(toml), "--quiet"]
    subprocess.run([*cmd, "--json", str(out)], check=True, timeout=120)
    result = json.loads(out.read_text())
    assert result["status"] == "converged" and result["min_clearance"] >= 0.01
    assert result["cost"] == pytest.approx(cost, rel=2e-6)

    planned = browser.execute_script("return seq")  # the page's count of plans asked for
    browser.find_element(By.ID, "wp-1-remove").click()  # a waypoint removed plans again
    wait.until(lambda d: len(d.find_elements(By.CSS_SELECTOR, "#waypoints rect.waypoint")) == 1)
    wait.until(lambda d: d.execute_script("return seq") > planned and _settled(d))
    assert _text(browser, "status").startswith("converged")


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


#: The map's image on the view: the start of its href, its size and the view's, or null.
MAP_IMAGE = """
const image = document.querySelector("#view image#map");
if (!image) return null;
const box = image.getBoundingClientRect();
const view = document.getElementById("view").getBoundingClientRect();
return {href: image.getAttribute("href").slice(0, 40), width: box.width, height: box.height,
        view_width: view.width, view_height: view.height};
"""


def test_a_map_is_opened_and_planned_on(server, browser, tmp_path):
    browser.get(server)
    wait = WebDriverWait(browser, WAIT)
    wait.until(lambda d: _text(d, "cost") not in ("", "–"))  # paper case 1, planned on load
    t0 = time.perf_counter()
    browser.find_element(By.ID, "map-yaml").send_keys(str(MAPS / "tb3_sandbox.yaml"))
    browser.find_element(By.ID, "map-image").send_keys(str(MAPS / "tb3_sandbox.pgm"))
    # Read in one script: every answer redraws the view, and with it the map's image element
    # (a reference held across a redraw is stale).
    image = wait.until(lambda d: d.execute_script(MAP_IMAGE))
    assert image["href"].startswith("data:image/png;base64,")
    assert "robot radius 0.2 m, weight W 1" in _text(browser, "map-info")
    assert browser.find_element(By.ID, "radius").get_attribute("value") == "0.2"
    assert browser.find_element(By.ID, "weight").get_attribute("value") == "1"
    assert not browser.find_element(By.ID, "error").is_displayed()
    # the view fits the arena (the known cells), not the whole 19.2 m square of the map
    image = browser.execute_script(MAP_IMAGE)
    assert image["width"] > 1.3 * image["view_width"]
    assert image["height"] > 1.3 * image["view_height"]

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
    view = browser.find_element(By.ID, "view").rect
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


def test_the_page_shows_the_solver_being_prepared_then_plans(preparing_server, browser, tmp_path):
    """A fresh machine: the page says which model is being prepared and each model's state,
    plans paper case 1 (a unicycle) as soon as the unicycle is ready while the others are still
    being prepared, and plans the car once the car is ready."""
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
    wait.until(lambda d: _text(d, "preparing-models").startswith("unicycle compiling"))
    assert _text(browser, "preparing-models") == (
        "unicycle compiling · diff-drive waiting · car waiting"
    )
    bar = browser.find_element(By.ID, "preparing-bar")
    assert (bar.get_attribute("value"), bar.get_attribute("max")) == ("0", "3")
    assert _text(browser, "cost") == "–"  # paper case 1 waits for the unicycle
    (tmp_path / "preparing.png").write_bytes(browser.get_screenshot_as_png())

    (gate / "unicycle").touch()
    # while the others wait; the worker loads the unicycle first (a timeout, not a target: in a
    # CI run on a loaded machine the plan came after more than 20 s, quiet it takes 2)
    first = WebDriverWait(browser, 3 * WAIT)
    first.until(lambda d: _text(d, "status").startswith("converged"))
    assert banner.is_displayed()
    wait.until(lambda d: "(model 2 of 3)" in _text(d, "preparing-text"))
    assert "the unicycle is ready: it plans meanwhile." in _text(browser, "preparing-text")
    assert " s on them, " in _text(browser, "preparing-text")  # the diff-drive's seconds
    ready = "unicycle ready · diff-drive compiling · car waiting"  # its process started
    wait.until(lambda d: _text(d, "preparing-models") == ready)
    assert bar.get_attribute("value") == "1"
    assert not browser.find_element(By.ID, "error").is_displayed()
    (tmp_path / "unicycle-ready.png").write_bytes(browser.get_screenshot_as_png())

    Select(browser.find_element(By.ID, "model")).select_by_value("car")
    wait.until(lambda d: "the plan runs as soon as the car is ready." in _text(d, "preparing-text"))
    assert _text(browser, "cost") == "–"  # no path of the unicycle left drawn for the car
    for model in ("diff-drive", "car"):
        (gate / model).touch()
    WebDriverWait(browser, 60).until(lambda d: not banner.is_displayed())
    wait.until(lambda d: _text(d, "status").startswith("converged"))  # the car, once ready
    assert _plotted(browser) == ["v", "sigma", "omega"]
    assert not browser.find_element(By.ID, "error").is_displayed()
