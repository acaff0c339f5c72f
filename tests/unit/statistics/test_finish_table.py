"""``metrics.finish_table``: the metric columns of many realisations at once, bit for bit those
of the per-realisation formulas (kept here as the oracle, ``reference_row``), and
``ensemble.run_chunk``'s table built on it: the same columns, order, dtypes and values as a
table of per-realisation rows.

Scenes: white noise on a cubic NES; an impact NES under filtered ground motion with limits and
``sa``/``pga``; a two-storey building with an impact absorber and two limits; a periodically
forced impact NES (Poincare samples and regimes, one scene a row as in an uncertain study); a
scene without input energy; and synthetic rows that diverge or hold edge values.
"""

from __future__ import annotations

import math
import struct

import numpy as np
import pandas as pd
import pytest

from tests.helpers import example_data, scene_from, study_from, two_dof_data
from vines_stoch.dynamics import refine_regimes
from vines_stoch.ensemble import draw_parameters, run_chunk
from vines_stoch.kernels import sample_buffer, simulate
from vines_stoch.kernels.chunk import realization_streams
from vines_stoch.metrics import (
    FAILED_BALANCE,
    MAX_PERIOD,
    PERIODIC_TOLERANCE,
    finish,
    finish_table,
    ground_intensity,
    regime,
    regimes,
)
from vines_stoch.outputs import (
    ACC_MAX_K,
    DRIFT_MAX_K,
    SLOTS,
    STATUS_DIVERGED,
    X_MAX_K,
    X_SQ_INT_K,
    passage_slots,
)
from vines_stoch.scenario.settings import REGIME_SAMPLES
from vines_stoch.scene import build_scene

_S = {name: i for i, name in enumerate(SLOTS)}
SEED = 5


def reference_row(raw: np.ndarray, scene, samples: np.ndarray | None = None) -> dict:
    """The metric row of one realisation by the per-realisation formulas (the oracle)."""
    g = raw.tolist().__getitem__
    input_energy = g(_S["input_energy"])
    absorbed = g(_S["absorber_dissipation"]) + g(_S["impact_loss"])
    dissipated = absorbed + g(_S["primary_dissipation"])
    edm = absorbed / input_energy if input_energy > 0 else math.nan
    residual = ((input_energy - g(_S["final_energy"]) - dissipated) / input_energy if input_energy > 0
                else math.nan)
    row = {
        "input_energy": input_energy,
        "edm": edm,
        "energy_integral": g(_S["energy_integral"]),
        "e1_max": g(_S["e1_max"]),
        "x1_max": g(_S["x1_max"]),
        "x1_rms": math.sqrt(max(g(_S["x1_square_integral"]), 0.0) / scene.window),
        "impacts": int(g(_S["impacts"])),
        "energy_residual": residual,
        "primary_dissipation": g(_S["primary_dissipation"]),
        "absorber_dissipation": g(_S["absorber_dissipation"]),
        "impact_loss": g(_S["impact_loss"]),
        "impacts_left": int(g(_S["impacts_left"])),
        "impacts_right": int(g(_S["impacts_right"])),
        "peak_force": g(_S["peak_force"]),
        "contact_time": g(_S["contact_time"]),
    }
    nf = scene.n_floors
    for k in range(nf):
        slot = len(SLOTS) + k
        row[f"x_max_{k + 1}"] = g(slot + X_MAX_K * nf)
        row[f"x_rms_{k + 1}"] = math.sqrt(max(g(slot + X_SQ_INT_K * nf), 0.0) / scene.window)
        row[f"drift_max_{k + 1}"] = g(slot + DRIFT_MAX_K * nf)
        row[f"acc_max_{k + 1}"] = g(slot + ACC_MAX_K * nf)
    finite = all(math.isfinite(v) for k, v in row.items() if k not in ("edm", "energy_residual"))
    passages = passage_slots(nf)
    for limit, name in enumerate(scene.limit_names):
        row[f"first_passage_{name}"] = g(passages + limit)
    # (the scheme failed: a balance off by more than half the input, or where none went in by more
    # than half the largest account; a dissipation negative beyond that; NaN is not)
    final, losses = g(_S["final_energy"]), [g(_S[k]) for k in ("primary_dissipation", "absorber_dissipation",
                                                                  "impact_loss")]
    dissipated = losses[1] + losses[2] + losses[0]
    scale = input_energy if input_energy > 0 else max(abs(v) for v in (input_energy, final, *losses))
    failed = (abs(input_energy - final - dissipated) > FAILED_BALANCE * scale
              or dissipated < -FAILED_BALANCE * scale)
    row["status"] = "diverged" if g(_S["status"]) == STATUS_DIVERGED or not finite or failed else "ok"
    row["regime"] = (regime(samples, 2.0 * np.pi / scene.period)
                     if samples is not None and samples.size and row["status"] == "ok" else None)
    return row


def reference_chunk(scene, seed: int, point: int, start: int, stop: int, study=None) -> pd.DataFrame:
    """``run_chunk``'s table (no history) from per-realisation rows of ``reference_row``, the
    regimes then named (``dynamics.refine_regimes``)."""
    rows, scenes, kept = [], [], []
    for r in range(start, stop):
        drawn = draw_parameters(study, seed, point, r) if study is not None else {}
        if drawn:
            scene = build_scene(study.realise(point, drawn))
        samples = sample_buffer(scene)
        raw = simulate(scene, realization_streams(scene, seed, point, r), samples=samples)
        scenes.append(scene)
        kept.append(samples)
        row = {"point": point, "realization": r, **drawn, **reference_row(raw, scene, samples)}
        if scene.im_period > 0:
            row.update(ground_intensity(scene, realization_streams(scene, seed, point, r)))
        rows.append(row)
    frame = pd.DataFrame(rows)
    frame["regime"] = frame["regime"].astype("string")
    longest = max(len(k) for k in kept)  # (an uncertain frequency: as many samples as periods)
    padded = np.stack([np.pad(k, ((0, longest - len(k)), (0, 0)), constant_values=np.nan) for k in kept])
    refine_regimes(frame, scenes, padded, every=scenes[0].lyapunov)
    return frame


def realisations(scene, n: int) -> tuple[np.ndarray, list[np.ndarray]]:
    """Raw vectors ``(n, slots)`` and Poincare samples of realisations ``0..n-1`` of ``scene``."""
    raws, samples = [], []
    for r in range(n):
        buffer = sample_buffer(scene)
        raws.append(simulate(scene, realization_streams(scene, SEED, 0, r), samples=buffer))
        samples.append(buffer)
    return np.stack(raws), samples


def bits(value) -> bytes:
    return struct.pack("<d", value)


def assert_same(got, want, where: str) -> None:
    """Equal values of the same Python type; floats bit for bit (NaN, -0.0 included)."""
    assert type(got) is type(want), f"{where}: {got!r} ({type(got)}) != {want!r} ({type(want)})"
    if isinstance(want, float):
        assert bits(got) == bits(want), f"{where}: {got!r} != {want!r}"
    else:
        assert got == want, f"{where}: {got!r} != {want!r}"


def assert_rows(table: pd.DataFrame, rows: list[dict]) -> None:
    """``table`` holds ``rows`` (dicts of the oracle) in order: columns, dtypes and values."""
    assert len(table) == len(rows)
    assert list(table.columns) == list(rows[0])
    for name in table.columns:
        want = rows[0][name]
        kind = {bool: None, int: np.dtype(np.int64), float: np.dtype(np.float64)}.get(type(want))
        if name == "regime":
            assert table[name].dtype == pd.StringDtype(na_value=pd.NA)
        elif name == "status":
            assert table[name].dtype == pd.DataFrame({"s": ["ok"]})["s"].dtype
        else:
            assert table[name].dtype == kind, name
    for i, row in enumerate(rows):
        for name, want in row.items():
            got = table[name].iloc[i]
            if name == "regime":
                got = None if got is pd.NA else got
            elif isinstance(got, np.floating):
                got = float(got)
            elif isinstance(got, np.integer):
                got = int(got)
            assert_same(got, want, f"row {i} {name}")


NOISY = {"name": "noisy", **two_dof_data(),
         "loads": [{"type": "harmonic", "amplitude": 0.1, "frequency": 1.0},
                   {"type": "white-noise", "intensity": 0.05}],
         "simulation": {"duration": 20.0, "dt": 0.01}}
BUILDING = {"name": "two-storey-limits",
            "primary": {"masses": [2.0, 1.0], "stiffnesses": [200.0, 120.0], "dampings": [0.8, 0.5]},
            "absorbers": [{"type": "impact", "mass": 0.1, "clearance": 0.02, "restitution": 0.6,
                           "floor": 2}],
            "loads": [{"type": "white-noise", "intensity": 2.0}],
            "simulation": {"duration": 8.0, "dt": 0.002, "metrics_from": 1.0},
            "limits": {"roof": {"metric": "x_max_2", "value": 0.4},
                       "drift": {"metric": "drift_max_1", "value": 0.22}}}
PERIODIC = {"name": "periodic", "primary": {"mass": 1.0, "stiffness": 1.0, "damping": 0.3},
            "absorbers": [{"type": "impact", "mass": 0.2, "clearance": 0.6, "restitution": 0.6,
                           "damping": 0.3, "stiffness": 0.5}],
            "loads": [{"type": "harmonic", "amplitude": 1.0, "frequency": 1.0}],
            "simulation": {"duration": 300.0, "dt": 1e-2, "scheme": "rk4"}}
STILL = {"name": "still", **two_dof_data(),
         "loads": [{"type": "harmonic", "amplitude": 0.0, "frequency": 1.0}],
         "simulation": {"duration": 10.0, "dt": 0.01, "scheme": "rk4"}}


def ground_motion() -> dict:
    data = example_data("ground_motion", "sweep")
    data["simulation"] = {"duration": 6.0, "dt": 2e-3}
    return data


@pytest.mark.parametrize("case", ["noisy", "ground-motion", "building", "still"])
def test_rows_of_simulated_realisations_match_the_oracle(case):
    data = {"noisy": NOISY, "ground-motion": ground_motion(), "building": BUILDING, "still": STILL}[case]
    scene = scene_from(data)
    raws, samples = realisations(scene, 1 if case == "still" else 6)
    rows = [reference_row(raw, scene, s) for raw, s in zip(raws, samples)]
    assert_rows(finish_table(raws, scene, samples), rows)
    assert_rows(finish_table(raws, scene), [{**row, "regime": None} for row in rows])
    if case == "ground-motion":
        assert any(row["impacts"] > 0 for row in rows)
    if case == "building":
        assert {"first_passage_roof", "first_passage_drift", "x_rms_2"} <= set(rows[0])
        assert any(math.isfinite(row["first_passage_roof"]) for row in rows)
        assert any(math.isnan(row["first_passage_roof"]) for row in rows)
    if case == "still":
        assert rows[0]["input_energy"] == 0.0 and math.isnan(rows[0]["edm"]) and rows[0]["status"] == "ok"


def orbit(n: int, count: int = REGIME_SAMPLES) -> np.ndarray:
    """``count`` Poincare rows of an ``n``T orbit of two bodies with one left impact each ``n``
    periods."""
    rows = []
    for k in range(count):
        state = [0.1 * (k % n), 0.2, 0.5, 0.0]
        rows.append(state + [k // n, 0])
    return np.array(rows, dtype=float)


def test_periodic_rows_get_their_regime_and_edge_values_their_status():
    """Regimes from each row's samples (none where a row diverged or has none); NaN, inf,
    -0.0, negative square integrals and non-positive input energy as the oracle has them."""
    scene = scene_from(PERIODIC)
    raws, samples = realisations(scene, 1)
    raw = raws[0]
    assert reference_row(raw, scene, samples[0])["regime"] == "T,2,2"
    n_floors = scene.n_floors
    edits = [
        {},                                                  # the simulated row: T,2,2
        {},                                                  # with a 2T orbit's samples
        {},                                                  # with noisy samples: aperiodic
        {"status": STATUS_DIVERGED},                         # flagged: no regime
        {"e1_max": math.inf},                                # an infinite metric: diverged
        {"x1_square_integral": math.nan},                    # NaN x1_rms: diverged
        {"x1_square_integral": -1.0},                        # clipped to 0
        {"x1_square_integral": -0.0},                        # max(-0.0, 0.0) is -0.0
        {"x1_square_integral": 1e308},                       # overflows over a short window
        {"input_energy": 0.0},                               # edm, residual NaN; energy from nowhere
        {"input_energy": -2.0},                              # the same: diverged
        {"input_energy": 0.0, "final_energy": 0.0, "primary_dissipation": 0.0, "absorber_dissipation": 0.0,
         "impact_loss": 0.0},                                # no energy at all: ok
        {"absorber_dissipation": -raw[_S["input_energy"]]},  # a dashpot giving energy back: diverged
        {"input_energy": math.nan},                          # diverged
        {"final_energy": math.inf},                          # an infinite residual: the scheme failed
        {"final_energy": raw[_S["final_energy"]] + 0.25 * raw[_S["input_energy"]]},  # residual -0.25: ok
        {"final_energy": raw[_S["final_energy"]] + 0.75 * raw[_S["input_energy"]]},  # -0.75: diverged
        {"absorber_dissipation": math.nan},                  # edm NaN, but a metric NaN: diverged
        {"impacts": 3.7, "impacts_left": -2.5},              # truncated as int()
        {len(SLOTS) + ACC_MAX_K * n_floors: math.inf},       # a floor metric: diverged
        {"contact_time": -0.0},
    ]
    table_raw = np.repeat(raw[np.newaxis], len(edits), axis=0)
    for i, edit in enumerate(edits):
        for key, value in edit.items():
            table_raw[i, _S[key] if isinstance(key, str) else key] = value
    rng = np.random.default_rng(1)
    count = samples[0].shape[0]  # (every forcing period of the window)
    noisy = orbit(1, count) + rng.normal(0.0, 0.05, size=(count, 6)) * [1, 1, 1, 1, 0, 0]
    rows_samples = [samples[0], orbit(2, count), noisy] + [samples[0]] * (len(edits) - 3)
    rows_samples[-1] = None
    rows_samples[-2] = np.empty((0, 6))
    short = build_scene(study_from(PERIODIC, {"simulation.metrics_from": 299.99}).points[0])
    for sc in (scene, short):
        want = [reference_row(r, sc, s) for r, s in zip(table_raw, rows_samples)]
        assert_rows(finish_table(table_raw, sc, rows_samples), want)
    want = [reference_row(r, scene, s) for r, s in zip(table_raw, rows_samples)]
    assert [w["regime"] for w in want[:4]] == ["T,2,2", "2T,1,0", "aperiodic", None]
    assert [w["status"] for w in want[3:6]] == ["diverged"] * 3
    assert [w["status"] for w in want[9:13]] == ["diverged", "diverged", "ok", "diverged"]
    # samples as one array (realisations, samples, columns)
    stacked = np.stack([samples[0], orbit(2, count), noisy])
    assert_rows(finish_table(table_raw[:3], scene, stacked), want[:3])
    # the single-row form
    for r, s, w in zip(table_raw, rows_samples, want):
        row = finish(r, scene, s)
        assert list(row) == list(w)
        for name in w:
            assert_same(row[name], w[name], name)


def test_one_scene_a_row_reads_each_window_and_period():
    """Rows of different scenes (forcing frequency and metrics window, as an uncertain study's
    realisations): each row's x1_rms and regime from its own scene."""
    scenes = [scene_from(PERIODIC, changes={"loads.0.frequency": f, "simulation.metrics_from": m})
              for f, m in ((0.9, 50.0), (1.0, 100.0), (1.1, 20.0))]
    assert len({s.window for s in scenes}) == 3 and len({s.period for s in scenes}) == 3
    raws, samples = [], []
    for sc in scenes:
        raw, sample = realisations(sc, 1)
        raws.append(raw[0])
        samples += sample
    want = [reference_row(r, sc, s) for r, sc, s in zip(raws, scenes, samples)]
    assert all(w["regime"] for w in want)
    assert_rows(finish_table(np.stack(raws), scenes, samples), want)
    # velocities alternating by 0.95e-3: a 2T orbit at omega = 0.9, within tolerance of T above
    alternating = np.zeros((REGIME_SAMPLES, 6))
    alternating[:, :2] = 1.0
    alternating[::2, 2] = 0.95e-3
    want = [reference_row(r, sc, alternating) for r, sc in zip(raws, scenes)]
    assert [w["regime"] for w in want] == ["2T,0,0", "T,0,0", "T,0,0"]
    assert_rows(finish_table(np.stack(raws), scenes, [alternating] * 3), want)
    with pytest.raises(ValueError, match="scenes for"):
        finish_table(np.stack(raws), scenes[:2], samples)
    with pytest.raises(ValueError, match="same floors and limits"):
        finish_table(np.stack(raws[:2]), [scenes[0], scene_from(BUILDING)])


def test_refusals_as_the_per_row_formulas():
    scene = scene_from(NOISY)
    raw = np.zeros((2, passage_slots(scene.n_floors)))
    with pytest.raises(ValueError, match="2-D"):
        finish_table(raw[0], scene)
    raw[1, _S["impacts"]] = math.nan
    with pytest.raises(ValueError):
        reference_row(raw[1], scene)
    with pytest.raises(ValueError, match="impact counts"):
        finish_table(raw, scene)
    assert len(finish_table(raw[:0], scene)) == 0


@pytest.mark.parametrize("case", ["noisy", "ground-motion-im", "building", "uncertain-periodic"])
def test_run_chunk_table_matches_per_realisation_rows(case):
    """Columns, order, dtypes and values of ``run_chunk``'s table as a table of per-row dicts."""
    if case == "uncertain-periodic":
        data = {**PERIODIC, "uncertain": {
            "absorbers.0.damping": {"distribution": "uniform", "low": 0.2, "high": 0.5},
            "loads.0.frequency": {"distribution": "uniform", "low": 0.8, "high": 1.2},
            "absorbers.0.clearance": {"distribution": "uniform", "low": 0.3, "high": 1.5}}}
    else:
        with_im = {**ground_motion(), "intensity_measures": {"period": 1.0}}
        data = {"noisy": NOISY, "ground-motion-im": with_im, "building": BUILDING}[case]
    study = study_from(data)
    uncertain = study if study.base.uncertain else None
    scene = build_scene(study.points[0])
    got, _ = run_chunk(scene, SEED, 0, 2, 7, study=uncertain)
    want = reference_chunk(scene, SEED, 0, 2, 7, uncertain)
    pd.testing.assert_frame_equal(got, want, check_exact=True)
    assert got.dtypes.tolist() == want.dtypes.tolist()
    for name in want.columns:
        if want[name].dtype.kind in "fi":
            assert got[name].to_numpy().tobytes() == want[name].to_numpy().tobytes(), name
    if case == "ground-motion-im":
        assert list(got.columns[-2:]) == ["sa", "pga"]
    if case == "uncertain-periodic":
        assert got["regime"].notna().all() and got["regime"].nunique() > 1


def _regime_of_one(samples: np.ndarray, omega: float) -> str | None:
    """MODEL.md section 4's regime of one realisation, written out as a loop (the oracle of
    ``metrics.regimes``, which runs a chunk's rows together)."""
    rows = samples[~np.isnan(samples[:, 0])]
    nb = (samples.shape[1] - 2) // 2
    if rows.shape[0] < 3:
        return None
    state = np.hstack([rows[:, :nb], rows[:, nb:2 * nb] / omega])
    scale = float(np.abs(state).max()) or 1.0
    for n in range(1, MAX_PERIOD + 1):
        if rows.shape[0] < 2 * n + 1:
            break
        if np.abs(state[n:] - state[:-n]).max() <= PERIODIC_TOLERANCE * scale:
            cycles = (rows.shape[0] - 1) // n
            left, right = (rows[-1, 2 * nb:] - rows[-1 - cycles * n, 2 * nb:]) / cycles
            return f"{'' if n == 1 else n}T,{left:.0f},{right:.0f}"
    return "aperiodic"


def test_regimes_of_a_chunk_are_each_rows():
    """Rows of 1T, 2T, 3T and 8T orbits, aperiodic and resting rows, with fewer samples kept (a
    shorter window: NaN after them; two samples: none), and per-row forcing frequencies."""
    rng = np.random.default_rng(4)
    rows = []
    for k, n in enumerate([1, 2, 3, 8, 1, 2]):
        rows.append(orbit(n))
        rows.append(orbit(n) + rng.normal(0.0, 0.05, size=orbit(n).shape) * [1, 1, 1, 1, 0, 0])
        short = orbit(n)
        short[5 + 3 * k:] = np.nan
        rows.append(short)
    rows.append(np.zeros_like(orbit(1)))
    rows.append(orbit(1))
    rows[-1][2:] = np.nan  # (two samples: no regime)
    samples = np.stack(rows)
    omega = rng.uniform(0.5, 2.0, samples.shape[0])
    got = regimes(samples, omega)
    assert got == [_regime_of_one(s, w) for s, w in zip(samples, omega)]
    assert {"T,1,0", "2T,1,0", "8T,1,0", "aperiodic", None} <= set(got)
