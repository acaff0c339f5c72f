"""vines_stoch: stochastic Monte Carlo response analysis of vibration absorbers.

Public API::

    study = load_scenario("scenarios/parallel_nes_impulse.toml")
    realizations, summary = run(study, "results/x")
    realizations, summary = read_results("results/x")
"""

__version__ = "0.1.0"

from .ensemble import run  # noqa: E402
from .scenario import ScenarioError, load_scenario, parse_scenario  # noqa: E402
from .store import read_results  # noqa: E402

__all__ = ["ScenarioError", "__version__", "load_scenario", "parse_scenario", "read_results", "run"]
