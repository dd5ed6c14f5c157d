"""index.html of a results folder: the results page (src/xicm/report/results_page.py) as one self-contained
HTML page (no scripts, no network), the same tables and cell texts as its README.md."""

from __future__ import annotations

from typing import Any

from xicm.report import results_markdown
from xicm.report.html_run import render


def page_html(page: dict[str, Any]) -> str:
    return render("results.html.j2", {"title": "xicm results", "page": page, "fmt": results_markdown})
