"""The results page's one hand-written input, `<results>/settings.yaml`: per setting (a folder of
run folders), the run every row is paired against and the rows paired against another, with why.

    settings:
      agnostos/paper-protocol-k18:            # a folder below the results folder
        baseline: nearest_demo-language       # a run folder in it: every other row pairs with it ...
        paired_with:                          # ... except these rows, which pair with another run
          nearest_demo-language-new-scene:
            why: ran under the simulator of that rerun
            rows: [gemma3_270m-bf16-language-grammar]

It holds names and reasons only: every figure on the page comes from the run folders. A setting
not listed still gets its rows, without paired tests.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from xicm.core.contracts.errors import XicmError

SETTINGS_FILE = "settings.yaml"


class SettingsError(XicmError):
    """settings.yaml is not the shape the results page reads."""


@dataclass(frozen=True)
class Pairing:
    baseline: str
    why: str | None = None


@dataclass(frozen=True)
class SettingDecl:
    """What settings.yaml declares about one setting."""

    baseline: str | None = None
    rows: dict[str, Pairing] = field(default_factory=dict)  # row -> the run it pairs with, where not the baseline

    def pairing(self, row: str) -> Pairing | None:
        """The run `row` is paired against (None for the baseline itself, or without a baseline)."""
        if row in self.rows:
            return self.rows[row]
        if self.baseline is None or row == self.baseline:
            return None
        return Pairing(self.baseline)

    def named_runs(self) -> list[str]:
        """Every run folder name the declaration mentions (to say which are missing)."""
        names = [*([self.baseline] if self.baseline else []), *self.rows, *(p.baseline for p in self.rows.values())]
        return sorted(set(names))


def load_settings(root: Path) -> dict[str, SettingDecl]:
    """{setting folder (relative to root, '/'): its declaration}; {} when root has no settings.yaml;
    SettingsError (one sentence) when the file is not YAML or not this shape."""
    path = Path(root) / SETTINGS_FILE
    if not path.is_file():
        return {}
    import yaml

    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8")) or {}
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" (line {mark.line + 1})" if mark is not None else ""
        raise SettingsError(f"{path} is not valid YAML{where}: {getattr(exc, 'problem', None) or exc}") from None
    if not isinstance(data, dict) or set(data) - {"settings"} or not isinstance(data.get("settings", {}), dict):
        raise SettingsError(f"{path} must hold one mapping, `settings:`, of setting folders to their declarations")
    return {str(name).strip("/"): _setting(path, str(name), decl) for name, decl in (data.get("settings") or {}).items()}


def _setting(path: Path, name: str, decl: Any) -> SettingDecl:
    where = f"{path}, setting {name}"
    decl = decl or {}
    if not isinstance(decl, dict) or set(decl) - {"baseline", "paired_with"}:
        raise SettingsError(f"{where}: a setting takes `baseline: RUN` and `paired_with: {{RUN: {{why, rows}}}}` only")
    baseline = decl.get("baseline")
    if baseline is not None and not isinstance(baseline, str):
        raise SettingsError(f"{where}: `baseline` is the name of one run folder, not {baseline!r}")
    rows: dict[str, Pairing] = {}
    for other, group in (decl.get("paired_with") or {}).items():
        if not isinstance(group, dict) or set(group) - {"why", "rows"} or not isinstance(group.get("rows"), list):
            raise SettingsError(f"{where}: paired_with.{other} takes `rows: [RUN, ...]` and an optional `why:`")
        for row in group["rows"]:
            if str(row) in rows:
                raise SettingsError(f"{where}: row {row} is paired twice (with {rows[str(row)].baseline} and {other})")
            rows[str(row)] = Pairing(str(other), group.get("why"))
    return SettingDecl(baseline, rows)
