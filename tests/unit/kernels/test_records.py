"""What a run records beyond the metrics: the event log against the metrics it details and the
Newton impact's closed-form loss, the same numbers whatever a run asks to record, and one loop
whatever it asks."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from tests.helpers import example_scene
from vines_stoch import outputs
from vines_stoch.kernels import chunk_runner, kernel_for, simulate, simulate_chunk
from vines_stoch.outputs import SLOTS, new_events
from vines_stoch.physics.absorbers import HERTZ, IMPACT, RESTITUTION
from vines_stoch.scene import limit_row

_S = {name: i for i, name in enumerate(SLOTS)}

#: Scenes with impacts and Hertz contact in both event schemes: the RK4 step (deterministic
#: impacts beside a cubic NES; the double-sided Hertz NES under harmonic force) and the
#: kick-drift-kick step (deterministic impacts; Hertz contact and plastic impacts under white
#: noise, on the Brownian tree).
CASES = {
    "rk4 impacts": ("parallel_nes_impulse", "rk4", 10.0),
    "rk4 Hertz contact": ("seed003_ds20", "rk4", 10.0),
    "kdk impacts": ("parallel_nes_impulse", "euler-maruyama", 10.0),
    "kdk Hertz contact and impacts under noise": ("contact_noise_parallel", None, 3.0),
}


def _scene(name: str, scheme: str | None, duration: float):
    return example_scene(name, {"simulation.duration": duration, "simulation.metrics_from": duration / 4},
                         scheme)


@pytest.mark.parametrize("case", list(CASES))
def test_the_event_log_details_the_impacts_the_metrics_count(case):
    scene = _scene(*CASES[case])
    events = new_events(100_000)
    out = simulate(scene, np.random.default_rng(3), events=events)
    logged = events[np.isfinite(events[:, outputs.EVENT_T])]
    assert np.isnan(events[len(logged):]).all()  # the rows in order, the rest untouched
    assert len(logged) == out[_S["impacts"]] > 0
    side = logged[:, outputs.EVENT_SIDE]
    assert (side == -1).sum() == out[_S["impacts_left"]] and (side == 1).sum() == out[_S["impacts_right"]]
    t = logged[:, outputs.EVENT_T]
    assert (np.diff(t) >= 0).all()
    assert scene.i0 * scene.dt <= t[0] and t[-1] <= scene.n_steps * scene.dt
    # the losses, in the order the loop added them, sum to the impact loss exactly
    total = 0.0
    for loss in logged[:, outputs.EVENT_LOSS]:
        total += loss
    assert total == out[_S["impact_loss"]]
    a = logged[:, outputs.EVENT_ABSORBER].astype(int)
    kind = scene.kind[a]
    assert set(kind) <= {IMPACT, HERTZ}
    speed = logged[:, outputs.EVENT_SPEED]
    if CASES[case][1] == "rk4":  # each absorber moving into the wall it meets (kick-drift-kick:
        assert (side * speed > 0).all()  # the velocity after the closing kick, which a slow impact's loads
        # may have turned, is the one the impact map acts on)
    assert (logged[kind == HERTZ, outputs.EVENT_LOSS] == 0.0).all()  # (Hertz contact: elastic)
    # an impact loses what the Newton map takes, (1 - e^2) mu u^2 / 2 (Wei et al. eqs. 2-3), or
    # mu u^2 / 2 when it starts sticking (e = 0)
    impacts = kind == IMPACT
    if impacts.any():
        host = scene.host[a[impacts]]
        m1, ma = scene.mass[host], scene.mass[scene.n_floors + a[impacts]]
        mu_u2 = 0.5 * m1 * ma / (m1 + ma) * speed[impacts] ** 2
        e = scene.rows[a[impacts], RESTITUTION]
        elastic = np.isclose(logged[impacts, outputs.EVENT_LOSS], (1 - e**2) * mu_u2, rtol=1e-12, atol=0.0)
        plastic = np.isclose(logged[impacts, outputs.EVENT_LOSS], mu_u2, rtol=1e-12, atol=0.0)
        assert (elastic | plastic).all()


@pytest.mark.parametrize("case", ["rk4 impacts", "kdk impacts", "kdk harmonic and white noise"])
def test_what_a_run_records_changes_no_number(case):
    """The records write into their own arrays, never into the state or the accounts: a run
    that keeps an event log and history rows ends with the metrics and state of one that keeps
    none, bitwise: both run the same compiled loop (``common.recording``)."""
    if case == "kdk harmonic and white noise":
        scene = _scene("seed000_harmonic_noise_none", None, 10.0)
    else:
        scene = _scene(*CASES[case])
    bare_final, kept_final = np.zeros((2, scene.mass.shape[0])), np.zeros((2, scene.mass.shape[0]))
    bare = simulate(scene, np.random.default_rng(5), final=bare_final)
    kept = simulate(scene, np.random.default_rng(5), final=kept_final, events=new_events(7),
                    history=np.zeros((5, 2)), stride=scene.n_steps // 4)
    np.testing.assert_array_equal(kept, bare)
    np.testing.assert_array_equal(kept_final, bare_final)


@pytest.mark.parametrize("case", ["rk4 Hertz contact", "kdk Hertz contact and impacts under noise"])
def test_asking_for_a_record_compiles_nothing(case):
    """What a run records is run-time data of its loop (``common.recording``): a path that keeps
    history rows (a contact force among them), an event log and first passages runs the same
    loop as one that keeps none, on the signature the first compiled, and so does a chunk of
    the scalar loop that keeps them."""
    scene = _scene(*CASES[case])
    kernel = kernel_for(scene, general=True)  # (the loop of a short path: ``kernels.general_run``)
    simulate(scene, np.random.default_rng(5))
    signatures = len(kernel.overloads)
    assert signatures > 0
    limited = replace(scene, limits=np.array([limit_row("e1_max", 1e-9, scene.n_floors)]))
    simulate(limited, np.random.default_rng(5), events=new_events(7), history=np.zeros((5, 2)),
             signals=("x1", "contact_1"), stride=scene.n_steps // 4)
    assert kernel_for(limited, general=True) is kernel and len(kernel.overloads) == signatures
    run = chunk_runner(scene, "scalar")
    simulate_chunk(scene, 5, 0, 0, 1, executor="scalar")
    chunks = len(run.overloads)
    simulate_chunk(limited, 5, 0, 0, 2, history=(10, 3), signals=("x1", "contact_1"), event_rows=4,
                   executor="scalar")
    assert chunk_runner(limited, "scalar") is run and len(run.overloads) == chunks
