"""The package's warnings, one category each, so that a Python user can filter them as usual
(``warnings.simplefilter("error", vines_stoch.CoarseStepWarning)``); the command line prints the
same lines as ``warning: ...``; what the package compiles goes to the ``vines_stoch`` logger
(``LOG``) at INFO.  A ``Notice`` is a warning's line (a ``str``) that knows its
category."""

from __future__ import annotations

import logging

#: The package's logger: what it compiles or loads (``ensemble.prepare_loops``), at INFO.
LOG = logging.getLogger("vines_stoch")


class VinesStochWarning(UserWarning):
    """Every warning of vines_stoch."""


class CoarseStepWarning(VinesStochWarning):
    """``simulation.dt`` is stable but coarse for what the scene holds (``scenario/accuracy.py``)."""


class IdenticalRealizationsWarning(VinesStochWarning):
    """Several realisations asked of a scene without noise or uncertain parameters."""


class LongRunWarning(VinesStochWarning):
    """A run of more path-steps than ``scenario.study.LONG_RUN``: its cost said before it starts."""


class DivergedWarning(VinesStochWarning):
    """Realisations that diverged (``status``): left out of the statistics, counted in
    ``n_failed``."""


class EnergyBalanceWarning(VinesStochWarning):
    """Realisations ended ok whose energy balance does not close (``|energy_residual|`` above
    ``simulation.residual_tolerance``)."""


class Notice(str):
    """A warning's line with its category (``category``)."""

    category: type[VinesStochWarning] = VinesStochWarning

    def __new__(cls, text: str, category: type[VinesStochWarning] = VinesStochWarning) -> Notice:
        notice = super().__new__(cls, text)
        notice.category = category
        return notice


def emit(lines, stacklevel: int = 3) -> None:
    """``warnings.warn`` each line with its category (``Notice.category``; plain lines:
    ``VinesStochWarning``)."""
    import warnings

    for line in lines:
        warnings.warn(str(line), getattr(line, "category", VinesStochWarning), stacklevel=stacklevel)
