"""Work-precision studies of ``make bench``: runtime against error for vines_stoch and its peers
in one process, with the figures for ``reports/benchmarks.md`` and the PNG diagrams.

- Deterministic impulse scene (LPO + cubic NES, ``X = 1``) and impact scene (parallel NES):
  EDM error against scipy DOP853 at rtol 1e-12 with impacts located as events
  (``reference.parallel_nes_reference``); peers: the same scipy reference at looser tolerances.
- Stochastic smooth scene (LPO + cubic NES under ``0.1 cos t`` plus white noise): strong error of
  the state at ``T`` against a fine-step solution on the same Brownian path; peers: sdeint's
  ``itoEuler`` and ``itoSRI2`` given the same Wiener increments.  Weak error of the stationary
  variance of a linear oscillator against its closed form.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..kernels import simulate
from ..metrics import finish, finish_table
from ..outputs import X1_SQ_INT
from ..plotting import REPORT_EXTRA, pyplot
from . import scenes
from .reference import parallel_nes_reference

#: White-noise intensity of the stochastic smooth scene (``scenes/noisy.toml``).
SIGMA = 0.05


@dataclass
class Curve:
    """One solver's work-precision points: (setting, seconds per path, error)."""

    name: str
    points: list[tuple[str, float, float]] = field(default_factory=list)


def _timed(fn, repeats: int = 1) -> tuple[float, object]:
    start = time.perf_counter()
    for _ in range(repeats):
        value = fn()
    return (time.perf_counter() - start) / repeats, value


def deterministic(impact: bool) -> list[Curve]:
    """EDM error of vines_stoch RK4 over dt and of DOP853 over rtol (both with events)."""
    clearance = 0.2 if impact else 1e30

    def reference(rtol: float, atol: float) -> float:
        return parallel_nes_reference(1.0, 1.0, 0.0, (0.05, 1.0, 0.01), (0.05, clearance, 0.6), 1.0, 100.0,
                                      rtol=rtol, atol=atol)[0]

    exact = reference(1e-12, 1e-14)
    ours = Curve("vines_stoch RK4" + (" + impact events" if impact else ""))
    for n in np.round(1562.5 * 2.0 ** (0.5 * np.arange(13))):  # dt = 0.064 to 0.001, steps of sqrt 2
        dt = 100.0 / n  # T = 100 in whole steps
        scene = scenes.scene("impulse_parallel" if impact else "impulse", {"simulation.dt": float(dt)})
        simulate(scene)
        seconds, raw = _timed(lambda scene=scene: simulate(scene),
                              repeats=max(1, int(0.2 / (scene.n_steps * 2e-7))))
        edm = finish(raw, scene)["edm"]
        ours.points.append((f"dt = {dt:.3g}", seconds, abs(edm - exact)))
    peer = Curve("scipy DOP853 + events")
    for rtol in (1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10):
        seconds, edm = _timed(lambda rtol=rtol: reference(rtol, rtol * 1e-3))
        peer.points.append((f"rtol = {rtol:.0e}", seconds, abs(edm - exact)))
    return [ours, peer]


def noisy_scene(dt: float, duration: float = 20.0, scheme: str = "euler-maruyama", sigma: float = SIGMA,
                amplitude: float = 0.1):
    """The Scene of the stochastic smooth scene (``scenes/noisy.toml``: 2-DOF cubic NES under
    ``amplitude cos t`` plus white noise ``sigma``) at step ``dt`` over ``duration`` with
    ``scheme``."""
    return scenes.scene("noisy", {"simulation.dt": dt, "simulation.duration": duration,
                                  "simulation.scheme": scheme, "loads.0.amplitude": amplitude,
                                  "loads.1.intensity": sigma})


def coarse_increments(normals: np.ndarray, m: int) -> tuple[np.ndarray, np.ndarray]:
    """Standard normals ``(u1, u2)`` of the steps of ``m`` fine steps of a Brownian path given
    by one standard normal a fine step: ``dW = sqrt(h) u1`` and the time integral of ``W - W_0``
    over the step, ``h^1.5 (u1 + u2 / sqrt 3) / 2`` (the SRA scheme's two draws), both exact
    for the path that is linear between the fine points."""
    n = normals[: (normals.shape[0] // m) * m].reshape(-1, m)
    before = np.cumsum(n, axis=1) - n                        # W - W_0 before each fine step, in sqrt(fine dt)
    u1 = n.sum(axis=1) / math.sqrt(m)
    integral = (before + 0.5 * n).sum(axis=1) / m ** 1.5     # time integral over h^1.5
    return u1, math.sqrt(3.0) * (2.0 * integral - u1)


def _replay(scene, normals: np.ndarray, m: int) -> np.ndarray:
    """The normals ``scene`` replays for the path of fine normals ``normals``, ``m`` fine steps
    a step (two a step for SRA3)."""
    u1, u2 = coarse_increments(normals, m)
    return np.stack([u1, u2], axis=1).ravel() if scene.scheme == "sra" else u1


def strong(paths: int = 8, fine_dt: float = 2.5e-5, duration: float = 20.0,
           sdeint_paths: int = 4) -> list[Curve]:
    """Strong error (mean over paths of the state error at ``T``) against the fine-step SRA3
    solution on the same Brownian path, for both our schemes and sdeint's."""
    import sdeint

    fine = noisy_scene(fine_dt, duration, "sra")
    levels = (8e-2, 4e-2, 2e-2, 1e-2, 5e-3, 2.5e-3, 1.25e-3)
    kdk, sra = Curve("vines_stoch kick-drift-kick"), Curve("vines_stoch SRA3")
    euler, sri2 = Curve("sdeint itoEuler"), Curve("sdeint itoSRI2")
    final = np.zeros((2, 2))
    rng = np.random.default_rng(2026)
    normals = [rng.standard_normal(fine.n_steps) for _ in range(paths)]

    reference = []
    for n in normals:
        simulate(fine, normals=_replay(fine, n, 1), final=final)
        reference.append(final.copy())

    def f(y, t):
        x1, x2, v1, v2 = y
        u, w = x2 - x1, v2 - v1
        force = -u ** 3 - 0.01 * w
        return np.array([v1, v2, 0.1 * math.cos(t) - x1 - force, force / 0.05])

    G = np.array([[0.0], [0.0], [SIGMA], [0.0]])

    def g(y, t):
        return G

    for dt in levels:
        m = round(dt / fine_dt)
        for curve, scheme in ((kdk, "euler-maruyama"), (sra, "sra")):
            if scheme == "sra" and dt < 5e-3:
                continue  # finer SRA3 steps only extend its curve below every peer's error
            scene = noisy_scene(dt, duration, scheme)
            replays = [_replay(scene, n, m) for n in normals]
            simulate(scene, normals=replays[0])
            finals = np.zeros((paths, 2, 2))

            def ours(scene=scene, replays=replays, finals=finals) -> None:
                for c, out in zip(replays, finals):
                    simulate(scene, normals=c, final=out)

            seconds = min(_timed(ours)[0] for _ in range(5))  # best of 5 batches, as for sdeint
            errors = [np.linalg.norm(out - ref) for out, ref in zip(finals, reference)]
            curve.points.append((f"dt = {dt:g}", seconds / paths, float(np.mean(errors))))
        if dt > 2e-2:
            continue
        n_steps = math.ceil(duration / dt - 1e-9)
        tspan = np.linspace(0.0, n_steps * dt, n_steps + 1)
        increments = [(coarse_increments(n, m)[0] * math.sqrt(dt)).reshape(-1, 1)
                      for n in normals[:sdeint_paths]]
        for curve, method in ((euler, sdeint.itoEuler), (sri2, sdeint.itoSRI2)):

            def theirs(method=method, tspan=tspan, increments=increments) -> list[np.ndarray]:
                return [method(f, g, np.zeros(4), tspan, dW=dw) for dw in increments]

            seconds, ys = min((_timed(theirs) for _ in range(5 if dt > 4e-3 else 2)),
                              key=lambda timed: timed[0])
            errors = [np.linalg.norm(np.array([y[-1, :2], y[-1, 2:]]) - ref) for y, ref in zip(ys, reference)]
            curve.points.append((f"dt = {dt:g}", seconds / sdeint_paths, float(np.mean(errors))))
    return [kdk, sra, euler, sri2]


def weak(paths: int = 1024, duration: float = 1100.0) -> list[tuple[str, float, float, float, float]]:
    """Stationary variance of x1 of the linear oscillator, time- and ensemble-averaged over
    ``[100, T]``, against ``sigma^2 / (2 c k) = 5``: rows ``(scheme, dt, estimate, its standard
    error, seconds per path)`` (the same seeds for every row)."""
    exact = 1.0 / (2 * 0.1 * 1.0)
    rows = []
    for scheme in ("euler-maruyama", "sra"):
        for dt in (0.4, 0.2, 0.1, 0.05):
            scene = scenes.scene("linear", {"simulation.duration": duration, "simulation.dt": dt,
                                            "simulation.scheme": scheme})
            simulate(scene, np.random.default_rng(0))
            start = time.perf_counter()
            values = np.array([simulate(scene, np.random.default_rng(r))[X1_SQ_INT] / (duration - 100.0)
                               for r in range(paths)])
            seconds = (time.perf_counter() - start) / paths
            rows.append((scheme, dt, float(values.mean()) - exact,
                         float(values.std(ddof=1) / math.sqrt(paths)), seconds))
    return rows


#: The smooth scene's loads for the weak study of the metrics: (label, harmonic amplitude,
#: noise intensity).
WEAK_LOADS = (("0.1 cos t + white noise 0.05", 0.1, 0.05), ("white noise 0.2", 0.0, 0.2))


def weak_metrics(paths: int = 200, duration: float = 100.0, fine_dt: float = 1e-3,
                 levels: tuple[float, ...] = (0.2, 0.1, 0.05, 0.025), loads=WEAK_LOADS) -> list[tuple]:
    """Bias of the ensemble means of the energy integral and the EDM (the statistics users
    read) on the smooth scene, against SRA3 at ``fine_dt`` on the same Brownian paths.  The
    coupling makes the standard errors those of the paired differences, small enough to show
    the bias itself.  Rows ``(loads, scheme, dt, energy-integral bias, its standard error,
    EDM bias, its standard error, seconds per path)``, biases relative to the fine means."""
    def metrics(sc, raws: list[np.ndarray]) -> np.ndarray:
        # row-major, as the means below sum in an order set by the memory layout
        return np.ascontiguousarray(finish_table(np.stack(raws), sc)[["energy_integral", "edm"]], dtype=float)

    rows = []
    rng = np.random.default_rng(2027)
    for label, amplitude, sigma in loads:
        fine = noisy_scene(fine_dt, duration, "sra", sigma, amplitude)
        normals = [rng.standard_normal(fine.n_steps) for _ in range(paths)]
        reference = metrics(fine, [simulate(fine, normals=_replay(fine, n, 1)) for n in normals])
        for scheme in ("euler-maruyama", "sra"):
            for dt in levels:
                coarse = noisy_scene(dt, duration, scheme, sigma, amplitude)
                replays = [_replay(coarse, n, round(dt / fine_dt)) for n in normals]
                simulate(coarse, normals=replays[0])
                start = time.perf_counter()
                raws = [simulate(coarse, normals=r) for r in replays]
                seconds = (time.perf_counter() - start) / paths
                values = metrics(coarse, raws)
                diff = (values - reference) / reference.mean(axis=0)
                bias, se = diff.mean(axis=0), diff.std(axis=0, ddof=1) / math.sqrt(paths)
                rows.append((label, scheme, dt, bias[0], se[0], bias[1], se[1], seconds))
    return rows


#: The absorbers of the same-path studies of contact and impacts under noise: a double-sided
#: Hertz absorber (K = 7e5 N/m^1.5, both obstacles 0.1 away) and an impact absorber (r = 0.9),
#: on the LPO m = k = 1, c = 0.02, both started towards a wall.
SAME_PATH = {
    "hertz": ({"type": "hertz", "geometry": "double-sided", "mass": 0.1, "offset": 0.0, "gap": 0.1,
               "contact_left": {"young": [1e5, 1e5], "poisson": [0.3, 0.3], "radius": 1.0},
               "contact_right": {"young": [1e5, 1e5], "poisson": [0.3, 0.3], "radius": 1.0}},
              {"type": "initial", "displacement": [0.0, 0.1], "velocity": [0.0, 1.0]}),
    "impact": ({"type": "impact", "mass": 0.1, "clearance": 0.1, "restitution": 0.9},
               {"type": "initial", "velocity": [0.0, 1.0]}),
}


def same_path_errors(kind: str, levels: list[int], fine: int = 14, paths: int = 20, duration: float = 0.5,
                     sigma: float = 0.1) -> tuple[np.ndarray, np.ndarray]:
    """Strong errors on one Brownian path of the ``SAME_PATH`` scene ``kind`` under white noise
    ``sigma``: the mean over ``paths`` of ``|x1(T) - x1_fine(T)|`` at ``dt = 2^-level`` against
    ``dt = 2^-fine``, and the seconds a path takes at each level.  Every run replays the same
    fine normals (``simulate(..., refine=...)``) with the same tree seed, so all integrate one
    path, inside the steps too (``kernels/brownian.py``)."""
    absorber, initial = SAME_PATH[kind]
    data = {"name": f"same-path-{kind}", "primary": {"mass": 1.0, "stiffness": 1.0, "damping": 0.02},
            "absorbers": [absorber], "loads": [initial, {"type": "white-noise", "intensity": sigma}],
            "simulation": {"duration": duration}}
    by_level = {level: scenes.scene(data, {"simulation.dt": 2.0**-level}) for level in [*levels, fine]}
    rng = np.random.default_rng(5)
    errors = np.zeros((paths, len(levels)))
    seconds = np.zeros(len(levels))
    final = np.zeros((2, 2))
    for m in range(paths):
        normals = rng.standard_normal(math.ceil(duration * 2**fine))

        def x1_end(level: int, m: int = m, normals: np.ndarray = normals) -> float:
            simulate(by_level[level], np.random.default_rng(m), normals=normals, refine=2 ** (fine - level),
                     final=final)
            return final[0, 0]

        reference = x1_end(fine)
        for i, level in enumerate(levels):
            start = time.perf_counter()
            errors[m, i] = abs(x1_end(level) - reference)
            seconds[i] += time.perf_counter() - start
    return errors.mean(axis=0), seconds / paths


def strong_order(levels: list[int], errors: np.ndarray) -> float:
    """Least-squares slope of ``log error`` against ``log dt`` (``dt = 2^-level``)."""
    return float(np.polyfit(np.log(2.0 ** -np.array(levels)), np.log(errors), 1)[0])


def ratio_at_equal_error(ours: Curve, peer: Curve) -> list[tuple[str, str, float]]:
    """For each peer point, the cheapest of ours with equal or smaller error: ``(peer setting,
    our setting, peer time / our time)``."""
    rows = []
    for setting, seconds, error in peer.points:
        good = [p for p in ours.points if p[2] <= error]
        if good:
            best = min(good, key=lambda p: p[1])
            rows.append((setting, best[0], seconds / best[1]))
    return rows


def plot(panels: dict[str, list[Curve]], path: Path, xlabel: str = "seconds per path") -> bool:
    """Work-precision diagrams, one panel per scene: error against runtime on log axes; False
    (and nothing written) where matplotlib is not installed."""
    plt = pyplot(str(path))
    if plt is None:
        return False
    fig, axes = plt.subplots(1, len(panels), figsize=(5.2 * len(panels), 4.2), squeeze=False)
    for ax, (title, curves) in zip(axes[0], panels.items()):
        for curve in curves:
            ax.loglog([p[1] for p in curve.points], [max(p[2], 1e-17) for p in curve.points], "o-",
                      label=curve.name)
        ax.set_title(title)
        ax.set_xlabel(xlabel)
        ax.set_ylabel("error")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return True


def _table(curves: list[Curve]) -> str:
    lines = ["| solver | setting | ms per path | error |", "| --- | --- | ---: | ---: |"]
    for curve in curves:
        lines += [f"| {curve.name} | {s} | {sec * 1e3:.2f} | {err:.1e} |" for s, sec, err in curve.points]
    return "\n".join(lines)


def _ratios(ours: Curve, peers: list[Curve]) -> str:
    lines = ["| peer | peer setting | our cheapest setting with equal or smaller error "
             "| peer time / our time |",
             "| --- | --- | --- | ---: |"]
    for peer in peers:
        rows = ratio_at_equal_error(ours, peer)
        lines += [f"| {peer.name} | {a} | {b} | {r:.0f}x |" for a, b, r in rows]
        missing = len(peer.points) - len(rows)
        if missing:
            lines.append(f"| {peer.name} | {missing} more setting(s) | none of ours as accurate | - |")
    return "\n".join(lines)


def section(folder: Path) -> str:
    """Run every study, write ``folder/work-precision.png`` (where matplotlib is installed) and
    return the Markdown section."""
    impulse, impact, noisy = deterministic(False), deterministic(True), strong()
    variance = weak()
    drawn = plot({"impulse, cubic NES (EDM error)": impulse, "impulse, parallel NES (EDM error)": impact,
                  "noise, cubic NES (strong error at T)": noisy}, folder / "work-precision.png")
    figure = ("![work-precision diagrams](work-precision.png)" if drawn else
              f"(The diagrams are not drawn: matplotlib is not installed; `{REPORT_EXTRA}` adds them.)")
    metric_rows = "\n".join(f"| {label} | {scheme} | {dt:g} | {100 * e:+.3f} % | {100 * es:.3f} % | "
                            f"{100 * d:+.2f} % | {100 * ds:.2f} % | {sec * 1e3:.3f} |"
                            for label, scheme, dt, e, es, d, ds, sec in weak_metrics())
    weak_rows = "\n".join(f"| {scheme} | {dt:g} | {bias:+.3f} | {se:.3f} | {100 * bias / 5.0:+.2f} % | "
                          f"{sec * 1e3:.1f} |"
                          for scheme, dt, bias, se, sec in variance)
    schemes = "\n".join(f"| {a} | {b} | {r:.1f}x |" for a, b, r in ratio_at_equal_error(noisy[1], noisy[0]))
    return f"""## Work-precision

{figure}

### Deterministic impulse scene

LPO m = k = 1 (undamped) with the cubic NES (eps = 0.05, k3 = 1, c = 0.01), impulse X = 1,
T = 100: error of the EDM against scipy DOP853 at rtol 1e-12 with events; the peer is the same
scipy solution at looser tolerances (absolute tolerance rtol / 1000).

{_table(impulse)}

{_ratios(impulse[0], impulse[1:])}

### Impact scene

The same plus the impact NES (eps = 0.05, clearance 0.2, r = 0.6): the parallel NES of seed
000, impacts located as events by both solvers. (The DOP853 errors are not monotonic in rtol:
a different impact sequence late in the run changes the EDM.)

{_table(impact)}

{_ratios(impact[0], impact[1:])}

### Stochastic smooth scene

LPO with the cubic NES under 0.1 cos t plus white noise 0.05, T = 20: mean over paths of the
norm of the state error at T against the vines_stoch SRA3 solution at dt = 2.5e-5 on the same
Brownian path (8 paths; sdeint 4 paths, given the same Wiener increments; the SRA3 steps get
the path's time integrals as well). Each solver runs its paths back to back, as an ensemble
does, and the time per path is the mean over the batch, best of 5 batches (2 for sdeint's
finest settings); vines_stoch's includes its per-call set-up
(about 20 us, a large part of its shortest runs). A single call timed alone, right after
other work has flushed the caches, takes several times longer.

{_table(noisy)}

Kick-drift-kick against the peers:

{_ratios(noisy[0], noisy[2:])}

SRA3 against the peers:

{_ratios(noisy[1], noisy[2:])}

SRA3 against kick-drift-kick (`scheme = "sra"` against the default for noisy scenes):

| kick-drift-kick setting | cheapest SRA3 setting with equal or smaller error | time ratio |
| --- | --- | ---: |
{schemes}

### Weak error of the stationary variance

Linear oscillator m = k = 1, c = 0.1 under white noise 1: variance of x1, averaged over
[100, 1100] and 1024 paths (the same seeds in every row, so rows share their sampling error),
against sigma^2 / (2 c k) = 5.

| scheme | dt | error | standard error | relative | ms per path |
| --- | ---: | ---: | ---: | ---: | ---: |
{weak_rows}

### Weak error of the metrics, and the choice of `"auto"`

The smooth scene (T = 100) under two loads: bias of the ensemble means of the energy integral
and the EDM against SRA3 at dt = 1e-3 on the same 200 Brownian paths (paired differences, so
the standard errors are those of the differences), relative to the fine means; time per path
of the kernel alone.

| loads | scheme | dt | energy-integral bias | standard error | EDM bias | standard error | ms per path |
| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: |
{metric_rows}

SRA3 wins the strong (pathwise) comparison above; on these ensemble statistics, which are what
a run reports, kick-drift-kick is as accurate or more at the same dt and cheaper per step, so
`scheme = "auto"` keeps kick-drift-kick for noisy scenes and `"sra"` is the choice for
pathwise accuracy (histories compared with a given Brownian path, replayed paths).
"""
