"""Hertz contact and impacts under noise: the Brownian tree inside a step, Gibbs equipartition,
the noise-free limit, strong convergence on the same Brownian path."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tests.helpers import example_data, lane_metrics, raw_metrics, scene_from, study_from
from vines_stoch.kernels.brownian import MEMO, TREE_DEPTH, new_memo, node_normal, path_value, tree_value
from vines_stoch.kernels.chunk import lane_scene
from vines_stoch.kernels.kdk import tree_point
from vines_stoch.streams.rng import TAIL_WORD
from vines_stoch.validation.precision import same_path_errors, strong_order

#: Soft contact surfaces (K = 7.3e2 N/m^1.5: contacts last long enough to matter for the
#: statistics) and steel on steel.
SOFT = {"young": [1e3, 1e3], "poisson": [0.3, 0.3], "radius": 1.0}


def _hertz(geometry: str, offset: float, gap: float, contact: dict, mass: float = 0.1, stiffness: float = 0.0,
           damping: float = 0.0) -> dict:
    return {"type": "hertz", "geometry": geometry, "mass": mass, "stiffness": stiffness, "damping": damping,
            "offset": offset, "gap": gap, "contact_left": contact, "contact_right": contact}


# -- the Brownian tree -----------------------------------------------------------------------


def test_tree_values_follow_the_brownian_bridge_law():
    """Over 20,000 trees of ``2 W`` (scale 2), the values at three points of ``[0, 1]`` pinned at
    ``0.7`` at 1 have the bridge's mean ``0.7 t`` and covariance ``4 (min(s, t) - s t)``: every
    entry within 4 standard errors (the points are not dyadic, so they lie below the tree's
    leaves)."""
    seeds = np.arange(20_000, dtype=np.uint64) * np.uint64(2654435761) + np.uint64(12345)
    times = np.array([0.1234567, 0.4999, 0.87654321])
    w = np.array([[tree_value(0.7, 1.0, t, 2.0, s, 0, new_memo(1), 0) for t in times] for s in seeds])
    n = w.shape[0]
    mean, cov = w.mean(axis=0), np.cov(w.T)
    exact_cov = 4.0 * (np.minimum.outer(times, times) - np.outer(times, times))
    assert np.all(np.abs(mean - 0.7 * times) < 4 * np.sqrt(np.diag(exact_cov) / n))
    # standard error of a sample covariance of jointly normal variables
    se = np.sqrt((exact_cov**2 + np.outer(np.diag(exact_cov), np.diag(exact_cov))) / n)
    assert np.all(np.abs(cov - exact_cov) < 4 * se)


def _splitmix(z: np.ndarray) -> np.ndarray:
    """splitmix64's output function of ``z + golden`` (Steele, Lea and Flood 2014) in numpy's
    ``uint64`` arithmetic (modulo 2^64)."""
    z = z + np.uint64(0x9E3779B97F4A7C15)
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return z ^ (z >> np.uint64(31))


def test_a_node_normal_is_the_box_muller_cosine_of_its_hash():
    """A tree node's normal against an independent reference (the hash in numpy, Box-Muller's
    cosine in ``float64``): within ``float32`` rounding (4e-7 relative, 1e-7 absolute) for the
    fast transform, within 4 ``float64`` ulps of the radius for the nodes whose first word is below
    ``rng.TAIL_WORD`` (every such node of the first 4 M, whose share is its ``2^-16`` within 5
    standard errors); over 200,000 nodes the normals' mean and variance hold within 5 standard
    errors."""
    key = np.uint64(0x0123456789ABCDEF)
    nodes = np.arange(1, 4_000_001, dtype=np.uint64)
    hashes = _splitmix(key ^ (nodes * np.uint64(0x9E3779B97F4A7C15)))
    tail = (hashes >> np.uint64(32)) < TAIL_WORD
    assert abs(tail.sum() - nodes.size * 2.0**-16) <= 5 * math.sqrt(nodes.size * 2.0**-16)
    for chosen in (np.arange(200_000), np.flatnonzero(tail)):
        h = hashes[chosen]
        u1 = ((h >> np.uint64(32)).astype(float) + 0.5) * 2.0**-32
        radius = np.sqrt(-2.0 * np.log(u1))
        ref = radius * np.cos(2.0 * np.pi * (h & np.uint64(0xFFFFFFFF)).astype(float) * 2.0**-32)
        got = np.array([node_normal(key, int(n)) for n in nodes[chosen]])
        exact = tail[chosen]
        assert np.all(np.abs(got - ref)[~exact] <= 4e-7 * np.abs(ref[~exact]) + 1e-7)
        # (a few ulps of the radius: the cosine's rounding near its zeros)
        assert np.all(np.abs(got - ref)[exact] <= 4 * np.finfo(float).eps * radius[exact])
    got = np.array([node_normal(key, int(n)) for n in nodes[:200_000]])
    assert abs(got.mean()) < 5 / math.sqrt(got.size) and abs(got.var() - 1.0) < 5 * math.sqrt(2 / got.size)


def test_tree_is_one_path_for_a_coarse_step_and_its_fine_steps():
    """The path a step of 8 replayed fine normals sees equals, at any instant, the fine steps'
    path (their partial sums plus the tree below each fine step): a coarse run and the fine run
    integrate the same path.  Exact to rounding."""
    rng = np.random.default_rng(3)
    normals = rng.standard_normal(3 * 8 * 2)  # 3 coarse steps, 8 fine steps each, 2 noisy floors
    seed, dt, refine, sigma = np.uint64(987654321), 0.8, 8, 1.3
    h = dt / refine
    for step in range(3):
        for k in range(2):
            fine = normals[(step * refine + np.arange(refine)) * 2 + k] * sigma * math.sqrt(h)
            for tau in rng.uniform(0.0, dt, 50):
                j = min(int(tau / h), refine - 1)
                expected = fine[:j].sum() + path_value(seed, step * refine + j, k, fine[j], h, tau - j * h,
                                                       sigma, normals, 1, 2, k, False, new_memo(2))
                got = path_value(seed, step, k, fine.sum(), dt, tau, sigma, normals, refine, 2, k, True,
                                 new_memo(2))
                assert got == pytest.approx(expected, rel=1e-10, abs=1e-13)  # (summation order)


def test_tree_values_do_not_depend_on_the_queries_before_them():
    """A memo shared by a run's queries (``tree_value`` resumes its descent from the last one)
    gives bitwise the values of fresh descents, whatever the order of the queries: nearby
    instants as a contact's sub-steps ask, dyadic points (early returns), the ends, random
    instants, on two floors' memos, each switching between two steps' trees."""
    rng = np.random.default_rng(11)
    length = 1e-3
    times = np.concatenate([0.3e-3 + 1e-9 * np.arange(40),
                            length * np.array([0.5, 0.25, 0.75, 0.0, 1.0, 0.625]),
                            rng.uniform(0.0, length, 60)])
    queries = [(tau, floor, step) for tau in times for floor in (0, 1) for step in (3, 4)]
    for order in (np.arange(len(queries)), rng.permutation(len(queries)), rng.permutation(len(queries))):
        memo = new_memo(2)
        for i in order:
            tau, floor, step = queries[i]
            key = np.uint64(77 + 1000 * floor + step)
            total = 0.01 * (1 + floor + step)
            shared = tree_value(total, length, tau, 0.5, key, step, memo, floor * MEMO)
            assert shared == tree_value(total, length, tau, 0.5, key, step, new_memo(1), 0)


@pytest.mark.parametrize("off, length", [(0.0, 1e-3), (0.37e-3, 0.55e-3), (0.61e-3, 1.3e-5), (0.2e-3, 5e-8)])
def test_a_root_search_s_trials_on_the_tree_are_its_nodes(off, length):
    """``kdk.crossing``'s first trials (``tree_point``), whichever side of each the root lies:
    each is a node of the step's tree strictly inside the bracket, each a level below the last,
    and a query there ends at that node, drawing the normals of the levels between (one where
    no level is skipped: the memo holds the last trial's descent); in the bracket left, no node
    lies inside (it lies in one leaf, where the path is linear)."""
    dt, key = 1e-3, np.uint64(2024)
    levels = MEMO - 2  # (the memo's count of the levels it keeps)
    rng = np.random.default_rng(5)
    for _ in range(20):
        memo = new_memo(1)
        values = []
        lo, hi = 0.0, length
        tree_lo, tree_hi, depth = 0.0, dt, 0
        while True:
            tree_lo, tree_hi, depth, mid = tree_point(tree_lo, tree_hi, depth, off, lo, hi)
            if depth >= TREE_DEPTH:
                break
            assert lo < mid - off < hi
            node = mid / dt * 2.0 ** (depth + 1)  # an odd multiple of dt / 2^(depth + 1), as rounded
            assert node == pytest.approx(round(node), abs=1e-9) and round(node) % 2 == 1
            kept = memo[levels]
            values.append(tree_value(0.02, dt, mid, 0.5, key, 7, memo, 0))
            assert memo[levels] == depth + 1  # the descent ended at the node
            assert kept == 0.0 or memo[levels] > kept  # below the last trial's
            if rng.random() < 0.5:  # the root left of the trial: the tree's interval halved
                hi, tree_hi = mid - off, mid
            else:
                lo, tree_lo = mid - off, mid
            depth += 1
        leaf = dt / 2.0 ** TREE_DEPTH
        assert math.floor((off + lo) / leaf * (1 + 1e-12)) >= math.ceil((off + hi) / leaf * (1 - 1e-12)) - 1
        assert len(values) <= TREE_DEPTH


# -- statistics of contact under noise ------------------------------------------------------


PRESSED = dict(_hertz("single-sided", 0.0, 5.0, SOFT, stiffness=1.0), rest=-1.0)


@pytest.mark.parametrize("absorber, paths, duration",
                         [(_hertz("single-sided", 0.2, 5.0, SOFT, stiffness=0.05), 100, 1100.0),
                          (_hertz("double-sided", 0.2, 0.2, SOFT), 100, 1100.0),
                          (PRESSED, 30, 600.0)],
                         ids=["single-sided", "double-sided", "pressed into its barrier"])
@pytest.mark.parametrize("lanes", [False, True], ids=["scalar loop", "lanes"])
def test_elastic_hertz_absorber_keeps_gibbs_equipartition(absorber, paths, duration, lanes):
    """An elastic Hertz absorber (no absorber damping) on a primary with damping ``c1`` under white
    noise ``sigma`` on the primary: the Gibbs law makes ``<x1^2> = theta / k1`` and
    ``<v1^2> = theta / m1``, ``theta = sigma^2 / (2 c1)``, whatever the contact law.  Time
    averages over ``[100, duration]``, each within 4 standard errors (from the spread of the
    paths' averages: the paths are independent).  The absorber spends about 2 % (single-sided)
    and 6 % (double-sided) of the time in contact, 150-600 contacts a path; pressed into its
    barrier by its spring (rest 1 m beyond it) about 80 %, so the noise must act inside the
    contact sub-steps for the law to hold.  Both in the scalar loop (numpy's generators, a path
    at a time) and in SIMD lanes (``simulate_chunk``: Philox streams, each contact step finished by
    the scalar step)."""
    c1, sigma, t0 = 0.1, 0.05, 100.0
    theta = sigma**2 / (2.0 * c1)
    scene = scene_from({
        "name": "gibbs",
        "primary": {"mass": 1.0, "stiffness": 1.0, "damping": c1},
        "absorbers": [absorber],
        "loads": [{"type": "white-noise", "intensity": sigma}],
        "simulation": {"duration": duration, "dt": 0.01, "metrics_from": t0},
    })
    window = duration - t0
    if lanes:
        assert lane_scene(scene)
        rows = lane_metrics(scene, 20261127, paths)
    else:
        rows = [raw_metrics(scene, np.random.default_rng(path)) for path in range(paths)]
    x2, v2, contacts = [], [], []
    for m in rows:
        x2.append(m["x1_square_integral"] / window)
        v2.append(2.0 * (m["energy_integral"] / window - 0.5 * x2[-1]))  # E1 = (v1^2 + x1^2) / 2
        contacts.append(m["impacts"])
    assert min(contacts) > 50
    for values in (np.array(x2), np.array(v2)):
        se = values.std(ddof=1) / math.sqrt(values.size)
        assert abs(values.mean() - theta) < 4.0 * se, (values.mean() / theta - 1.0, se / theta)


def test_the_example_s_steel_contacts_last_about_a_millisecond():
    """``scenarios/contact_noise_parallel.toml``'s steel-on-steel Hertz absorber alone (20 kg,
    K = 1.6e10 N/m^1.5) under its loads: its contacts last 0.4-1.6 ms on average over 8 paths of
    10 s (0.8 ms, as its description says, not tens of microseconds), where a Hertz impact's
    duration ``3.21 (m / K)^0.4 w^-0.2`` (Johnson, *Contact Mechanics*, section 11.4; ``m``
    about the absorber's mass, the primary being 50 times heavier) is 0.7-1.4 ms for approach
    speeds ``w`` of 3-0.1 m/s (measured: 0.81 ms over 476 contacts)."""
    data = example_data("contact_noise_parallel")
    scene = scene_from({**data, "absorbers": data["absorbers"][:1]}, changes={"simulation.duration": 10.0})
    runs = [raw_metrics(scene, np.random.default_rng(k)) for k in range(8)]
    contacts = sum(r["impacts"] for r in runs)
    mean = sum(r["contact_time"] for r in runs) / contacts
    assert contacts >= 40 and 0.4e-3 < mean < 1.6e-3, (contacts, mean)


def test_noise_to_zero_reproduces_the_deterministic_contact_solution():
    """The SSVI design SS-1(20) of seed 003 under its harmonic force: kick-drift-kick with white
    noise 1e-6 N s^0.5 gives the steady ``e1_max`` of the deterministic RK4 solver within 1e-3
    relative, and its error halves with ``dt`` (the scheme's first-order damping term: the
    closing kick takes the dashpots at the half-step velocity), contact counts and contact
    time agreeing."""
    data = example_data("seed003_ss20", "sweep")
    reference = raw_metrics(scene_from(data))
    errors = []
    for dt in (1e-3, 5e-4):
        noise = {"type": "white-noise", "intensity": 1e-6}
        scene = scene_from(data, changes={"simulation.dt": dt, "loads": [*data["loads"], noise]})
        assert scene.scheme == "euler-maruyama"
        m = raw_metrics(scene, np.random.default_rng(1))
        errors.append(m["e1_max"] / reference["e1_max"] - 1.0)
        assert m["impacts"] == reference["impacts"]
        assert m["contact_time"] == pytest.approx(reference["contact_time"], rel=1e-3)
    assert abs(errors[0]) < 1e-3
    assert 1.6 < errors[0] / errors[1] < 2.4


# -- strong convergence on the same Brownian path -------------------------------------------


def test_strong_order_of_hertz_contact_under_noise_is_one():
    """A double-sided Hertz absorber (K = 7e5 N/m^1.5) hitting both walls under white noise
    (``precision.SAME_PATH``):
    strong order 1 on the same path (the contact force is continuous, so the scheme keeps the
    order of kick-drift-kick for additive noise).  Measured 0.97 here (dt = 2^-6 .. 2^-11
    against 2^-14, 20 paths) and 0.90 over 2^-6 .. 2^-15 against 2^-16 (30 paths); asserted
    above 0.75, with the errors decreasing at every level."""
    levels = [6, 7, 8, 9, 10, 11]
    errors, _ = same_path_errors("hertz", levels, fine=14, paths=20)
    assert np.all(np.diff(errors) < 0)
    assert strong_order(levels, errors) > 0.75


def test_strong_order_of_impacts_under_noise_is_one_half():
    """An impact absorber (r = 0.9) under white noise: strong order 1/2 on the same path.  The
    scheme's position error O(dt) moves each impact by O(dt), and the relative velocity the
    Newton map reverses carries the Brownian velocity of the primary, Hoelder 1/2 in time:
    O(sigma dt^1/2) per impact.  (Not the bridge: the earlier independent bridge draws and the
    tree measure the same.)  Measured 0.62 here (dt = 2^-6 .. 2^-11 against 2^-14, 30 paths) and
    0.51 over 2^-6 .. 2^-15 against 2^-16; asserted in [0.3, 0.8]: apart from 1 (the order
    without impacts) and from 0."""
    levels = [6, 7, 8, 9, 10, 11]
    errors, _ = same_path_errors("impact", levels, fine=14, paths=30)
    assert errors[-1] < errors[0] / 4
    assert 0.3 < strong_order(levels, errors) < 0.8


# -- no combination of absorber law and load type is refused --------------------------------

ABSORBERS = {
    "linear": {"type": "linear", "mass": 0.05, "stiffness": 0.05, "damping": 0.01},
    "cubic": {"type": "cubic", "mass": 0.05, "stiffness": 1.0, "damping": 0.01},
    "impact": {"type": "impact", "mass": 0.05, "clearance": 0.2, "restitution": 0.6},
    "hertz single-sided": _hertz("single-sided", 0.1, 0.2, SOFT, mass=0.05, stiffness=0.05),
    "hertz double-sided": _hertz("double-sided", 0.1, 0.2, SOFT, mass=0.05),
}
LOADS = {
    "impulse": {"type": "impulse", "velocity": 1.0},
    "harmonic": {"type": "harmonic", "amplitude": 0.1, "frequency": 1.0},
    "white-noise": {"type": "white-noise", "intensity": 0.05},
    "filtered-noise": {"type": "filtered-noise", "intensity": 0.05, "frequency": 2.0, "damping": 0.3},
    "ground-motion": {"type": "ground-motion", "soil": "medium", "intensity": 0.1},
    "half-sine": {"type": "half-sine", "amplitude": 1.0, "duration": 0.5},
    "pulse-train": {"type": "pulse-train", "amplitude": 1.0, "width": 0.1, "period": 1.0},
    "chirp": {"type": "chirp", "amplitude": 0.1, "f0": 0.1, "f1": 0.3, "duration": 10.0},
    "wind": {"type": "wind", "speed": 20.0, "height": 3.0, "area": 1e-3, "drag": 1.3},
}


@pytest.mark.parametrize("absorber", list(ABSORBERS))
def test_every_absorber_law_runs_under_every_load_type(absorber):
    """Every absorber law under every load type (records aside: they need files, and take the
    checks of the closed-form loads), alone and with white noise added, is accepted with
    ``scheme = "auto"`` (the scheme that runs it accepts its contents), and by kick-drift-kick,
    which takes every scene.  (What remains refusable: RK4 with noise, being deterministic, and
    SRA3 with events or filters; ``schemes.refusal`` names why.)"""
    from vines_stoch import schemes

    for name, load in LOADS.items():
        for extra in ([], [LOADS["white-noise"]]):
            study = study_from({
                "name": "combination", "primary": {"mass": 1.0, "stiffness": 1.0, "damping": 0.02},
                "absorbers": [ABSORBERS[absorber]], "loads": [load, *extra],
                "simulation": {"duration": 10.0, "dt": 1e-3}})
            point = study.points[0]
            assert schemes.refusal(schemes.SCHEMES[point.scheme], *point.contents) is None, (name, extra)
            assert schemes.refusal(schemes.SCHEMES["euler-maruyama"], *point.contents) is None, (name, extra)


@pytest.mark.parametrize("loads", [[LOADS["filtered-noise"]], [LOADS["half-sine"], LOADS["white-noise"]]],
                         ids=["filtered noise", "half-sine + white noise"])
def test_hertz_absorbers_run_under_filtered_and_piecewise_noisy_loads(loads):
    """The two Hertz combinations no example scenario runs: a double-sided Hertz absorber beside a
    single-sided one under filtered noise, and under a half-sine shock plus white noise (sub-steps
    at the shock's ends and at contacts in one step): every path in contact, its energy balance
    closed within 1e-3 of the input, the example scenarios' criterion (measured: up to 3e-5 and
    1.1e-4, the scheme's potential-energy error at two contact sub-steps a step)."""
    scene = scene_from({
        "name": "hertz-loads", "primary": {"mass": 1.0, "stiffness": 1.0, "damping": 0.02},
        "absorbers": [ABSORBERS["hertz double-sided"], ABSORBERS["hertz single-sided"]],
        "loads": [{"type": "impulse", "velocity": 0.5}, *loads],
        "simulation": {"duration": 50.0, "dt": 1e-3}})
    for path in range(3):
        m = raw_metrics(scene, np.random.default_rng(path))
        assert m["status"] == 0 and m["impacts"] > 0 and m["contact_time"] > 0
        residual = (m["input_energy"] - m["final_energy"] - m["primary_dissipation"]
                    - m["absorber_dissipation"] - m["impact_loss"])
        assert abs(residual) < 1e-3 * m["input_energy"]
