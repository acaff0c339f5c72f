"""The seed ledger (``vines_stoch/validation/ledger.toml``) holds to its words: every status of
the fixed vocabulary, every "reproduced" with its tolerance and tests, every test it names
defined in its file, every figure and table of the four papers with a row, and the report
(``reports/seed-tables.md``) carrying the ledger as it is, under a title that claims no more."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from tests.helpers import ROOT
from vines_stoch.validation import ledger
from vines_stoch.validation.ledger import LEDGER, PAPERS, STATUSES, Item, load, markdown

SEEDS = ROOT.parent / "shared" / "seeds"
#: Figures or tables named in a paper's text: a caption or a reference, one or a list ("Figs. 7
#: and 8", "Fig. 11, 12", "Tables 2-4").
NAMED = re.compile(r"\b(Figs?\.|Figures?|Tables?)\s*(\d+(?:\s*(?:,|and|&|-|–)\s*\d+)*)", re.IGNORECASE)


def named_items(text: str) -> set[tuple[str, int]]:
    """("Fig." or "Table", number) of every figure and table ``text`` names, lists and ranges
    spelled out."""
    found = set()
    for kind, numbers in NAMED.findall(text):
        kind = "Table" if kind.lower().startswith("table") else "Fig."
        for first, dash, last in re.findall(r"(\d+)(?:\s*([-–])\s*(\d+))?", numbers):
            span = range(int(first), int(last) + 1) if dash and int(last) - int(first) < 20 else [int(first)]
            found |= {(kind, n) for n in span}
    return found


def test_every_row_holds_to_its_status():
    items = load()
    assert items and {item.status for item in items} <= set(STATUSES)
    keys = [(item.seed, item.item) for item in items]
    assert len(keys) == len(set(keys)), "an item has two rows"


@pytest.mark.parametrize("status, fields, words", [
    ("proven", {}, "status 'proven': one of reproduced"),
    ("reproduced", {"tolerance": ""}, "reproduced: needs the tolerance"),
    ("differs", {"cause": "unknown"}, "differs: needs the cause shown"),
    ("qualitative", {"tests": ()}, "qualitative: needs the test"),
])
def test_a_row_that_does_not_hold_is_named(status, fields, words):
    row = Item(seed="003", item="Table 2", subject="s", paper="p", ours="o", status=status, tolerance="±1 %",
               cause="a misprint", tests=("tests/papers/test_ledger.py::test_every_row_holds_to_its_status",))
    row = Item(**{**row.__dict__, **fields})
    assert words in row.problem()


def test_every_named_test_exists():
    for item in load():
        for node in item.tests:
            path, _, name = node.partition("::")
            source = ROOT / path
            assert source.is_file(), f"{item.seed} {item.item}: {path} does not exist"
            assert re.search(rf"^def {re.escape(name)}\(", source.read_text(), re.M), \
                f"{item.seed} {item.item}: {node} is not defined"


@pytest.mark.skipif(not SEEDS.is_dir(), reason="the seed papers' text is not beside the project")
def test_every_figure_and_table_of_the_papers_has_a_row():
    rows = {(item.seed, item.item) for item in load()}
    for seed in PAPERS:
        text = next(SEEDS.glob(f"{seed}_*.txt")).read_text()
        for kind, number in sorted(named_items(text)):
            assert (seed, f"{kind} {number}") in rows, f"seed {seed} {kind} {number} has no row"


def test_the_report_carries_the_ledger_and_claims_no_more():
    report = (ROOT / "reports" / "seed-tables.md").read_text()
    title = report.splitlines()[0]
    assert "reproduced" not in title.lower(), title
    assert "\n".join(markdown(load())) in report, "reports/seed-tables.md is older than the ledger: " \
        "make seeds"


def test_counts_are_by_seed_and_status(tmp_path: Path):
    path = tmp_path / "ledger.toml"
    path.write_text(LEDGER.read_text())
    found = ledger.counts(load(path))
    assert set(found) == set(PAPERS) and sum(sum(c.values()) for c in found.values()) == len(load())


def test_lists_and_ranges_of_figures_are_read():
    assert named_items("see Figs. 7 and 8, Fig.3, figure 2; Tables 2-4 and Fig. 11, 12") == {
        ("Fig.", 7), ("Fig.", 8), ("Fig.", 3), ("Fig.", 2), ("Table", 2), ("Table", 3), ("Table", 4),
        ("Fig.", 11), ("Fig.", 12)}


def test_refresh_rewrites_only_the_ledger_section(tmp_path: Path):
    report = tmp_path / "seed-tables.md"
    report.write_text("# title\n\n## Every seed item and its status\n\nold rows\n\n"
                      "## Seed 002: runs\n\nkept\n")
    ledger.refresh(report)
    text = report.read_text()
    assert "old rows" not in text and "\n".join(markdown(load())) in text
    assert text.startswith("# title\n\n") and text.endswith("## Seed 002: runs\n\nkept\n")
    report.write_text("# no ledger\n")
    with pytest.raises(ValueError, match="holds no ledger section"):
        ledger.refresh(report)
