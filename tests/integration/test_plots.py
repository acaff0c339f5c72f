"""Plots fit for a paper: physical names and SI units on the axes, PNG and SVG of every figure,
the fragility curve's bootstrap band, whole-number ticks on counts, legends clear of the data."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.special import ndtr

from tests.helpers import cli, sdof_fragility_run
from vines_stoch.fragility import band
from vines_stoch.plotting import counts, label, legend, pyplot, save
from vines_stoch.store import KEY, png_text, prepare_folder, svg_identifier

plt = pyplot("the test figures")
pytestmark = pytest.mark.skipif(plt is None, reason="matplotlib is not installed")


@pytest.mark.parametrize(("column", "tables", "text"), [
    ("t", None, "time [s]"),
    ("e1_max", None, "peak energy of the primary [J] (e1_max)"),
    ("edm_mean", None, "energy dissipation measure EDM, mean [–] (edm_mean)"),
    ("impacts", None, "number of impacts (impacts)"),
    ("drift_max_3", None, "peak drift of storey 3 [m] (drift_max_3)"),
    ("first_passage_roof", None, "first passage of roof [s] (first_passage_roof)"),
    ("loads.0.intensity", None, r"load 1 noise intensity [N s$^{1/2}$] (loads.0.intensity)"),
    ("loads.1.intensity", {"loads": [{"type": "impulse"}, {"type": "ground-motion"}]},
     r"load 2 noise intensity [m s$^{-3/2}$] (loads.1.intensity)"),
    ("loads.0.sa.value", {"loads": [{"type": "record", "units": "g"}]},
     "load 1 target spectral acceleration Sa [g] (loads.0.sa.value)"),
    ("absorbers.0.stiffness", {"absorbers": [{"type": "cubic"}]}, "absorber 1 stiffness [N/m³]"
                                                                  " (absorbers.0.stiffness)"),
    ("absorbers.1.clearance", None, "absorber 2 clearance [m] (absorbers.1.clearance)"),
    ("status", None, "status"),
])
def test_axis_labels_name_the_quantity_and_its_si_unit(column, tables, text):
    assert label(column, tables) == text


def test_every_unit_is_typeset_by_matplotlib():
    """Every unit a label can carry draws (mathtext parses it): powers typeset, not ``^`` text."""
    from vines_stoch.plotting import _BY_TYPE, FIELDS, FLOOR_QUANTITIES, QUANTITIES

    units = {u for _, u in [*QUANTITIES.values(), *FLOOR_QUANTITIES.values(), *FIELDS.values()]}
    units |= set(_BY_TYPE.values())
    fig, ax = plt.subplots()
    for unit in sorted(units):
        assert "^" not in unit.replace("$^{", ""), unit
        ax.set_xlabel(f"x [{unit}]")
        fig.canvas.draw()  # (a unit mathtext cannot parse raises here)
    plt.close(fig)


def test_every_figure_is_png_and_svg_with_the_run_key(tmp_path):
    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    written = save(fig, tmp_path / "figure.png", {KEY: "0123abcd"})
    assert [p.name for p in written] == ["figure.png", "figure.svg"]
    assert png_text(tmp_path / "figure.png")[KEY] == "0123abcd"
    assert svg_identifier(tmp_path / "figure.svg") == f"{KEY} 0123abcd"
    again = save(plt.subplots()[0], tmp_path / "empty")  # (no key: none in the files)
    assert svg_identifier(again[1]) == "" and KEY not in png_text(again[0])


def test_a_new_run_deletes_its_own_fragility_svg_only(tmp_path):
    for name, meta in (("fragility_roof", {KEY: "k"}), ("fragility_other", None)):
        fig, _ = plt.subplots()
        save(fig, tmp_path / name, meta)
    prepare_folder(tmp_path, "new", 1, "s.toml")
    assert not (tmp_path / "fragility_roof.svg").exists() and not (tmp_path / "fragility_roof.png").exists()
    assert (tmp_path / "fragility_other.svg").exists()  # (not this program's: left alone)


def test_count_axes_have_whole_ticks_and_large_legends_go_below_the_axes():
    fig, ax = plt.subplots()
    ax.hist([0.1, 0.2, 0.2, 0.3], bins=3, label="a")
    counts(ax.yaxis)
    fig.canvas.draw()
    ticks = ax.get_yticks()
    assert len(ticks) >= 2 and np.all(ticks == np.round(ticks))
    legend(ax)
    assert ax.get_legend()._loc == 0  # "best": where it covers the least data
    for k in range(5):
        ax.plot([0, 1], [k, k], label=f"line {k}")
    legend(ax)
    fig.canvas.draw()
    box = ax.get_legend().get_window_extent().transformed(ax.transAxes.inverted())
    assert box.y1 < 0.0  # below the axes: clear of the data
    plt.close(fig)


def test_band_of_identical_replicates_is_their_curve_and_a_step_for_beta_zero():
    x = np.geomspace(0.1, 10.0, 50)
    low, high = band(x, np.full(40, 1.5), np.full(40, 0.4))
    np.testing.assert_allclose(low, ndtr(np.log(x / 1.5) / 0.4), rtol=1e-12)
    np.testing.assert_allclose(high, low, rtol=1e-12)
    low, high = band(x, np.r_[np.full(20, 1.0), np.full(20, 2.0)], np.zeros(40))
    assert set(np.unique(low)) <= {0.0, 1.0} and (low <= high).all()
    assert (high[(x >= 1.0) & (x < 2.0)] == 1.0).all() and (low[(x >= 1.0) & (x < 2.0)] == 0.0).all()


def test_fragility_plot_has_its_band_units_and_svg(tmp_path):
    """A linear SDOF under white noise swept over intensity (as test_fragility's run)."""
    out = sdof_fragility_run(tmp_path, "sdof-band", realizations=100, points=5, samples=200)
    svg = (out / "fragility_roof.svg").read_text()
    assert "95 % bootstrap band" in svg and "load 1 noise intensity [N s" in svg
    assert "probability of exceeding roof" in svg
    code, err = cli("report", out, "--out", tmp_path / "reports")
    assert code == 0, err
    folder = tmp_path / "reports" / "sdof-band"
    for name in ("edm_histogram", "exceedance", "edm_vs_input_energy"):
        assert (folder / f"{name}.png").stat().st_size > 0 and (folder / f"{name}.svg").stat().st_size > 0
    assert "[SVG](edm_histogram.svg)" in (folder / "report.md").read_text()


def test_results_plot_in_memory():
    """``Results.plot``: a metric against the swept value with its band and estimate, a limit's
    exceedance and the drift profile, each drawn into an Axes and returned (no file written)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    import vines_stoch

    data = {"name": "frame",
            "primary": {"masses": [2.0, 2.0, 1.5], "stiffnesses": [900.0, 800.0, 700.0],
                        "dampings": [3.0, 2.5, 2.0], "heights": [4.0, 3.0, 3.0]},
            "loads": [{"type": "white-noise", "intensity": 1.0}],
            "simulation": {"duration": 20.0, "dt": 0.005}, "ensemble": {"realizations": 16, "seed": 1},
            "sweep": {"loads.0.intensity": [0.5, 1.0, 2.0]},
            "limits": {"roof": {"metric": "x1_max", "value": 0.1}}}
    results = vines_stoch.run(data)
    ax = results.plot.metric("x1_rms")
    assert len(ax.lines) == 2 and ax.get_xlabel().startswith("load 1 noise intensity")  # mean, estimate
    np.testing.assert_allclose(ax.lines[0].get_ydata(), results.summary["x1_rms_mean"])
    np.testing.assert_allclose(ax.lines[1].get_ydata(), results.summary["x1_rms_estimate"])
    fig, (a, b) = plt.subplots(1, 2)
    assert results.plot.exceedance("roof", ax=a) is a and results.plot.drift_profile(2, ax=b) is b
    profile = [results.summary[f"drift_ratio_max_{k}_mean"].iloc[2] for k in (1, 2, 3)]
    np.testing.assert_allclose(b.lines[0].get_xdata(), profile)
    plt.close("all")
