"""The report stack: per-run tables (summary.json, table.md, tasks.csv), the paper's Table-2 layout,
sweeps, merged and paired reports, and the HTML pages and their figures (`xicm-report`).

The tables need numpy and scipy only; the pages and plots need jinja2 and matplotlib, the
`report` extra, imported through `require` so a missing one is one sentence, not a traceback.

The results page, results/README.md and results/index.html (src/xicm/report/results_page.py), is rebuilt
from the committed run folders, from the repository root, with

    xicm-report --results-page results/

after adding or changing a row (a run folder under results/<setting>/); results/settings.yaml
names each setting's baseline and the rows paired with another run. Commit the page with the
rows: tests/test_results_page.py fails while the committed page differs from what the rows give."""

from __future__ import annotations

import importlib
from types import ModuleType

from xicm.core.contracts.errors import XicmError

EXTRA = "pip install 'xicm[report]'"


class ReportExtraMissing(XicmError):
    """A page or plot was asked for without the `report` extra installed."""


def require(module: str, what: str) -> ModuleType:
    """`module` (jinja2, matplotlib...) imported, or ReportExtraMissing naming `what` needed it."""
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise ReportExtraMissing(f"{what} needs {module.split('.')[0]}, part of the report extra ({EXTRA})") from exc
