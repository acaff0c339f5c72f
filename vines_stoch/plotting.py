"""matplotlib, where installed: the PNG plots of reports, fits and optimisations are an extra
(``pip install "vines-stoch[report]"``); without it everything else is still written."""

from __future__ import annotations

import sys
from typing import Any

#: What adds the plots.
REPORT_EXTRA = 'pip install "vines-stoch[report]"'


def available() -> bool:
    """True when matplotlib can be imported."""
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        return False
    return True


def pyplot(what: str) -> Any | None:
    """``matplotlib.pyplot`` on the file-only Agg backend, or None after one line on standard
    error saying that ``what`` (e.g. ``"objective_history.png"``) was not drawn."""
    try:
        import matplotlib
    except ImportError:
        print(f"note: {what}: not drawn, matplotlib is not installed ({REPORT_EXTRA} adds it)",
              file=sys.stderr)
        return None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt
