"""Scenario validation: one clear message per mistake, naming file, key, value and rule."""

from __future__ import annotations

import math
import subprocess
import sys
import tomllib

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.helpers import study_from
from vines_stoch import ScenarioError, load_scenario

GOOD = """
name = "t"
[primary]
mass = 1.0
stiffness = 1.0
damping = 0.0
[[absorbers]]
type = "cubic"
mass = 0.05
stiffness = 1.0
damping = 0.01
[[absorbers]]
type = "impact"
mass = 0.05
clearance = 0.2
restitution = 0.6
[[loads]]
type = "impulse"
velocity = 0.5
[simulation]
duration = 10.0
dt = 1e-3
"""
#: The tables of ``GOOD``.
GOOD_DATA = tomllib.loads(GOOD)

CASES = [
    ("unknown key", GOOD.replace("damping = 0.0\n[[", "dampnig = 0.0\n[["),
     "primary.dampnig = 0.0: unknown key; allowed keys: mass, stiffness, damping"),
    ("wrong type", GOOD.replace("mass = 1.0", 'mass = "heavy"'),
     "primary.mass = 'heavy': must be a number"),
    ("negative mass", GOOD.replace("mass = 1.0", "mass = -1.0"),
     "primary.mass = -1.0: must be in [1e-15, 1e+15]"),
    ("restitution", GOOD.replace("restitution = 0.6", "restitution = 1.4"),
     "absorbers.1.restitution = 1.4: must be in [0, 1]"),
    ("missing section", GOOD.replace("[simulation]\nduration = 10.0\ndt = 1e-3\n", ""),
     "simulation: missing required section"),
    ("unknown absorber type", GOOD.replace('type = "cubic"', 'type = "magnetic"'),
     "absorbers.0.type = 'magnetic': must be one of 'linear', 'cubic', 'impact'"),
    ("negative damping", GOOD.replace("damping = 0.01", "damping = -0.01"),
     "absorbers.0.damping = -0.01: must be >= 0"),
    ("dt beyond duration", GOOD.replace("dt = 1e-3", "dt = 20.0"),
     "simulation.dt = 20.0: must be <= simulation.duration (10)"),
    ("bad sweep key", GOOD + '[sweep]\n"loads.3.velocity" = [1.0, 2.0]\n',
     "sweep.loads.3.velocity = [1.0, 2.0]: must name an existing numeric field"),
    ("sweep out of range", GOOD + '[sweep]\n"absorbers.1.restitution" = [0.5, 1.5]\n',
     "sweep.absorbers.1.restitution = [0.5, 1.5]: its value 1.5: must be in [0, 1]"),
    ("pulse wider than period", GOOD.replace('type = "impulse"\nvelocity = 0.5',
                                             'type = "pulse-train"\namplitude = 1.0\nwidth = 2.0\n'
                                             'period = 1.0'),
     "loads.0.width = 2.0: must be <= period (1)"),
    ("ground motion without filter", GOOD.replace('type = "impulse"\nvelocity = 0.5',
                                                  'type = "ground-motion"\nintensity = 1.0'),
     "loads.0.ground_frequency: missing: give it or a soil preset (firm, medium, soft)"),
    ("stationary start with envelope", GOOD.replace(
        'type = "impulse"\nvelocity = 0.5',
        'type = "filtered-noise"\nintensity = 1.0\nfrequency = 2.0\ndamping = 0.1\nstart = "stationary"\n'
        'envelope = { type = "saragoni-hart", peak = 3.0, shape = 2.0 }'),
     "loads.0.start = 'stationary': a stationary start needs a load without envelope"),
    ("jennings order", GOOD.replace('type = "impulse"\nvelocity = 0.5',
                                    'type = "ground-motion"\nsoil = "soft"\nintensity = 1.0\n'
                                    'envelope = { type = "jennings", rise = 5.0, hold = 2.0, decay = 0.2 }'),
     "loads.0.envelope.hold = 2.0: must be >= rise (5)"),
    ("rk4 with filtered noise", GOOD.replace('type = "impulse"\nvelocity = 0.5',
                                             'type = "filtered-noise"\nintensity = 1.0\nfrequency = 2.0\n'
                                             'damping = 0.1')
     + 'scheme = "rk4"\n', "simulation.scheme = 'rk4': is deterministic"),
    ("history quantile", GOOD + "history = { quantiles = [0.05, 1.5] }\n",
     "simulation.history.quantiles.1 = 1.5: must be in (0, 1)"),
    ("history points", GOOD + "history = { points = 1 }\n",
     "simulation.history.points = 1: must be in [2, 100000]"),
    ("history repeated quantile", GOOD + "history = { quantiles = [0.5, 0.5] }\n",
     "simulation.history.quantiles = [0.5, 0.5]: must not repeat a value"),
    ("target sem", GOOD + "[ensemble]\ntarget_sem = 0.0\n", "ensemble.target_sem = 0.0: must be > 0"),
    ("double-sided without its left obstacle", GOOD.replace(
        'type = "impact"\nmass = 0.05\nclearance = 0.2\nrestitution = 0.6',
        'type = "hertz"\ngeometry = "double-sided"\nmass = 0.05\noffset = 0.0\ngap = 0.2\n'
        'contact_right = { k = 1e6 }'),
     "absorbers.1.contact_left: missing: a double-sided absorber has a left contact"),
    ("one barrier with a left contact", GOOD.replace(
        'type = "impact"\nmass = 0.05\nclearance = 0.2\nrestitution = 0.6',
        'type = "hertz"\ngeometry = "one-barrier"\nmass = 0.05\noffset = 0.0\ngap = 0.2\n'
        'contact_left = { k = 1e6 }\ncontact_right = { k = 1e6 }'),
     "absorbers.1.contact_left = {'k': 1000000.0}: a one-barrier absorber never touches the primary"),
]


@pytest.mark.parametrize("label,text,message", CASES, ids=[c[0] for c in CASES])
def test_bad_input_names_file_key_value_and_rule(write, label, text, message):
    path = write(text)
    with pytest.raises(ScenarioError) as err:
        load_scenario(path)
    assert str(err.value).startswith(str(path)), err.value
    assert message in str(err.value)


def test_a_one_barrier_absorber_never_touches_the_primary(write):
    """Seed 001 eq. (1), ``geometry = "one-barrier"``: no surface on the primary (its wall at
    -inf, its constant 0), the obstacle at ``gap`` from the primary with ``obstacle =
    "from-primary"``."""
    text = GOOD.replace('type = "impact"\nmass = 0.05\nclearance = 0.2\nrestitution = 0.6',
                        'type = "hertz"\ngeometry = "one-barrier"\nmass = 0.05\noffset = 0.1\ngap = 0.2\n'
                        'obstacle = "from-primary"\ncontact_right = { k = 1e6 }')
    row = load_scenario(write(text)).points[0].absorbers[1].parameters()
    assert (row["wall_lo"], row["wall_hi"], row["k_left"], row["k_right"]) == (-math.inf, 0.2, 0.0, 1e6)


def test_zero_stiffness_and_damping_are_valid():
    study = study_from(GOOD_DATA, {"primary.stiffness": 0.0, "absorbers.0.stiffness": 0.0,
                                   "absorbers.0.damping": 0.0})
    assert study.base.primary.stiffness == 0.0


def test_sweep_grid_values():
    study = study_from(GOOD_DATA, {"sweep": {"loads.0.velocity": {"logspace": [0.01, 10.0, 4]}}})
    values = [p.loads[0].velocity for p in study.points]
    assert values == pytest.approx([0.01, 0.1, 1.0, 10.0], rel=1e-12)


@pytest.mark.parametrize("text", [c[1] for c in CASES[:6]], ids=[c[0] for c in CASES[:6]])
def test_cli_exits_nonzero_without_traceback(write, text):
    path = write(text)
    proc = subprocess.run([sys.executable, "-m", "vines_stoch.cli", "validate", str(path)],
                          capture_output=True, text=True)
    assert proc.returncode != 0
    assert "Traceback" not in proc.stderr + proc.stdout
    lines = [line for line in proc.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and str(path) in lines[0], proc.stderr


@settings(max_examples=60, deadline=None)
@given(st.floats(allow_nan=True, allow_infinity=True))
def test_restitution_accepted_exactly_in_unit_interval(value):
    changes = {"absorbers.1.restitution": value}
    if value == value and 0.0 <= value <= 1.0:
        assert study_from(GOOD_DATA, changes).base.absorbers[1].restitution == value
    else:
        with pytest.raises(ScenarioError, match="absorbers.1.restitution"):
            study_from(GOOD_DATA, changes)
