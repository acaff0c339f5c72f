"""The project's account of every figure and table of the four seed papers (``ledger.toml``):
what the paper prints, what the project gets, and a status from a fixed vocabulary
(``STATUSES``), with the tests that back it.  ``vines-stoch reproduce`` writes it at the head of
``reports/seed-tables.md``; ``tests/papers/test_ledger.py`` holds every row to its word (a
status outside the vocabulary, a "reproduced" without a tolerance, a test that does not exist,
a figure or table of a paper without a row: each fails)."""

from __future__ import annotations

import tomllib
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

#: The ledger shipped with the package.
LEDGER = Path(__file__).with_name("ledger.toml")

#: The statuses a row may have, and what each means.
STATUSES = {
    "reproduced": "a test compares ours with the printed number(s) within the stated tolerance",
    "differs": "ours differs from the printed number, and the cause is shown (by a test or the report)",
    "qualitative": "the paper prints no number; a test checks its qualitative statement",
    "not-reproduced": "the case runs, and does not give the paper's result; cause unknown",
    "not-built": "no test covers the item yet (the report may draw it: the row says what it shows)",
    "illustration": "a drawing, photograph or sketch: nothing to reproduce",
}
#: The papers, by number (docs/model.md cites them in full).
PAPERS = {
    "000": "Wei et al. 2019, the parallel NES",
    "001": "Lizunov, Pogorelova, Postnikova, the model of a VI NES",
    "002": "Lizunov, Pogorelova, Postnikova 2023, optimal SSVI designs",
    "003": "Lizunov, Pogorelova, Postnikova, Gerashchenko 2024, mass of SSVI and DSVI",
}
_KEYS = ("seed", "item", "subject", "paper", "ours", "status", "tolerance", "cause", "tests")


@dataclass(frozen=True)
class Item:
    """One figure, table or textual claim of a seed paper and the project's status on it."""

    seed: str
    item: str
    subject: str
    paper: str
    ours: str
    status: str
    tolerance: str
    cause: str
    tests: tuple[str, ...]

    def problem(self) -> str | None:
        """Why the row does not hold to its status's word (None: it does)."""
        if self.seed not in PAPERS:
            return f"seed {self.seed!r}: one of {', '.join(PAPERS)}"
        if self.status not in STATUSES:
            return f"status {self.status!r}: one of {', '.join(STATUSES)}"
        if self.status == "reproduced" and not (self.tolerance and self.tests):
            return "reproduced: needs the tolerance its tests hold and the tests"
        if self.status == "differs" and not (self.cause and self.cause != "unknown"):
            return "differs: needs the cause shown"
        if self.status == "qualitative" and not self.tests:
            return "qualitative: needs the test that checks the statement"
        return None


def load(path: Path = LEDGER) -> list[Item]:
    """The rows of a ledger; ValueError naming the row of one that does not hold to its word."""
    rows = tomllib.loads(path.read_text())["item"]
    items = []
    for number, row in enumerate(rows, start=1):
        if set(row) != set(_KEYS):
            raise ValueError(f"{path}: item {number}: keys {sorted(row)}, want {sorted(_KEYS)}")
        item = Item(**{**row, "tests": tuple(row["tests"])})
        why = item.problem()
        if why:
            raise ValueError(f"{path}: item {number} (seed {item.seed} {item.item}): {why}")
        items.append(item)
    return items


def counts(items: list[Item]) -> dict[str, Counter]:
    """The rows' statuses counted by seed."""
    found: dict[str, Counter] = {seed: Counter() for seed in PAPERS}
    for item in items:
        found[item.seed][item.status] += 1
    return found


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def markdown(items: list[Item]) -> list[str]:
    """The ledger as a report section: the vocabulary, the counts by seed, and one row an item."""
    lines = ["## Every seed item and its status", "",
             "One row for each figure and table of the four papers (and their checkable claims in the "
             "text): what the paper prints, what we get, and one status of this vocabulary "
             "(`vines_stoch/validation/ledger.toml`; `tests/papers/test_ledger.py` holds each row to "
             "it):", ""]
    lines += [f"- **{status}**: {meaning}" for status, meaning in STATUSES.items()]
    lines += ["", "| seed | " + " | ".join(STATUSES) + " | items |", "|---" * (len(STATUSES) + 2) + "|"]
    for seed, found in counts(items).items():
        cells = " | ".join(str(found[s]) for s in STATUSES)
        lines.append(f"| {seed} | {cells} | {sum(found.values())} |")
    lines += ["", "| seed | item | subject | paper | ours | status | tolerance or cause | tests |",
              "|---|---|---|---|---|---|---|---|"]
    for item in items:
        why = item.tolerance if item.status == "reproduced" else item.cause
        tests = ", ".join(f"`{t.split('::')[-1]}`" for t in item.tests)
        lines.append(f"| {item.seed} | {item.item} | {_cell(item.subject)} | {_cell(item.paper)} | "
                     f"{_cell(item.ours)} | {item.status} | {_cell(why)} | {tests} |")
    return lines + [""]


def refresh(report: Path) -> Path:
    """Rewrite the ledger's section of a seed report (``reports/seed-tables.md``) from the ledger
    as it is, leaving the rest (the runs) untouched: ``vines-stoch reproduce --ledger-only``."""
    lines = report.read_text().split("\n")
    heading = markdown([])[0]
    if heading not in lines:
        raise ValueError(f"{report}: holds no ledger section ({heading!r}): run vines-stoch reproduce")
    start = lines.index(heading)
    end = next((i for i in range(start + 1, len(lines)) if lines[i].startswith("## ")), len(lines))
    report.write_text("\n".join(lines[:start] + markdown(load()) + lines[end:]))
    return report


__all__ = ["LEDGER", "PAPERS", "STATUSES", "Item", "counts", "load", "markdown", "refresh"]
