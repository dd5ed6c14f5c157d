"""report.html and sweep.html from run folders written by hand (no simulator): the Table-2
layout with the paper's rows, per-episode media, the pool's first frames, the sweep's plots."""

import json
import re
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

from xicm.report import table2
from xicm.report.cli import main as report_main
from xicm.report.html_run import write_run_html
from xicm.report.html_sweep import write_sweep_html

ROOT = Path(__file__).resolve().parents[1]
L1, L2 = "close_fridge", "unplug_charger"  # one task of each paper level
SPLITS = {L1: "level1", L2: "level2", "open_drawer": "seen"}
DEMO = "open_drawer/s10000/e0000"


class Page(HTMLParser):
    """The tags and attributes of a page, and the text of each table row by the table's id."""

    def __init__(self, text):
        super().__init__()
        self.tags, self.rows, self._table, self._row = [], {}, [], None
        self.feed(text)

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        self.tags.append((tag, attrs))
        if tag == "table":
            self._table.append(attrs.get("id"))
        elif tag == "tr":
            self._row = []
            self.rows.setdefault(self._table[-1], []).append(self._row)
        elif tag in ("td", "th") and self._row is not None:
            self._row.append("")

    def handle_endtag(self, tag):
        if tag == "table":
            self._table.pop()
        if tag in ("tr", "table"):
            self._row = None

    def handle_data(self, data):
        if self._row is not None and self._row:
            self._row[-1] += data.strip()


def make_run(folder, outcomes, pool_path="pools/seen.h5", video_bytes=None, config=None):
    """outcomes: {(task, seed): [bool, ...]}; the first episode of each task gets a transcript and, with
    video_bytes, a video of that many bytes."""
    folder.mkdir(parents=True)
    cfg = {"run_name": folder.name, "seeds": sorted({s for _, s in outcomes}), "episodes": max(map(len, outcomes.values())),
           "pool_path": pool_path, "simulator": {"name": "sapien"}, "policy": {"name": "xicm"}, **(config or {})}
    tasks = list(dict.fromkeys(t for t, _ in outcomes))
    (folder / "run.json").write_text(json.dumps({"tasks": tasks, "splits": SPLITS, "policy": "xicm", "config": cfg}))
    rows = []
    for (task, seed), results in outcomes.items():
        for i, ok in enumerate(results):
            extra = {}
            if i == 0:
                rel = f"transcripts/{task}/s{seed}-e{i:04d}.json"
                (folder / rel).parent.mkdir(parents=True, exist_ok=True)
                calls = [{"messages": [{"role": "user", "content": f"prompt <{task}> & demos"}], "reply": "[[1, 2, 3, 4, 5, 6, 1]]"}]
                (folder / rel).write_text(json.dumps({"task": task, "seed": seed, "episode": i, "calls": calls}))
                extra["transcript"] = rel
                if video_bytes:
                    rel = f"videos/{task}/s{seed}-e{i:04d}-{'PASS' if ok else 'FAIL'}.mp4"
                    (folder / rel).parent.mkdir(parents=True, exist_ok=True)
                    (folder / rel).write_bytes(b"\0" * video_bytes[task])
                    extra["video"] = rel
            rows.append({"task": task, "seed": seed, "episode": i, "success": ok, "steps": 3,
                         "error_kind": None if ok else "max_steps", "error_message": None if ok else "no success within 25 key actions",
                         "retrieved": [DEMO], "timings": {"reset": 1.0, "llm": 0.5, "total": 2.0}, "extra": extra})
    (folder / "episodes.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    return folder


def make_pool(path):
    """A pool file holding one demo's first frame (the report reads it through core.dataset)."""
    import h5py

    from xicm.core.results.dataset import FORMAT

    path.parent.mkdir(parents=True, exist_ok=True)
    with h5py.File(path, "w") as f:
        f.attrs["format"] = FORMAT
        f.create_dataset(f"demos/{DEMO}/first_rgb", data=np.full((64, 64, 3), 200, np.uint8))


def test_paper_table_columns_are_the_agnostos_benchmark_and_its_levels_add_up():
    import yaml

    benchmark = yaml.safe_load((ROOT / "src/xicm/conf/benchmark/agnostos.yaml").read_text())
    paper = table2.paper_table()
    assert table2.columns() == benchmark["tasks"] and (len(paper["level1"]), len(paper["level2"])) == (13, 10)
    assert paper["source"] == "paper, RLBench/CoppeliaSim"
    names = [row["name"] for row in paper["rows"]]
    assert names[0] == "X-ICM (72B)" and "π0" in names and "VoxPoser" in names
    for row in paper["rows"]:  # All is the mean over 23 tasks: 13 of Level-1, 10 of Level-2
        assert (13 * row["level1"] + 10 * row["level2"]) / 23 == pytest.approx(row["all"], abs=0.06), row["name"]


def test_our_row_uses_the_papers_levels_and_leaves_seen_tasks_out():
    rows = [{"task": t, "seed": s, "episode": i, "success": ok}
            for t, s, outcomes in ((L1, 0, [1, 1]), (L1, 1, [1, 0]), (L2, 0, [0, 0]), (L2, 1, [1, 0]), ("open_drawer", 0, [1, 1]))
            for i, ok in enumerate(outcomes)]
    ours = table2.our_row(rows, "mine")
    assert set(ours["tasks"]) == {L1, L2} and ours["episodes"] == 8
    assert ours["groups"]["Level-1"]["success"] == pytest.approx(75.0) and ours["groups"]["Level-1"]["n"] == 4
    assert ours["groups"]["All"]["success"] == pytest.approx(50.0)  # seeds: (100 + 0)/2, (50 + 50)/2
    assert ours["groups"]["All"]["successes"] == 4 and ours["groups"]["All"]["ci_low"] == pytest.approx(21.52, abs=0.01)
    head, data = table2.flat_rows(ours, "ours, sapien")
    assert head[:3] == ["method", "source", "put_toilet_roll_on_stand"] and head[-4:] == ["Level-1", "Level-2", "All", "All std"]
    assert data[0][0:2] == ["mine", "ours, sapien"] and data[0][head.index(L1)] == 75.0 and data[0][head.index("lamp_on")] is None
    assert [r[1] for r in data[1:]] == ["paper, RLBench/CoppeliaSim"] * 5 and data[1][-4:] == [37.6, 20.3, 30.1, 1.0]


def test_run_page_is_self_contained_with_table2_paper_rows_media_and_first_frames(tmp_path):
    run = make_run(tmp_path / "run", {(L1, 0): [True, False], (L2, 0): [False], ("open_drawer", 0): [True]},
                   pool_path=str(tmp_path / "pools/seen.h5"), video_bytes={L1: 1000, L2: 300_000, "open_drawer": 1000})
    make_pool(tmp_path / "pools/seen.h5")
    text = write_run_html(run, inline_video_mb=0.1).read_text()
    page = Page(text)
    links = [v for _, attrs in page.tags for k, v in attrs.items() if k in ("src", "href") and v]
    assert not [v for v in links if re.match(r"(https?:)?//", v)]  # nothing from the network
    head, ours, *paper = page.rows["table2"]
    assert len(head) == 1 + 23 + 3 and head[1] == "put_toilet_roll_on_stand" and head[-3:] == ["Level-1", "Level-2", "All"]
    assert ours[0] == "runours, sapien (this run)" and ours[3].startswith("50.0") and ours[2] == "–"
    assert [r[0] for r in paper] == [f"{name}paper, RLBench/CoppeliaSim" for name in
                                     ("X-ICM (72B)", "X-ICM (72B), random selection", "X-ICM (7B)", "π0", "VoxPoser")]
    assert paper[0][-3:] == ["37.6", "20.3", "30.1(1.0)"]
    # the X-ICM rows' task cells come from X-ICM's own logs (mean over seeds); rows without logs stay '·'
    assert (paper[0][head.index(L1)], paper[0][head.index(L2)], paper[2][head.index(L1)]) == ("12.7", "2.7", "22.7")
    assert paper[1][head.index(L1)] == paper[3][head.index(L1)] == "·"
    assert (f'title="{L1}: mean of 6 seeds (std 5.4); of 150 episodes 85 % failed early, 3 % used all 25 key actions, '
            f'mean 3.4 key actions; X-ICM&#39;s logs, jiaming-zhou/X-ICM at 0a8cd6c"') in text
    videos = [attrs for tag, attrs in page.tags if tag == "video"]
    assert len(videos) == 2 and all(v["src"].startswith("data:video/mp4;base64,") for v in videos)  # the 1000-byte ones
    assert f'<a href="videos/{L2}/s0-e0000-FAIL.mp4">' in text and "1 larger ones are linked" in text
    assert "prompt &lt;close_fridge&gt; &amp; demos" in text  # transcripts are escaped text
    assert re.search(r"\.d0 \{ background-image: url\(data:image/png;base64,", text) and f'title="{DEMO}"' in text
    assert text.count("<svg") == 4  # levels, success, errors, seconds per stage


def test_a_pool_that_is_not_reachable_is_said_on_the_page(tmp_path):
    run = make_run(tmp_path / "run", {(L1, 0): [True]}, pool_path="data/pools/elsewhere.h5")
    text = write_run_html(run).read_text()
    assert "the demonstration pool &#39;data/pools/elsewhere.h5&#39; is not reachable from here" in text
    assert "background-image" not in text and f">{DEMO}</span>" in text


def test_report_command_writes_run_and_sweep_pages(tmp_path, capsys):
    root = tmp_path / "multirun"
    for k, outcome in ((1, [False, False]), (6, [True, False]), (18, [True, True])):
        for retriever in ("language", "random"):
            run = make_run(root / f"k{k}-{retriever}", {(L1, 0): outcome, (L2, 0): outcome},
                           config={"policy": {"name": "xicm", "k": k}, "retriever": {"name": retriever}})
    report_main([str(root), "--html"])
    out = capsys.readouterr().out
    assert out.count("report.html (") == 6 and f"written: {root}/sweep.html" in out
    page = Page((root / "sweep.html").read_text())
    head, *rows = page.rows["runs-table"]
    assert head[:2] == ["policy.k", "retriever.name"] and [r[:2] for r in rows][:2] == [["1", "language"], ["1", "random"]]
    assert rows[-1][-1] == "k18-random" and rows[2][head.index("All %")] == "50.0"
    assert rows[2][head.index("All 95 % CI (n)")] == "15.0–85.0 (4)"  # Wilson of 2 of 4
    links = [attrs["href"] for tag, attrs in page.tags if tag == "a"]
    assert "k6-language/report.html" in links and (root / "k6-language/report.html").is_file()
    text = (root / "sweep.html").read_text()
    assert text.count("<svg") == 2 and "retriever.name=random" in text  # one plot per axis, a line per other value


def test_report_command_refuses_a_bad_video_limit(tmp_path, capsys):
    run = make_run(tmp_path / "run", {(L1, 0): [True]})
    with pytest.raises(SystemExit) as done:
        report_main([str(run), "--html", "--inline-video-mb", "lots"])
    assert done.value.code == 2 and "argument --inline-video-mb: 'lots' is not a number of megabytes >= 0" in capsys.readouterr().err
    assert not (run / "report.html").exists()


@pytest.mark.parametrize("enabled", [True, False])
def test_eval_job_writes_the_page_unless_report_html_is_false(tmp_path, enabled):
    from omegaconf import OmegaConf

    from xicm.core.assembly.eval_job import _write_html

    run = make_run(tmp_path / "run", {(L1, 0): [True]})
    _write_html(OmegaConf.create({"report": {"html": enabled, "inline_video_mb": 2}}), run)
    assert (run / "report.html").is_file() == enabled


def test_merged_runs_get_one_page(tmp_path, capsys):
    a = make_run(tmp_path / "a", {(L1, 0): [True]})
    b = make_run(tmp_path / "b", {(L2, 0): [False]})
    report_main(["--merge", str(tmp_path / "merged"), str(a), str(b), "--html"])
    assert f"written: {tmp_path}/merged/report.html" in capsys.readouterr().out
    head, ours, *_ = Page((tmp_path / "merged/report.html").read_text()).rows["table2"]
    assert ours[head.index(L1)].startswith("100.0") and ours[head.index(L2)].startswith("0.0") and ours[-1].startswith("50.0")


REPORT_EXTRA = ("jinja2", "matplotlib", "matplotlib.pyplot")


def test_core_and_the_report_tables_import_without_the_report_extra():
    """jinja2 and matplotlib (the `report` extra) blocked: every core module and the report's
    modules still import; only writing a page or a plot needs them."""
    import subprocess
    import sys

    code = (
        "import sys, pkgutil, importlib;"
        f"sys.modules.update(dict.fromkeys({REPORT_EXTRA!r}));"
        "import xicm.core, xicm.report;"
        "names = [m.name for p in (xicm.core, xicm.report) for m in pkgutil.walk_packages(p.__path__, p.__name__ + '.')];"
        "[importlib.import_module(n) for n in names];"
        "print(len(names), [m for m in ('jinja2', 'matplotlib') if sys.modules.get(m) is not None])"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split(maxsplit=1)
    assert int(out[0]) > 40 and out[1].strip() == "[]"


def test_a_page_without_the_report_extra_is_one_sentence_and_the_tables_stay(tmp_path, capsys, monkeypatch):
    run = make_run(tmp_path / "run", {(L1, 0): [True]})
    for name in REPORT_EXTRA:
        monkeypatch.setitem(__import__("sys").modules, name, None)
    with pytest.raises(SystemExit) as done:
        report_main([str(run), "--html"])
    captured = capsys.readouterr()
    assert done.value.code == 2 and "| close_fridge | level1 | 100.0 |" in captured.out
    assert re.fullmatch(r"xicm: error: (an HTML report|a report figure) needs (jinja2|matplotlib), part of the report extra \(pip install 'xicm\[report\]'\)\n", captured.err), captured.err
    assert not (run / "report.html").exists()


def test_a_run_without_the_report_extra_says_so_and_ends_as_usual(tmp_path, capsys, monkeypatch):
    from omegaconf import OmegaConf

    from xicm.core.assembly.eval_job import _write_html

    run = make_run(tmp_path / "run", {(L1, 0): [True]})
    for name in REPORT_EXTRA:
        monkeypatch.setitem(__import__("sys").modules, name, None)
    _write_html(OmegaConf.create({"report": {"html": True, "inline_video_mb": 2}}), run)
    out = capsys.readouterr().out
    assert out.startswith("report.html not written (ReportExtraMissing: ") and "(pip install 'xicm[report]')" in out
    assert not (run / "report.html").exists()
