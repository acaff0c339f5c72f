"""Scenario files: parsing, validation and sweep expansion (SCENARIOS.md).

A scenario is validated completely before anything is computed.  Every mistake is reported
as one line naming the file, the dotted key, the value and what is allowed, e.g.
``scenarios/x.toml: absorbers.1.restitution = 1.4: must be in [0, 1]``.

The package by topic: ``bodies`` (primary and absorbers), ``loads``, ``settings`` (simulation,
history, ensemble, optimisation, output), ``distributions``, ``model`` (the root model),
``errors`` (the translator from pydantic's errors), ``sweeps`` and ``study`` (a file read and
expanded).  It imports neither numba, dask nor pandas: ``vines-stoch validate`` stays light.
"""

from .bodies import (
    Absorber,
    BistableAbsorber,
    Contact,
    CubicAbsorber,
    GapAbsorber,
    GeometricAbsorber,
    HertzAbsorber,
    ImpactAbsorber,
    LinearAbsorber,
    Primary,
    Rayleigh,
)
from .distributions import (
    Distribution,
    LognormalDistribution,
    NormalDistribution,
    TruncatedNormalDistribution,
    UniformDistribution,
)
from .errors import ScenarioError
from .loads import (
    BaseHarmonicLoad,
    BlastLoad,
    ChirpLoad,
    FilteredNoiseLoad,
    ForceRecordLoad,
    GroundMotionLoad,
    HalfSineLoad,
    HarmonicLoad,
    ImpulseLoad,
    InitialLoad,
    JenningsEnvelope,
    Load,
    PulseTrainLoad,
    RecordLoad,
    SaragoniHartEnvelope,
    WhiteNoiseLoad,
    WindLoad,
)
from .model import Scenario
from .settings import (
    OBJECTIVES,
    Bound,
    Ensemble,
    History,
    IntensityMeasures,
    Limit,
    Optimize,
    Output,
    Paths,
    Simulation,
    Spectra,
    limit_metrics,
    quantile_name,
)
from .study import Study, load_scenario, parse_scenario
from .sweeps import get_path, set_path

__all__ = [
    "OBJECTIVES", "Absorber", "BaseHarmonicLoad", "BistableAbsorber", "BlastLoad", "Bound", "ChirpLoad",
    "Contact", "CubicAbsorber", "Distribution", "Ensemble", "FilteredNoiseLoad", "ForceRecordLoad",
    "GapAbsorber", "GeometricAbsorber", "GroundMotionLoad", "HalfSineLoad", "HarmonicLoad",
    "HertzAbsorber", "History", "ImpactAbsorber", "IntensityMeasures", "ImpulseLoad", "InitialLoad",
    "JenningsEnvelope", "Limit", "LinearAbsorber", "Load", "LognormalDistribution", "NormalDistribution",
    "Optimize", "Output", "Paths", "Primary", "PulseTrainLoad", "Rayleigh", "RecordLoad",
    "SaragoniHartEnvelope",
    "Scenario", "ScenarioError", "Simulation", "Spectra", "Study", "TruncatedNormalDistribution",
    "UniformDistribution", "WhiteNoiseLoad", "WindLoad", "get_path", "limit_metrics", "load_scenario",
    "parse_scenario", "quantile_name", "set_path",
]
