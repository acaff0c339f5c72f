"""vines_stoch: stochastic Monte Carlo response analysis of vibration absorbers.

Public API (README, "Python API")::

    results = run("scenarios/parallel_nes_impulse.toml")           # in memory: nothing written
    results = run({"name": "x", ...}, out="results/x", realizations=200)
    realizations, summary = read_results("results/x")              # a Results unpacks as a pair
    solution = solve("scenarios/parallel_nes_impulse.toml")        # one realisation: ts, ys["e1"]
    table = estimate("scenarios/rare_oscillator.toml")             # no ensemble (MODEL.md section 6)

``run``, ``solve``, ``read_results``, ``Results`` and ``Solution`` are imported on first use
(PEP 562): reading and validating a scenario does not import numba, dask or pandas.
"""

from __future__ import annotations

from typing import Any


def _version() -> str:
    """The version of the installed distribution (pyproject.toml is its one source)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("vines-stoch")
    except PackageNotFoundError:  # a source tree that was never installed
        return "0+unknown"


__version__ = _version()

from .notices import (  # noqa: E402
    CoarseStepWarning,
    DivergedWarning,
    EnergyBalanceWarning,
    IdenticalRealizationsWarning,
    LongRunWarning,
    VinesStochWarning,
)
from .scenario import ScenarioError, load_scenario, parse_scenario  # noqa: E402

#: Public names imported on first use, and their modules.
_LAZY = {"run": "ensemble", "solve": "ensemble", "read_results": "results", "Results": "results",
         "Solution": "results", "estimate": "rvt"}

__all__ = ["CoarseStepWarning", "DivergedWarning", "EnergyBalanceWarning", "IdenticalRealizationsWarning",
           "LongRunWarning", "Results", "ScenarioError", "Solution", "VinesStochWarning", "__version__",
           "estimate", "load_scenario", "parse_scenario", "read_results", "run", "solve"]


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        from importlib import import_module

        from .environment import check

        check()  # (a mistake in the environment variables, named before numba reads them)

        return getattr(import_module(f".{_LAZY[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
