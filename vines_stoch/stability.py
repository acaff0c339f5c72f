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

from . import parse_scenario, run
from .bench import SSVI
from .scenario import ScenarioError

PRIMARY = "[primary]\nmass = 1.0\nstiffness = 1.0\ndamping = {c1}\n"
CUBIC = '[[absorbers]]\ntype = "cubic"\nmass = 0.05\nstiffness = 1.0\ndamping = 0.01\n'
IMPACT = '[[absorbers]]\ntype = "impact"\nmass = 0.05\nclearance = {clearance}\nrestitution = {r}\n'
IMPULSE = '[[loads]]\ntype = "impulse"\nvelocity = {x}\n'
NOISE = '[[loads]]\ntype = "harmonic"\namplitude = 0.1\nfrequency = 1.0\n[[loads]]\ntype = "white-noise"\nintensity = 0.05\n'
SIMULATION = "[simulation]\nduration = {T}\ndt = {dt}\n"

#: The SSVI design SS-1(60) of seed 003 with a steel absorber and steel obstacles (R = 5 cm).
STEEL_HERTZ = (SSVI.replace('name = "bench-ssvi"', 'name = "steel"')
               .replace("young = [2.1e11, 2.21e7]", "young = [2.1e11, 2.1e11]")
               .replace("young = [2.1e11, 2.05e7]", "young = [2.1e11, 2.1e11]")
               .replace("radius = 1.0", "radius = 0.05"))

STIFF = '[[absorbers]]\ntype = "linear"\nmass = 0.05\nstiffness = 1e6\ndamping = 0.1\n'

#: The last realisation's absorber is far stiffer than the others: past the stability limit.
ONE_UNSTABLE = '[[absorbers]]\ntype = "linear"\nmass = 0.05\nstiffness = 1.0\n'


@dataclass(frozen=True)
class Case:
    """A scene of the suite, the time it must end within, and what it must give."""

    name: str
    text: str
    bound_s: float
    expect: str = "result"        # "result": a run with a small energy residual; "error": refused
    tolerance: float = 1e-6       # largest |energy residual| of every realisation accepted
    realizations: int = 1
    order: int = 0                # > 0: the residual is the scheme's O(dt^order) error (checked at dt/2)

    def halved(self) -> "Case":
        """The case at half the step (the same Brownian paths are not implied: new grid)."""
        dt = self.text.split("dt = ", 1)[1].split("\n", 1)[0]
        return replace(self, text=self.text.replace(f"dt = {dt}", f"dt = {float(dt) / 2!r}"))


def _scene(name: str, *parts: str) -> str:
    return f'name = "{name}"\n' + "".join(parts)


CASES = (
    Case("restitution 0 (plastic impacts, sticking), impulse",
         _scene("r0", PRIMARY.format(c1=0.0), CUBIC, IMPACT.format(clearance=0.2, r=0.0), IMPULSE.format(x=1.0),
                SIMULATION.format(T=100.0, dt=1e-3)), 120.0),
    Case("restitution 1e-3, impulse",
         _scene("r1e-3", PRIMARY.format(c1=0.0), CUBIC, IMPACT.format(clearance=0.2, r=1e-3), IMPULSE.format(x=1.0),
                SIMULATION.format(T=100.0, dt=1e-3)), 120.0),
    Case("restitution 0 under harmonic + white noise (4 paths)",
         _scene("r0-noise", PRIMARY.format(c1=0.0), CUBIC, IMPACT.format(clearance=0.2, r=0.0), NOISE,
                SIMULATION.format(T=100.0, dt=1e-3), "[ensemble]\nrealizations = 4\n"), 120.0, tolerance=1e-5,
         realizations=4, order=1),
    Case("clearance 1e-9, impulse",
         _scene("tiny-gap", PRIMARY.format(c1=0.0), CUBIC, IMPACT.format(clearance=1e-9, r=0.6), IMPULSE.format(x=1.0),
                SIMULATION.format(T=100.0, dt=1e-3)), 120.0),
    Case("clearance 1e-9 under harmonic + white noise (4 paths)",
         _scene("tiny-gap-noise", PRIMARY.format(c1=0.0), CUBIC, IMPACT.format(clearance=1e-9, r=0.6), NOISE,
                SIMULATION.format(T=100.0, dt=1e-3), "[ensemble]\nrealizations = 4\n"), 120.0, tolerance=1e-5,
         realizations=4, order=1),
    Case("steel-on-steel Hertz contact (E = 210 GPa both, R = 5 cm)",
         STEEL_HERTZ, 120.0),
    Case("steel-on-steel Hertz contact under harmonic + white noise (4 paths)",
         STEEL_HERTZ.replace("[simulation]", '[[loads]]\ntype = "white-noise"\nintensity = 200.0\n[simulation]')
         + "[ensemble]\nrealizations = 4\n", 120.0, tolerance=1e-5, realizations=4),
    Case("impulse 1e3 times the design level (X = 1000, cubic NES)",
         _scene("x1000", PRIMARY.format(c1=0.0), CUBIC, IMPULSE.format(x=1000.0), SIMULATION.format(T=100.0, dt=1e-3)),
         120.0, tolerance=1e-4, order=4),
    Case("absorber 1e6 times stiffer than the primary, impulse",
         _scene("stiff", PRIMARY.format(c1=0.0), STIFF, IMPULSE.format(x=1.0), SIMULATION.format(T=20.0, dt=2e-5)),
         120.0, tolerance=1e-4, order=4),
    Case("absorber 1e6 times stiffer than the primary, white noise (4 paths)",
         _scene("stiff-noise", PRIMARY.format(c1=0.0), STIFF, NOISE, SIMULATION.format(T=20.0, dt=1e-4),
                "[ensemble]\nrealizations = 4\n"), 120.0, tolerance=5e-4, realizations=4, order=1),
    Case("10^7 steps (smooth scene under noise, T = 10^4, dt = 1e-3)",
         _scene("long", PRIMARY.format(c1=0.0), CUBIC, NOISE, SIMULATION.format(T=1e4, dt=1e-3)), 120.0,
         tolerance=1e-5),
    Case("dt past the linear stability limit (stiff absorber, dt = 1e-3)",
         _scene("too-coarse", PRIMARY.format(c1=0.0), STIFF, IMPULSE.format(x=1.0), SIMULATION.format(T=20.0, dt=1e-3)),
         10.0, expect="error"),
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
            study = parse_scenario(case.text, case.name)
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
             "Every case of `tests/test_stability.py`, one thread, wall time with the kernels compiled (the tests' bounds allow for compiling on a cold cache);",
             "cases whose residual is the scheme's own error state it at dt and dt/2 as well.",
             "", "| case | bound (s) | time (s) | outcome | max abs energy residual | EDM | most impacts |",
             "| --- | ---: | ---: | --- | ---: | --- | ---: |"]
    for case in CASES:
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
