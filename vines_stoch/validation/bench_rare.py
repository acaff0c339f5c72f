"""``make bench``'s "Rare events" section: what a rare-event estimate costs at p = 1e-4, 1e-6 and
1e-8 against crude Monte Carlo's need for the same coefficient of variation, with its error
against the exact reference (``first_passage.isee``)."""

from __future__ import annotations

import math
import time

from .. import rare
from ..ensemble import run
from . import first_passage, scenes

#: The linear oscillator of the rare-event tests (omega = 2 pi, zeta = 0.05, white noise of a
#: stationary standard deviation of 1, from rest, 10 s, dt = 0.01), its limit on the peak of |x|.
OSCILLATOR = {"name": "rare-bench", "primary": {"mass": 1.0, "stiffness": (2 * math.pi) ** 2,
                                                "damping": 0.1 * 2 * math.pi},
              "loads": [{"type": "white-noise", "intensity": math.sqrt(0.2 * (2 * math.pi) ** 3)}],
              "simulation": {"duration": 10.0, "dt": 0.01, "scheme": "euler-maruyama"},
              "ensemble": {"realizations": 20_000, "seed": 7},
              "limits": {"roof": {"metric": "x1_max", "value": 1.0}}}
#: Thresholds (standard deviations) of p about 1e-4, 1e-6 and 1e-8.
THRESHOLDS = {"1e-4": 4.76, "1e-6": 5.65, "1e-8": 6.41}
#: Each method's replica size and the target and budget of every estimate.
METHODS = {"splitting": 200, "subset": 1000}
TARGET, BUDGET = 0.15, 100_000
HEADER = ("| p about | method | exact p | estimate | z | cov | replicas | path-equivalents | s | "
          "crude paths for that cov | crude / method | path-equivalents for cov 0.15 (scaled) |\n"
          "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")


def _crude_rate() -> float:
    """Paths per second of a crude ``run`` of the oscillator (in memory, every core; the best of
    two after a warm-up)."""
    data = scenes.changed(OSCILLATOR, {"limits.roof.value": 4.0})
    run(data, realizations=100)
    best = math.inf
    for _ in range(2):
        start = time.perf_counter()
        run(data)
        best = min(best, time.perf_counter() - start)
    return OSCILLATOR["ensemble"]["realizations"] / best


def rows() -> tuple[list[tuple], float]:
    """One row a threshold and method: (p about, method, reference, its se, estimate, cov,
    replicas, path-equivalents, seconds, crude paths for that cov, crude seconds), and the
    crude rate."""
    rate = _crude_rate()
    out = []
    for label, b in THRESHOLDS.items():
        scene = scenes.scene(OSCILLATOR, {"limits.roof.value": b})
        reference, se = first_passage.isee(first_passage.response_matrix(scene), b)
        for method, n in METHODS.items():
            start = time.perf_counter()
            e = rare.estimate(lambda j, scene=scene: scene, 0, method, 5, 0, particles=n, target_cov=TARGET,
                              max_paths=BUDGET)
            seconds = time.perf_counter() - start
            crude = (1 - e.p) / (e.p * e.cov ** 2)
            out.append((label, method, reference, se, e.p, e.cov, len(e.replicas), e.paths, seconds, crude,
                        crude / rate))
    return out, rate


def section() -> str:
    """The section's Markdown."""
    table, rate = rows()
    lines = "\n".join(
        f"| {p} | {method} | {ref:.3e} (+- {se / ref:.1%}) | {est:.3e} | {(est - ref) / (est * cov):+.1f} | "
        f"{cov:.3f} | {reps} | {paths:,.0f} | {sec:.1f} | {crude:.2e} | {crude / paths:,.0f} | "
        f"{paths * (cov / 0.15) ** 2:,.0f} |"
        for p, method, ref, se, est, cov, reps, paths, sec, crude, _ in table)
    at = next(row for row in table if row[0] == "1e-6" and row[1] == "splitting")
    spread = at[5] * math.sqrt(at[6])  # (a replica's relative standard deviation: cov sqrt(R))
    return f"""## Rare events

`rare.estimate` on the linear oscillator of the rare-event tests (omega = 2 pi, zeta = 0.05,
white noise of a stationary standard deviation of 1, from rest, T = 10 s, dt = 0.01, 1,000 steps a
path), target coefficient of variation {TARGET}, budget {BUDGET:,} path-equivalents; splitting with
{METHODS['splitting']} paths a replica (10 % killed a level), subset simulation with
{METHODS['subset']} samples a level. The reference is exact for this linear process
(`validation/first_passage.py`, importance sampling using elementary events). "z" is the
estimate's error over its own standard error. Crude Monte Carlo's need: the paths
`(1 - p) / (p cov^2)` whose estimate has the coefficient of variation reached, at the crude
`run`'s measured rate on this host ({rate:,.0f} paths/s, every core).

{HEADER}
{lines}

Splitting's score is the running peak of the primary's energy (here the envelope `(k x^2 + m v^2) /
2`, `rare.energy_bound`): at 1e-6 a replica of {METHODS['splitting']} paths has a relative standard
deviation of {spread:.2f} in this run (cov times the square root of the replicas), against
{math.sqrt(math.log(1e6) / METHODS['splitting']):.2f} for the ideal score (`sqrt(ln(1 / p) / n)`,
which would also see how much of the path is left). Subset simulation's inputs
are the standard normals of the noise (white-noise increments and filters' normals) and the
uncertain parameters; splitting runs every scene.
"""


if __name__ == "__main__":
    print(section())
