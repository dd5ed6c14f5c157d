"""report.html of a real run in a real headless browser (Debian's chromium through selenium):
no console errors, the Table-2 rows and columns, and a recorded rollout video that plays.
A screenshot is kept under the test's tmp folder and copied to $XICM_ARTEFACTS when set."""

import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytestmark = [pytest.mark.slow, pytest.mark.browser, pytest.mark.subprocess]

TASKS = ("close_fridge", "unplug_charger")  # one Level-1 and one Level-2 task; the oracle solves both
CHROMEDRIVER = shutil.which("chromedriver")


@pytest.fixture(scope="module")
def oracle_run(tmp_path_factory):
    """A real oracle run on two AGNOSTOS tasks with videos; report.html is written by default."""
    tmp = tmp_path_factory.mktemp("browser")
    out = tmp / "run"
    command = [
        str(Path(sys.executable).parent / "xicm-eval"), "policy=oracle", "benchmark=agnostos", f"benchmark.tasks=[{','.join(TASKS)}]",
        "seeds=[0]", "episodes=1", "video.enabled=true", "video.every=3", f"paths.data={tmp}/nothing",
        f"hydra.run.dir={out}", "progress=false",
    ]
    done = subprocess.run(command, capture_output=True, text=True, cwd=tmp, timeout=900, check=False)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-3000:]
    assert f"results: {out}/ (episodes.jsonl, summary.json, table.md, tasks.csv, report.html)" in done.stdout
    return out


@pytest.fixture(scope="module")
def browser():
    if CHROMEDRIVER is None:
        pytest.skip("chromedriver is not installed (bash scripts/install_chromium.sh)")
    webdriver = pytest.importorskip("selenium.webdriver")
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    for arg in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", "--window-size=1400,1100",
                "--autoplay-policy=no-user-gesture-required"):
        options.add_argument(arg)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)
    yield driver
    driver.quit()


def test_the_report_of_a_real_run_loads_shows_table2_and_plays_its_video(oracle_run, browser, tmp_path):
    page = oracle_run / "report.html"
    browser.get(page.as_uri())
    table = browser.find_element("id", "table2")
    head = [th.text for th in table.find_elements("css selector", "thead th")]
    assert len(head) == 1 + 23 + 3 and head[-3:] == ["Level-1", "Level-2", "All"]
    rows = table.find_elements("css selector", "tbody tr")
    assert [r.get_attribute("class") for r in rows] == ["ours"] + ["paper"] * 5
    assert all("paper, RLBench/CoppeliaSim" in r.text for r in rows[1:])
    ours = [td.text.split("\n")[0] for td in rows[0].find_elements("tag name", "td")]
    assert ours[head.index("close_fridge")] == "100.0" and ours[head.index("lamp_on")] == "–" and ours[-1] == "100.0"

    videos = browser.find_elements("tag name", "video")
    assert len(videos) == len(TASKS)
    video = videos[0]
    assert video.get_attribute("src").startswith("data:video/mp4;base64,")
    browser.execute_script("arguments[0].closest('details').open = true; arguments[0].scrollIntoView(); arguments[0].play();", video)
    state = lambda: browser.execute_script("const v = arguments[0]; return [v.readyState, v.currentTime, v.error && v.error.code];", video)  # noqa: E731
    first = state()
    deadline = time.time() + 20
    while state()[1] <= first[1] + 0.2 and time.time() < deadline:
        time.sleep(0.2)
    ready, position, error = state()
    assert error is None and ready >= 2 and position > first[1] + 0.2, (first, state())

    shot = tmp_path / "report.png"
    browser.execute_script("window.scrollTo(0, 0)")
    assert browser.save_screenshot(str(shot)) and shot.stat().st_size > 10_000
    if os.environ.get("XICM_ARTEFACTS"):
        Path(os.environ["XICM_ARTEFACTS"]).mkdir(parents=True, exist_ok=True)
        shutil.copy(shot, Path(os.environ["XICM_ARTEFACTS"]) / "report_browser_test.png")
    errors = [e for e in browser.get_log("browser") if e["level"] == "SEVERE"]
    assert errors == [], json.dumps(errors)[:2000]
