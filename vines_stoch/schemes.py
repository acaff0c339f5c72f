"""The scheme registry: what each time-stepping scheme is, what it accepts and how stable it is.

One table read by the scenario checks (what a scheme refuses), the automatic choice, the
stability check of ``dt`` and the kernel dispatch (``kernels.kernel_for``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class Scheme:
    """A time-stepping scheme of the kernels.

    ``order``: deterministic order; ``strong_order``, ``weak_order``: with additive noise
    (None: not for noise); ``stability``: the largest ``omega dt`` at which it is stable on an
    undamped linear oscillator; ``noise``, ``impacts``, ``hertz``, ``filters``: what a scene
    may contain; ``normals``: standard normals a step draws per noisy floor; ``step``: its
    step, ``<step>_step`` of ``kernels/<step>.py``, which the one loop driver runs
    (``kernels/driver.py``); ``lanes``: its step also runs paths in SIMD lanes
    (``kernels/lanes.py``, for the scenes ``in_lanes`` admits); ``source``: where it comes from.
    """

    name: str
    order: int
    strong_order: float | None
    weak_order: float | None
    stability: float
    noise: bool
    impacts: bool
    hertz: bool
    filters: bool
    normals: int
    step: str
    source: str
    lanes: bool = False


SCHEMES: dict[str, Scheme] = {
    s.name: s for s in (
        Scheme("euler-maruyama", order=2, strong_order=1.0, weak_order=1.0, stability=2.0,
               noise=True, impacts=True, hertz=True, filters=True, normals=1, step="kdk", lanes=True,
               source="Euler-Maruyama for additive noise (Kloeden and Platen, Numerical Solution of "
                      "Stochastic Differential Equations, Springer 1992, section 10.2) in kick-drift-kick "
                      "form (velocity Verlet: Swope, Andersen, Berens and Wilson, J. Chem. Phys. 76 (1982) "
                      "637, doi:10.1063/1.442716); impacts and contact onsets located on the Brownian path, "
                      "Hertz contact sub-stepped, both on a virtual Brownian tree (kernels/kdk.py, "
                      "kernels/brownian.py)"),
        Scheme("sra", order=3, strong_order=1.5, weak_order=2.0, stability=math.sqrt(3.0), noise=True,
               impacts=False, hertz=False, filters=False, normals=2, step="sra3",
               source="SRA3, Roessler (2010), SIAM J. Numer. Anal. 48(3) 922-952, doi:10.1137/09076636X"),
        Scheme("rk4", order=4, strong_order=None, weak_order=None, stability=2.0 * math.sqrt(2.0),
               noise=False, impacts=True, hertz=True, filters=False, normals=0, step="rk4",
               source="classical Runge-Kutta (Kutta 1901; Hairer, Norsett and Wanner, Solving Ordinary "
                      "Differential Equations I, 2nd ed., Springer 1993, section II.1) with located impacts "
                      "and sub-stepped Hertz contact (kernels/rk4.py)"),
    )
}

#: The automatic choice, in order of preference: the first scheme that accepts the scene.
AUTO = ("rk4", "euler-maruyama")


def refusal(scheme: Scheme, noise: bool, filters: bool, impacts: bool, hertz: bool) -> str | None:
    """Why ``scheme`` cannot run a scene with these contents (None: it can)."""
    if noise and not scheme.noise:
        return "is deterministic; a scene with noise loads needs 'euler-maruyama' or 'auto'"
    if filters and not scheme.filters:
        return "takes white noise only (no filtered loads); use 'auto' or 'euler-maruyama'"
    if impacts and not scheme.impacts:
        return "has no impact or contact events; use 'auto', 'euler-maruyama' or 'rk4'"
    if hertz and not scheme.hertz:
        return "has no Hertz contact; use 'auto', 'euler-maruyama' or 'rk4'"
    return None


def in_lanes(scheme: str) -> bool:
    """Whether a scene of ``scheme`` runs its ensembles in SIMD lanes (``kernels/lanes.py``):
    a scheme with a lane step (impact and Hertz absorbers included: the lanes whose step holds
    an event finish it in the scalar step; filtered loads included: each lane advances its own
    filters).  Such a scene's CPU ensembles draw from counter-based Philox streams (those of
    the cuda backend, ``streams/rng.py``), whatever the run records."""
    return SCHEMES[scheme].lanes


def choose(noise: bool, filters: bool, impacts: bool, hertz: bool) -> str:
    """The scheme ``"auto"`` runs: the first of ``AUTO`` that accepts the scene (RK4 without
    noise, kick-drift-kick Euler-Maruyama with it)."""
    for name in AUTO:
        if refusal(SCHEMES[name], noise, filters, impacts, hertz) is None:
            return name
    return AUTO[-1]
