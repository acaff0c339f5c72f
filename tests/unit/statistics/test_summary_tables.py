"""The summary's quantiles and the in-memory tables' column types, against the slow ways they
stand in for: ``np.quantile`` on every column, and a whole Parquet round trip."""

import numpy as np
import pandas as pd
import pytest

from vines_stoch.ensemble.tables import in_file_types
from vines_stoch.metrics import _quantiles
from vines_stoch.store import write_table

COLUMNS = {
    "spread": np.random.default_rng(3).standard_normal(1001),
    "constant": np.full(50, 2.5),
    "zeros": np.zeros(7),
    "one": np.array([4.0]),
    "a nan": np.array([1.0, np.nan, 3.0]),
    "all nan": np.full(5, np.nan),
    "infinite": np.array([-np.inf, 1.0, np.inf]),
    "constant infinity": np.full(4, np.inf),
    "ties": np.array([1.0, 1.0, 2.0, 2.0, 2.0]),
}


@pytest.mark.parametrize("name", COLUMNS)
def test_quantiles_are_numpys(name):
    values = COLUMNS[name]
    with np.errstate(invalid="ignore"):  # (inf - inf in numpy's interpolation)
        expected, got = np.quantile(values, [0.05, 0.5, 0.95]), _quantiles(values)
    np.testing.assert_array_equal(got, expected)


def test_quantiles_of_nothing_are_nan():
    assert np.isnan(_quantiles(np.array([]))).all()


def test_in_memory_types_are_those_read_back(tmp_path):
    frame = pd.DataFrame({
        "point": np.arange(4, dtype=np.int64), "x": [0.5, -0.0, np.nan, 2.0],
        "flag": [True, False, True, True], "count": np.arange(4, dtype=np.int32),
        "status": pd.array(["ok", "ok", "diverged", "ok"], dtype="str"),
        "regime": pd.array(["1T,1,1", None, "aperiodic", None], dtype="string"),
        "note": ["a", "b", "c", "d"],
        "event_t": [np.array([0.1, 0.2]), np.array([]), np.array([1.0]), np.array([])],
    }, index=[3, 1, 2, 0])
    write_table(frame.reset_index(drop=True), tmp_path / "t.parquet", {})
    read = pd.read_parquet(tmp_path / "t.parquet")
    got = in_file_types(frame)
    pd.testing.assert_frame_equal(got, read, check_exact=True)
    assert list(got.dtypes) == list(read.dtypes)


def _samples():
    """Samples of many shapes: sizes around the buckets' and the sorted case's, ties, a far
    outlier (every other value in one bucket), widths past the largest double, tiny widths."""
    rng = np.random.default_rng(11)
    yield from (rng.standard_normal(n) for n in (2, 3, 10, 255, 256, 257, 1000, 4097, 100_003))
    yield rng.lognormal(0.0, 3.0, 50_000)
    yield np.round(rng.standard_normal(20_000), 1)  # (ties)
    yield np.append(rng.standard_normal(30_000), 1e12)
    yield np.array([-1e308, 1e308, 0.0, 5.0] * 100)
    yield 1.0 + 1e-15 * rng.standard_normal(5000)
    yield np.append(np.zeros(10_000), 5e-324)
    yield np.concatenate([rng.standard_normal(1000), [np.inf, -np.inf]])
    yield -np.abs(rng.standard_normal(2000)) * 0.0  # (zeros of both signs)


@pytest.mark.parametrize("values", list(_samples()), ids=lambda v: f"n{v.size}")
@pytest.mark.parametrize("q", [(0.05, 0.5, 0.95), (0.0, 1.0), (0.25, 0.999999, 1e-9)])
def test_compiled_quantiles_are_numpys_bit_for_bit(values, q):
    from vines_stoch.order import quantiles

    with np.errstate(invalid="ignore"):
        expected, got = np.quantile(values, q), quantiles(values, np.array(q))
    # (bit for bit, but for the sign of a zero: which of equal values a search finds is its own)
    assert (got + 0.0).tobytes() == (expected + 0.0).tobytes()
