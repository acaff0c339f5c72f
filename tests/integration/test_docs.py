"""The documentation cannot drift from the code: every scenario key and every command-line option
is documented, the gallery's scripts run, and the README's quick start prints what it shows."""

from __future__ import annotations

import importlib.util
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from pydantic import Field

from vines_stoch.scenario.fields import _Model

ROOT = Path(__file__).resolve().parents[2]
README = (ROOT / "README.md").read_text(encoding="utf-8")


def _reference():
    """``docs/_ext/vines_reference.py``, the generator of the reference pages (not a package)."""
    path = ROOT / "docs" / "_ext" / "vines_reference.py"
    spec = importlib.util.spec_from_file_location("vines_reference", path)
    module = sys.modules.setdefault("vines_reference", importlib.util.module_from_spec(spec))
    spec.loader.exec_module(module)
    return module


ref = _reference()


def test_every_schema_key_has_a_meaning_and_a_row():
    sections = ref.schema_keys()
    ref.check_coverage(sections, ref.meanings())  # raises, naming each undocumented field
    page = ref.scenario_reference()
    keys = [key for _, _, _, found in sections for key in found]
    assert len(keys) > 150
    for key in keys:
        assert f"| `{key.path}` |" in page, key.path
    # every model of every tagged union is reached: each absorber, load and distribution type
    tags = ('type = "hertz"', 'type = "wind"', 'type = "saragoni-hart"', 'distribution = "truncated-normal"')
    for tag in tags:
        assert f"with `{tag}`" in page


def test_reference_states_the_schema_ranges_and_defaults():
    rows = {key.path: key for _, _, _, found in ref.schema_keys() for key in found}
    restitution, realizations = rows["absorbers.N.restitution"], rows["ensemble.realizations"]
    assert (restitution.type, restitution.default) == ("number", "required")
    assert restitution.allowed == ">= 0; <= 1"
    assert (realizations.type, realizations.default) == ("integer", "`1`")
    assert realizations.allowed == ">= 1; <= 10000000"
    assert rows["simulation.scheme"].allowed == 'one of `"auto"`, `"euler-maruyama"`, `"rk4"`, `"sra"`'
    assert rows["loads.N.band"].allowed == "each > 0; each <= 1e+15; 2 items"
    assert rows["primary.masses"].allowed.endswith("1 to 200 items")


class _Extra(_Model):
    """A table with one key the meanings file does not know."""

    mass: float
    novel: int = Field(default=3, ge=1)


class _Root(_Model):
    """A root with a nested table."""

    name: str
    extra: _Extra


def test_an_undocumented_key_and_a_stale_entry_are_refused():
    sections = ref.schema_keys(_Root)
    meanings = {"_Root": {"name": "Run name.", "extra": "The table."},
                "_Extra": {"mass": "Mass (kg).", "gone": "x"}}
    with pytest.raises(ref.Undocumented) as caught:
        ref.check_coverage(sections, meanings)
    assert "_Extra.novel: a scenario key without a meaning" in str(caught.value)
    assert "_Extra.gone: in scenario_keys.toml but not a field of the schema" in str(caught.value)
    meanings["_Extra"] = {"mass": "Mass (kg).", "novel": "A count."}
    ref.check_coverage(sections, meanings)
    assert [where for where, *_ in sections] == ["", "extra"]
    novel = sections[1][3][1]
    assert (novel.path, novel.type, novel.default, novel.allowed) == ("extra.novel", "integer", "`3`", ">= 1")


def test_every_cli_option_is_documented():
    group, commands = ref.cli_commands()
    page = ref.cli_reference()
    assert len(commands) >= 9
    for name, command in commands.items():
        assert command.help and command.help.strip(), name
        assert f"## `vines-stoch {name}`" in page
        for param in ref.cli_parameters(command):
            assert param.help and param.help.strip(), f"{name} {param.name}: no help text"
            # console markup would swallow a bracketed word, e.g. "[limits]", from --help
            assert not re.search(r"\[[A-Za-z_]+\]", param.help), f"{name} {param.name}: {param.help!r}"
            shown = ", ".join(param.opts) if param.param_type_name == "option" else param.name.upper()
            assert f"| `{shown}` |" in page, f"{name} {shown}"


def test_help_shows_the_table_names():
    from typer.testing import CliRunner

    from vines_stoch.cli import app

    result = CliRunner().invoke(app, ["fragility", "--help"])
    assert result.exit_code == 0
    text = " ".join(re.sub(r"[│╭╮╰╯─]", " ", result.output).split())  # (the panels' frames and wrapping)
    assert "Name of the limit (a key of the limits table)." in text


@pytest.mark.parametrize("script", sorted(p.name for p in (ROOT / "examples").glob("plot_*.py")))
def test_gallery_script_runs_and_plots(script):
    """Each example runs as the gallery runs it (from examples/, no display) and draws finite data."""
    check = (
        "import runpy, sys, numpy as np, matplotlib\n"
        "matplotlib.use('Agg')\n"
        "import matplotlib.pyplot as plt\n"
        f"runpy.run_path({script!r}, run_name='__main__')\n"
        "figures = [plt.figure(n) for n in plt.get_fignums()]\n"
        "assert figures, 'no figure'\n"
        "data = [line.get_ydata() for f in figures for ax in f.axes for line in ax.lines]\n"
        "assert data and all(np.all(np.isfinite(np.asarray(d, float))) for d in data), 'no finite data'\n"
    )
    env = {**os.environ, "MPLBACKEND": "Agg"}
    done = subprocess.run([sys.executable, "-c", check], cwd=ROOT / "examples", env=env, capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    assert done.stdout.strip(), "the example prints its table"


def _block(after: str, language: str) -> str:
    """The first fenced block of ``language`` in the README after the text ``after``."""
    start = README.index(after)
    match = re.compile(rf"```{language}\n(.*?)```", re.S).search(README, start)
    return match.group(1)


def _numbers(text: str) -> list[list[float]]:
    """The rows of a printed table that hold only numbers, as floats."""
    rows = []
    for line in text.splitlines():
        try:
            rows.append([float(v) for v in line.split()])
        except ValueError:
            continue
    return [r for r in rows if r]


def test_readme_quick_start_prints_what_it_shows(tmp_path):
    """The quick start's command and pandas code, run in a fresh folder, print the tables the README
    shows (to their printed digits; the energy residual, round-off of the order of 1e-12, only in
    size) and write the plot."""
    command = _block("## Quick start", "sh").strip()
    assert command == ".venv/bin/vines-stoch run scenarios/parallel_nes_impulse.toml"
    (tmp_path / "scenarios").mkdir()
    shutil.copy(ROOT / "scenarios" / "parallel_nes_impulse.toml", tmp_path / "scenarios")
    executable = Path(sys.executable).parent / "vines-stoch"
    done = subprocess.run([str(executable), *command.split()[1:]], cwd=tmp_path, capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    shown = _block("standard output names the files", "text")
    first = [re.sub(r"; \d+\.\d s in all$", "", text.splitlines()[0]) for text in (done.stdout, shown)]
    assert first[0] == first[1]  # the files and their row counts (the time taken aside)
    assert done.stdout.splitlines()[1].split() == shown.splitlines()[1].split()  # the columns
    got, want = _numbers(done.stdout), _numbers(shown)
    assert len(got) == len(want) == 15
    for g, w in zip(got, want):
        assert g[:-1] == pytest.approx(w[:-1], rel=1e-3, abs=1e-4)
        assert abs(g[-1]) < 1e-9 and abs(w[-1]) < 1e-9  # energy_residual_mean

    code = _block("Read them with pandas", "python")
    done = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True,
                          env={**os.environ, "MPLBACKEND": "Agg"}, timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    shown = _block("plt.savefig", "text")
    assert done.stdout.splitlines()[0].split() == shown.splitlines()[0].split()
    got, want = _numbers(done.stdout), _numbers(shown)
    assert len(got) == len(want) == 5
    for g, w in zip(got, want):
        assert g == pytest.approx(w, rel=1e-4, abs=1e-6)
    assert (tmp_path / "edm.png").stat().st_size > 10_000


def test_readme_python_lines_run():
    """The README's lines for Python run as shown: a scenario in memory, one path's histories."""
    code = _block("The same from Python", "python")
    code += "\nprint(len(results.summary), solution.ts.shape[0])"
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    rows, steps = map(int, done.stdout.split()[-2:])
    assert rows == 15 and steps > 1000


def test_readme_links_and_included_sections_exist():
    for target in re.findall(r"\]\(((?:docs|examples)/[^)#]*)\)", README):
        assert (ROOT / target).exists(), target
    for marker in ("quick-start", "glossary"):
        assert README.count(f"<!-- {marker} -->") == README.count(f"<!-- /{marker} -->") == 1
    glossary = README[README.index("<!-- glossary -->"):README.index("<!-- /glossary -->")]
    for word in ("EDM", "LPO", "SSVI / DSVI", "VI NES", "Regime `nT,k,m`", "Path-steps", "Seed papers"):
        assert f"**{word}" in glossary, word
    assert "make run" in README and "make test" in README


def test_readme_building_example_prints_what_it_shows(tmp_path):
    """The README's building under earthquakes: the exceedance of a drift ratio of 1/200 and the
    fragility fitted in memory print the numbers the README shows (to their printed digits)."""
    code = _block("A building under earthquakes", "python")
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    shown = _block("fitted in memory:\n\n```python", "text")
    assert done.stdout.split() == shown.split()
    scope: dict = {}
    exec(code[:code.index("results = ")], scope)  # (the scenario's dict, not its run)
    path = tmp_path / "building.toml"
    from tests.helpers import toml_text

    path.write_text(toml_text(scope["building"]))
    done = subprocess.run([sys.executable, "-m", "vines_stoch.cli", "validate", str(path)],
                          capture_output=True, text=True, timeout=120)
    periods = re.findall(r"T\d = ([0-9.]+) s", done.stdout)
    assert [f"{float(t):.3g}" for t in periods] == ["0.495", "0.174", "0.121"]
    assert "modal periods (0.495, 0.174 and 0.121 s)" in " ".join(README.split())
