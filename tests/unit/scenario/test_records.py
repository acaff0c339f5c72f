"""Record files: PEER NGA AT2 (header variants), two columns, one column; clear errors."""

from __future__ import annotations

import numpy as np
import pytest

from tests.helpers import ROOT, toml_text
from vines_stoch import ScenarioError, load_scenario
from vines_stoch.physics.loads import GROUND
from vines_stoch.records import G, RecordError, read_record
from vines_stoch.scene import build_scene

AT2_NEW = """PEER NGA STRONG MOTION DATABASE RECORD
IMPERIAL VALLEY 05/19/40, EL CENTRO ARRAY #9, 180
ACCELERATION TIME SERIES IN UNITS OF G
NPTS=    7, DT=   .0100 SEC
  .1000000E-01  .2000000E-01 -.3000000E-01  .4000000E-01  .5000000E-01
 -.6000000E-01  .7000000E-01
"""

AT2_OLD = """PACIFIC ENGINEERING AND ANALYSIS STRONG-MOTION DATA
 IMPERIAL VALLEY 05/19/40 0439, EL CENTRO ARRAY #9, 180
 ACCELERATION TIME HISTORY IN UNITS OF G
    7    0.0100    NPTS, DT
  .01000 .02000 -.03000 .04000 .05000
  -.06000 .07000
"""

VALUES = np.array([0.01, 0.02, -0.03, 0.04, 0.05, -0.06, 0.07])

def scenario(file: str, units: str, scale: float, **load) -> str:
    """Scenario text of a primary under the record ``file`` (``load``: more keys of the load)."""
    return toml_text({"name": "record",
                      "primary": {"mass": 2.0, "stiffness": 30.0, "damping": 0.5},
                      "loads": [{"type": "record", "file": file, "units": units, "scale": scale, **load}],
                      "simulation": {"duration": 0.2, "dt": 0.001}})


@pytest.mark.parametrize("text", [AT2_NEW, AT2_OLD], ids=["npts=-header", "old-header"])
def test_at2_headers(tmp_path, text):
    path = tmp_path / "r.AT2"
    path.write_text(text)
    for fmt in ("auto", "at2"):
        t, a = read_record(path, fmt)
        np.testing.assert_allclose(t, 0.01 * np.arange(7))
        np.testing.assert_allclose(a, VALUES)


def test_column_files(tmp_path):
    two = tmp_path / "two.txt"
    two.write_text("# t a\n0.0 0.1\n0.02 -0.2\n\n0.05 0.3\n")
    t, a = read_record(two)
    np.testing.assert_allclose(t, [0.0, 0.02, 0.05])
    np.testing.assert_allclose(a, [0.1, -0.2, 0.3])
    one = tmp_path / "one.txt"
    one.write_text("0.1\n-0.2\n0.3\n")
    t, a = read_record(one, dt=0.02)
    np.testing.assert_allclose(t, [0.0, 0.02, 0.04])
    np.testing.assert_allclose(a, [0.1, -0.2, 0.3])


@pytest.mark.parametrize("content, kwargs, message", [
    (AT2_NEW.replace("NPTS=    7", "NPTS=    8"), {}, "NPTS = 8, the file has 7 values"),
    (AT2_NEW.replace(".4000000E-01", "abc"), {}, "line 5: a 3-character token is not a number"),
    (AT2_NEW.replace("DT=   .0100", "DT=  -.0100"), {}, "line 4: DT = -0.01: must be > 0"),
    ("0.0 1.0\n0.1 2.0\n0.1 3.0\n", {}, "line 3: time 0.1 does not increase"),
    ("0.0 1.0\n0.1 2.0 5.0\n", {}, "line 2: 3 columns; expected 2"),
    ("1.0\n2.0\n", {}, "the scenario must give dt"),
    ("1.0\nnan\n", {"dt": 0.1}, "line 2: a 3-character token is not a finite number"),
    (AT2_NEW, {"fmt": "two-column"}, "line 1: 6 columns; expected 2"),
    ("0.0 1.0\n", {"fmt": "at2"}, "no AT2 header"),
])
def test_record_errors_name_file_and_line(tmp_path, content, kwargs, message):
    path = tmp_path / "bad.txt"
    path.write_text(content)
    with pytest.raises(RecordError) as err:
        read_record(path, **kwargs)
    assert str(path) in str(err.value)
    assert message in str(err.value)


def test_scenario_reads_records_relative_to_its_file(tmp_path):
    (tmp_path / "records").mkdir()
    (tmp_path / "records" / "r.AT2").write_text(AT2_NEW)
    path = tmp_path / "s.toml"
    path.write_text(scenario("records/r.AT2", "g", 2.0))
    scene = build_scene(load_scenario(path).points[0])
    np.testing.assert_allclose(scene.series_v, 2.0 * G * VALUES)
    assert scene.series_target.tolist() == [GROUND]
    assert scene.scheme == "rk4"


@pytest.mark.parametrize("file, units, extra, message", [
    ("missing.txt", "g", {}, "loads.0.file = 'missing.txt': "),
    ("r.AT2", "g", {"dt": -0.01}, "loads.0.dt = -0.01: must be > 0"),
    ("r.AT2", "gal", {}, "loads.0.units = 'gal': must be 'g' or 'm/s2'"),
    ("r.AT2", "g", {"dt": 0.02}, "the header says DT = 0.01, the scenario dt = 0.02"),
])
def test_scenario_record_errors(tmp_path, file, units, extra, message):
    (tmp_path / "r.AT2").write_text(AT2_NEW)
    path = tmp_path / "s.toml"
    path.write_text(scenario(file, units, 1.0, **extra))
    with pytest.raises(ScenarioError) as err:
        load_scenario(path)
    assert str(path) in str(err.value)
    assert message in str(err.value)


ELCENTRO = ROOT.parent / "shared" / "data" / "elcentro_1940_ns_quakeio.txt"


@pytest.mark.skipif(not ELCENTRO.is_file(), reason="El Centro data file not beside the checkout")
def test_elcentro_record_at_dt_001():
    """The 1940 N-S record read at dt = 0.01 s: PGA 0.3129 g at t = 2.15 s and a PGV near the
    published 0.31-0.36 m/s (trapezoidal integration)."""
    t, a = read_record(ELCENTRO, "one-column", dt=0.01)
    assert t.shape == (3995,)
    k = int(np.argmax(np.abs(a)))
    assert abs(abs(a[k]) - 0.3129) < 5e-4 and abs(t[k] - 2.15) < 1e-9
    velocity = np.concatenate([[0.0], np.cumsum(0.5 * (a[1:] + a[:-1]) * 0.01)]) * G
    assert 0.27 < np.max(np.abs(velocity)) < 0.36
