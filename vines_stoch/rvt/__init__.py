"""Estimates without an ensemble (MODEL.md section 6): exact linear random vibration, Gaussian
statistical linearisation and first-passage approximations.

- ``system``: the linear(ised) state-space model of a scene (bodies and load filters);
- ``moments``: stationary (Lyapunov) and time-varying covariances, harmonic means, spectra;
- ``linearization``: the absorber laws' equivalent slopes and their fixed point;
- ``passage``: Rice's crossing rates, Poisson and Vanmarcke first passage, mean peaks;
- ``table``: ``estimate(scenario)``, a row a sweep point, and ``beside`` a run's summary.

It reads scenes (``scene.py``), never kernels: nothing here compiles.
"""

from .table import estimate

__all__ = ["estimate"]
