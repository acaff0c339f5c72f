"""The numerical stability suite: scenes where real designs push the solver (plastic and nearly
plastic impacts, vanishing clearance, steel Hertz contact, extreme impulses, stiff absorbers,
long runs, a step past the stability limit, a diverging realisation).  Each case ends within
its time bound with a result whose energy residual is stated, or with a clear error; the tests
assert it and ``make bench`` reports it."""

from __future__ import annotations

import tempfile
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from ..ensemble import run
from ..scenario import ScenarioError, Study
from . import scenes

#: The harmonic + white-noise loads of the smooth scene (0.1 cos t plus white noise 0.05).
NOISE = scenes.scene_data("smooth")["loads"]
#: Four realisations (the default seed).
FOUR_PATHS = {"ensemble.realizations": 4}


@dataclass(frozen=True)
class Case:
    """A scene of the suite (scenario data), the time it must end within, and what it must give."""

    name: str
    data: dict[str, Any]
    bound_s: float
    expect: str = "result"        # "result": a run with a small energy residual; "error": refused
    tolerance: float = 1e-6       # largest |energy residual| of every realisation accepted
    realizations: int = 1
    order: int = 0                # > 0: the residual is the scheme's O(dt^order) error (checked at dt/2)

    def study(self, source: str | None = None) -> Study:
        """The validated study of the case (ScenarioError where it is refused); ``source``
        names it in messages (default: the case's name)."""
        return scenes.study(self.data, source=source or self.name)

    def halved(self) -> Case:
        """The case at half the step (the same Brownian paths are not implied: new grid)."""
        return replace(self, data=scenes.changed(self.data,
                                                 {"simulation.dt": self.data["simulation"]["dt"] / 2}))


def _case(name: str, scene: str, changes: dict[str, Any], bound_s: float = 120.0, **expected: Any) -> Case:
    """The case ``name``: the scene file ``scene`` with ``changes`` (dotted keys)."""
    return Case(name, scenes.changed(scenes.scene_data(scene), changes), bound_s, **expected)


def _steel(noise: bool) -> dict[str, Any]:
    """The SSVI design SS-1(60) of seed 003 with a steel absorber and steel obstacles (R = 5 cm),
    under its harmonic force (and, with ``noise``, white noise 200 N and four realisations)."""
    data = scenes.changed(scenes.scene_data("ssvi"), {"name": "steel"})
    for side in ("contact_left", "contact_right"):
        data["absorbers"][0][side].update(young=[2.1e11, 2.1e11], radius=0.05)
    if noise:
        data["loads"].append({"type": "white-noise", "intensity": 200.0})
        data["ensemble"] = {"realizations": 4}
    return data


CASES = (
    _case("restitution 0 (plastic impacts, sticking), impulse", "impulse_parallel",
          {"name": "r0", "absorbers.1.restitution": 0.0}),
    _case("restitution 1e-3, impulse", "impulse_parallel",
          {"name": "r1e-3", "absorbers.1.restitution": 1e-3}),
    _case("restitution 0 under harmonic + white noise (4 paths)", "impulse_parallel",
          {"name": "r0-noise", "absorbers.1.restitution": 0.0, "loads": NOISE, **FOUR_PATHS},
          tolerance=1e-5, realizations=4, order=1),
    _case("clearance 1e-9, impulse", "impulse_parallel", {"name": "tiny-gap", "absorbers.1.clearance": 1e-9}),
    _case("clearance 1e-9 under harmonic + white noise (4 paths)", "impulse_parallel",
          {"name": "tiny-gap-noise", "absorbers.1.clearance": 1e-9, "loads": NOISE, **FOUR_PATHS,
           "simulation.duration": 25.0},  # 25 s: 3.6e5 impacts (100 s: 1.2e6 in 3.5 times the time)
          tolerance=1e-5, realizations=4, order=1),
    Case("steel-on-steel Hertz contact (E = 210 GPa both, R = 5 cm)", _steel(noise=False), 120.0),
    Case("steel-on-steel Hertz contact under harmonic + white noise (4 paths)", _steel(noise=True), 120.0,
         tolerance=1e-5, realizations=4),
    _case("impulse 1e3 times the design level (X = 1000, cubic NES)", "impulse",
          {"name": "x1000", "loads.0.velocity": 1000.0}, tolerance=1e-4, order=4),
    _case("absorber 1e6 times stiffer than the primary, impulse", "stiff", {"name": "stiff"},
          tolerance=1e-4, order=4),
    _case("absorber 1e6 times stiffer than the primary, white noise (4 paths)", "stiff",
          {"name": "stiff-noise", "loads": NOISE, "simulation.dt": 1e-4, **FOUR_PATHS},
          tolerance=5e-4, realizations=4, order=1),
    _case("10^7 steps (smooth scene under noise, T = 10^4, dt = 1e-3)", "impulse",
          {"name": "long", "loads": NOISE, "simulation.duration": 1e4}, tolerance=1e-5),
    _case("dt past the linear stability limit (stiff absorber, dt = 1e-3)", "stiff",
          {"name": "too-coarse", "simulation.dt": 1e-3}, 10.0, expect="error"),
)


@dataclass
class Outcome:
    """What one case gave: time, failed and finished realisations, the worst energy residual
    and EDM range, or the error message."""

    case: Case
    seconds: float
    n_ok: int = 0
    n_failed: int = 0
    residual: float = float("nan")
    edm: tuple[float, float] = (float("nan"), float("nan"))
    impacts: int = 0
    error: str = ""


def run_case(case: Case, directory: Path | None = None) -> Outcome:
    """Run one case on one thread (into a temporary folder unless ``directory`` is given)."""
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        try:
            study = case.study()
        except ScenarioError as exc:
            return Outcome(case, time.perf_counter() - start, error=str(exc))
        realizations, summary = run(study, directory or Path(tmp), workers=1)
    ok = realizations[realizations["status"] == "ok"]
    return Outcome(case, time.perf_counter() - start, n_ok=len(ok), n_failed=int(summary["n_failed"].sum()),
                   residual=float(ok["energy_residual"].abs().max()) if len(ok) else float("nan"),
                   edm=(float(ok["edm"].min()), float(ok["edm"].max())) if len(ok) else (float("nan"),) * 2,
                   impacts=int(ok["impacts"].max()) if len(ok) else 0)


def section() -> str:
    """The Markdown section of ``reports/benchmarks.md``."""
    lines = ["## Stability suite", "",
             "Every case of `tests/integration/test_stability.py`, one thread, wall time with the kernels "
                 "compiled (the tests' bounds allow for compiling on a cold cache);",
             "cases whose residual is the scheme's own error state it at dt and dt/2 as well.",
             "", "| case | bound (s) | time (s) | outcome | max abs energy residual | EDM | most impacts |",
             "| --- | ---: | ---: | --- | ---: | --- | ---: |"]
    for case in CASES:
        run_case(case)  # compiles or loads its step loops: the time below is the run's own
        o = run_case(case)
        if o.error:
            outcome = "refused: " + o.error.split(": ", 2)[-1].replace("|", "/")
            lines.append(f"| {case.name} | {case.bound_s:.0f} | {o.seconds:.2f} | {outcome} | - | - | - |")
        else:
            outcome = f"{o.n_ok} ok, {o.n_failed} failed"
            residual = f"{o.residual:.1e}"
            if case.order:
                residual += f" (dt/2: {run_case(case.halved()).residual:.1e})"
            lines.append(f"| {case.name} | {case.bound_s:.0f} | {o.seconds:.2f} | {outcome} | {residual} | "
                         f"{o.edm[0]:.4f}-{o.edm[1]:.4f} | {o.impacts} |")
    return "\n".join(lines) + "\n"
