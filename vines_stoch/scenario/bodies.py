"""The bodies: the primary structure (one storey or a shear building) and the absorbers
(MODEL.md sections 1, 1a, 2)."""

from __future__ import annotations

from typing import Annotated, ClassVar, Literal

import numpy as np
from pydantic import Field, model_validator

from .errors import FieldError
from .fields import LARGEST, MAX_ABSORBERS, MAX_FLOORS, Floor, Mass, NonNegative, Positive, Real, _Model

#: A negative finite number (the bistable law's linear stiffness).
Negative = Annotated[float, Field(lt=0, ge=-LARGEST, allow_inf_nan=False)]


class Rayleigh(_Model):
    """Rayleigh damping ``C = alpha M + beta K`` with damping ``ratio`` at two ``modes`` of the
    primary (1-based): ``alpha = 2 z w_i w_j / (w_i + w_j)``, ``beta = 2 z / (w_i + w_j)``
    (Chopra, Dynamics of Structures, section 11.4)."""

    ratio: Annotated[float, Field(ge=0, lt=1)]
    modes: Annotated[list[Annotated[int, Field(ge=1)]], Field(min_length=2, max_length=2)]


class Primary(_Model):
    """The linear primary (MODEL.md sections 1, 1a): one storey (``mass``, ``stiffness``,
    ``damping``) or a shear building (``masses``, ``stiffnesses`` and ``dampings`` or
    ``rayleigh``, floors from the lowest to the roof; storey ``k`` joins floor ``k - 1``, the
    ground for ``k = 1``, to floor ``k``)."""

    mass: Mass | None = None
    stiffness: NonNegative | None = None
    damping: NonNegative | None = None
    masses: Annotated[list[Mass], Field(min_length=1, max_length=MAX_FLOORS)] | None = None
    stiffnesses: list[NonNegative] | None = None
    dampings: list[NonNegative] | None = None
    rayleigh: Rayleigh | None = None
    heights: Annotated[list[Positive], Field(min_length=1, max_length=MAX_FLOORS)] | None = None

    @model_validator(mode="after")
    def _layout(self) -> Primary:
        scalars = {"mass": self.mass, "stiffness": self.stiffness, "damping": self.damping}
        lists = {"masses": self.masses, "stiffnesses": self.stiffnesses, "dampings": self.dampings}
        if self.heights is not None and len(self.heights) != self.n_floors:
            raise FieldError("heights", self.heights, f"must list {self.n_floors} storey height(s) (m), "
                             "one per storey from the lowest (as primary.masses)")
        if self.masses is None:
            if self.mass is None:
                raise FieldError("mass", None, "missing: give mass (one storey) or masses = [...] "
                                 "(floors from the lowest to the roof)")
            for name, value in lists.items():
                if value is not None:
                    raise FieldError(name, value, "needs masses = [...]: a one-storey primary takes mass, "
                                     "stiffness and damping")
            if self.rayleigh is not None:
                raise FieldError("rayleigh", None,
                                 "needs a multi-storey primary (masses = [...]); give damping")
            return self
        for name, value in scalars.items():
            if value is not None:
                raise FieldError(name, value, f"give either {name} (one storey) or the lists masses, "
                                 "stiffnesses, dampings, not both")
        n = len(self.masses)
        for name in ("stiffnesses", "dampings"):
            value = lists[name]
            if value is not None and len(value) != n:
                raise FieldError(name, value, f"must list {n} values (one per storey, as primary.masses)")
        if self.stiffnesses is None:
            raise FieldError("stiffnesses", None, f"missing: give {n} storey stiffnesses")
        if self.dampings is not None and self.rayleigh is not None:
            raise FieldError("rayleigh", None, "give either dampings (storey dashpots) or rayleigh, not both")
        if self.rayleigh is not None:
            modes = self.rayleigh.modes
            if modes[0] == modes[1] or max(modes) > n:
                raise FieldError("rayleigh.modes", modes, f"must be two different modes in [1, {n}]")
            if self.frequencies()[0] <= 0.0:
                raise FieldError("rayleigh", None,
                                 "needs a primary fixed to the ground (every storey stiffness > 0)")
        return self

    @property
    def n_floors(self) -> int:
        return 1 if self.masses is None else len(self.masses)

    @property
    def floor_masses(self) -> list[float]:
        return [float(self.mass)] if self.masses is None else [float(m) for m in self.masses]

    @property
    def storey_stiffnesses(self) -> list[float]:
        if self.masses is None:
            return [float(self.stiffness or 0.0)]
        return [float(k) for k in self.stiffnesses]

    def frequencies(self) -> np.ndarray:
        """Natural frequencies (rad/s, ascending) of the primary alone (no absorbers)."""
        mass, stiffness = np.array(self.floor_masses), shear_stiffness(self.storey_stiffnesses)
        return eigenfrequencies(mass, stiffness)

    def modes(self) -> tuple[np.ndarray, np.ndarray]:
        """``(periods, shares)`` of the primary alone: its natural periods (s, longest first) and
        each mode's share of the total mass under base excitation, the effective modal mass
        ``(phi^T M 1)^2 / (phi^T M phi)`` over ``sum m`` (Chopra, *Dynamics of Structures*, 13.2)."""
        mass, stiffness = np.array(self.floor_masses), shear_stiffness(self.storey_stiffnesses)
        scale = 1.0 / np.sqrt(mass)
        eig, vectors = np.linalg.eigh(stiffness * np.outer(scale, scale))
        phi = vectors * scale[:, None]  # mass-normalised: phi^T M phi = 1
        with np.errstate(divide="ignore"):
            periods = 2.0 * np.pi / np.sqrt(np.clip(eig, 0.0, None))
        return periods, (phi.T @ mass) ** 2 / mass.sum()

    def damping_matrices(self) -> tuple[list[float], list[float]]:
        """``(storey dashpots, mass-proportional dashpots to the ground)``, one per floor:
        the given dashpots, or Rayleigh's ``beta k_k`` and ``alpha m_k``."""
        n = self.n_floors
        if self.masses is None:
            return [float(self.damping or 0.0)], [0.0]
        if self.rayleigh is None:
            return [float(c) for c in (self.dampings or [0.0] * n)], [0.0] * n
        w = self.frequencies()
        wi, wj = (w[m - 1] for m in self.rayleigh.modes)
        z = self.rayleigh.ratio
        alpha, beta = 2.0 * z * wi * wj / (wi + wj), 2.0 * z / (wi + wj)
        return [beta * k for k in self.storey_stiffnesses], [alpha * m for m in self.floor_masses]


def shear_stiffness(storeys: list[float]) -> np.ndarray:
    """Stiffness matrix of a shear building (MODEL.md 1a) from its storey stiffnesses."""
    n = len(storeys)
    k = np.zeros((n, n))
    for i, ks in enumerate(storeys):
        k[i, i] += ks
        if i > 0:
            k[i - 1, i - 1] += ks
            k[i - 1, i] -= ks
            k[i, i - 1] -= ks
    return k


def eigenfrequencies(mass: np.ndarray, stiffness: np.ndarray) -> np.ndarray:
    """Square roots of the eigenvalues of ``M^-1 K`` (diagonal ``M``), ascending."""
    scale = 1.0 / np.sqrt(mass)
    eig = np.linalg.eigvalsh(stiffness * np.outer(scale, scale))
    return np.sqrt(np.clip(eig, 0.0, None))


class _Absorber(_Model):
    """What every absorber type gives the scene: its row (``parameters``), the fields written
    into it as they are (``columns``: field name to ``physics.absorbers.COLUMNS`` name; the
    binding of uncertain parameters writes these in place), whether other fields make its row
    through a computation (``derived``), and its linearised stiffness (``spring``)."""

    columns: ClassVar[dict[str, str]] = {}
    derived: ClassVar[bool] = False

    def parameters(self) -> dict[str, float]:
        """The absorber's row by column name (``physics.absorbers.COLUMNS``)."""
        return {column: getattr(self, name) for name, column in self.columns.items()}


class LinearAbsorber(_Absorber):
    """Tuned mass damper: ``f = -k u - c w`` (MODEL.md section 2)."""

    type: Literal["linear"]
    floor: Floor | None = None
    mass: Mass
    stiffness: NonNegative = 0.0
    damping: NonNegative = 0.0

    columns: ClassVar[dict[str, str]] = {"stiffness": "k_lin", "damping": "damping"}

    @property
    def spring(self) -> float:
        """Stiffness of the attachment linearised about its stable rest position (the frequency
        estimate of the ``dt`` checks, ``Scenario.natural_frequencies``)."""
        return self.stiffness


class CubicAbsorber(_Absorber):
    """Cubic NES: ``f = -k u^3 - k_lin u - c w`` (MODEL.md section 2, Wei et al. eq. 1)."""

    type: Literal["cubic"]
    floor: Floor | None = None
    mass: Mass
    stiffness: NonNegative = 0.0
    damping: NonNegative = 0.0
    linear_stiffness: NonNegative = 0.0

    columns: ClassVar[dict[str, str]] = {"stiffness": "k_cubic", "linear_stiffness": "k_lin",
                                         "damping": "damping"}

    @property
    def spring(self) -> float:
        """Stiffness of the attachment linearised about ``u = 0`` (see ``LinearAbsorber.spring``)."""
        return self.linear_stiffness


class BistableAbsorber(_Absorber):
    """Bistable NES: the cubic law with a negative linear stiffness, ``f = -k u^3 - k_lin u - c w``,
    ``k_lin < 0 < k``, stable at ``u = +-sqrt(-k_lin / k)`` (MODEL.md section 2; Romeo, Sigalov,
    Bergman and Vakakis, J. Comput. Nonlinear Dyn. 10 (2015) 011007; Habib and Romeo, Nonlinear
    Dyn. 89 (2017)).  It starts at ``u = 0``, the top of the barrier, unless an ``initial`` load
    places it."""

    type: Literal["bistable"]
    floor: Floor | None = None
    mass: Mass
    stiffness: Positive
    linear_stiffness: Negative
    damping: NonNegative = 0.0

    columns: ClassVar[dict[str, str]] = {"stiffness": "k_cubic", "linear_stiffness": "k_lin",
                                         "damping": "damping"}

    @property
    def spring(self) -> float:
        """Stiffness at the two stable positions, ``k_lin + 3 k u^2 = -2 k_lin``."""
        return -2.0 * self.linear_stiffness


class GeometricAbsorber(_Absorber):
    """Geometrically nonlinear NES: two transverse linear springs of stiffness ``stiffness`` each,
    free length ``free_length``, installed length ``length >= free_length``,
    ``f = -2 k u (1 - l0 / sqrt(u^2 + l^2)) - c w`` (MODEL.md section 2; the physical cubic NES of
    McFarland, Bergman and Vakakis, Int. J. Non-Linear Mech. 40 (2005) 891): for ``l = l0`` and
    small ``u`` the cubic law with ``k / l0^2``."""

    type: Literal["geometric"]
    floor: Floor | None = None
    mass: Mass
    stiffness: Positive
    free_length: Positive
    length: Positive
    damping: NonNegative = 0.0

    @model_validator(mode="after")
    def _pretension(self) -> GeometricAbsorber:
        if self.length < self.free_length:
            raise FieldError("length", self.length, f"must be >= free_length ({self.free_length:g}): "
                             "springs installed in compression make a bistable absorber, not this law")
        return self

    columns: ClassVar[dict[str, str]] = {"stiffness": "k_geo", "free_length": "free_length",
                                         "length": "length", "damping": "damping"}

    @property
    def spring(self) -> float:
        """Stiffness of the attachment at ``u = 0``, ``2 k (1 - l0 / l)`` (it stiffens towards ``2 k``
        as ``|u|`` grows, as the cubic law's does without bound)."""
        return 2.0 * self.stiffness * (1.0 - self.free_length / self.length)


class GapAbsorber(_Absorber):
    """Piecewise-linear NES: a linear spring of stiffness ``stiffness`` engaged beyond a gap
    ``gap`` on either side, beside an optional linear spring ``linear_stiffness`` and a dashpot,
    ``f = -k_lin u - k (|u| - g)_+ sign(u) - c w`` (MODEL.md section 2; the non-smooth NES of
    Lamarque, Gendelman, Ture Savadkoohi and Etcheverria, Acta Mech. 221 (2011) 175): without the
    linear spring it has no stiffness at rest, an essentially nonlinear energy sink."""

    type: Literal["gap"]
    floor: Floor | None = None
    mass: Mass
    stiffness: Positive
    gap: NonNegative
    linear_stiffness: NonNegative = 0.0
    damping: NonNegative = 0.0

    columns: ClassVar[dict[str, str]] = {"stiffness": "k_gap", "gap": "gap", "linear_stiffness": "k_lin",
                                         "damping": "damping"}

    @property
    def spring(self) -> float:
        """Stiffness of the attachment with its gap spring engaged, ``k_lin + k`` (its stiffest
        branch: the frequency the ``dt`` checks must resolve)."""
        return self.linear_stiffness + self.stiffness


class ImpactAbsorber(_Absorber):
    """Vibro-impact NES in a symmetric cavity with Newton restitution (MODEL.md section 2).

    The cavity is in its host floor, or with ``impacts_with = j`` in absorber ``j`` (1-based,
    file order): the walls move with that absorber and the impacts exchange momentum with it,
    while the spring and dashpot still join the host floor.  This is the vibro-impact dual-mass
    damper (VIDM) of Wang J. et al., "Seismic response mitigation of building structures with a
    novel vibro-impact dual-mass damper", Eng. Struct. 215 (2020) 110673 (seed 001, Table 5):
    two absorbers on the roof that also strike each other.
    """

    type: Literal["impact"]
    floor: Floor | None = None
    mass: Mass
    clearance: Positive
    restitution: Annotated[float, Field(ge=0, le=1)]
    stiffness: NonNegative = 0.0
    damping: NonNegative = 0.0
    impacts_with: Annotated[int, Field(ge=1, le=MAX_ABSORBERS)] | None = None

    columns: ClassVar[dict[str, str]] = {"stiffness": "k_lin", "damping": "damping", "clearance": "clearance",
                                         "restitution": "restitution"}

    @property
    def spring(self) -> float:
        """Stiffness of the attachment's spring (see ``LinearAbsorber.spring``)."""
        return self.stiffness


class Contact(_Model):
    """Hertz contact constant ``K`` of one side, given directly (``k``) or from the surfaces:
    Young's moduli and Poisson ratios ``[barrier, absorber]`` and the sphere ``radius``
    (MODEL.md section 2)."""

    k: Positive | None = None
    young: Annotated[list[Positive], Field(min_length=2, max_length=2)] | None = None
    poisson: Annotated[list[Annotated[float, Field(ge=0, lt=0.5)]],
                       Field(min_length=2, max_length=2)] | None = None
    radius: Positive | None = None
    q: Positive = 0.318

    @model_validator(mode="after")
    def _one_way(self) -> Contact:
        surfaces = (self.young, self.poisson, self.radius)
        if self.k is not None and any(s is not None for s in surfaces):
            raise FieldError("k", self.k, "give either k or young/poisson/radius, not both")
        if self.k is None and any(s is None for s in surfaces):
            missing = [n for n, s in zip(("young", "poisson", "radius"), surfaces) if s is None]
            raise FieldError(missing[0], None, "missing: give k, or all of young = [barrier, absorber], "
                            "poisson = [barrier, absorber] and radius")
        return self

    @property
    def constant(self) -> float:
        """``K`` of ``F = K z^1.5``."""
        if self.k is not None:
            return float(self.k)
        from ..physics.hertz import hertz_constant  # (not at import: it brings in numba)

        return hertz_constant(self.young, self.poisson, self.radius, self.q)


class HertzAbsorber(_Absorber):
    """Vibro-impact NES with finite-duration Hertz contact (MODEL.md section 2, Lizunov et al.).

    ``offset`` is D (single-sided, one-barrier) or V (double-sided), ``gap`` is C.  ``rest``
    overrides the spring's rest offset (default D, or V + C for double-sided).  A one-barrier
    absorber is a single-sided one that never touches the primary: its one barrier is the
    obstacle, and it has no ``contact_left`` (seed 001 eq. 1).
    """

    type: Literal["hertz"]
    geometry: Literal["single-sided", "double-sided", "one-barrier"]
    floor: Floor | None = None
    mass: Mass
    stiffness: NonNegative = 0.0
    damping: NonNegative = 0.0
    offset: NonNegative
    gap: Positive
    contact_left: Contact | None = None
    contact_right: Contact
    obstacle: Literal["from-rest", "from-primary"] = "from-rest"
    rest: Real | None = None

    @model_validator(mode="after")
    def _geometry(self) -> HertzAbsorber:
        one_barrier = self.geometry == "one-barrier"
        if one_barrier and self.contact_left is not None:
            raise FieldError("contact_left", self.contact_left.model_dump(exclude_unset=True),
                             "a one-barrier absorber never touches the primary: "
                             "leave contact_left out, or use geometry = 'single-sided'")
        if not one_barrier and self.contact_left is None:
            raise FieldError("contact_left", None, f"missing: a {self.geometry} absorber has a left contact "
                             "(geometry = 'one-barrier' has none: seed 001 eq. 1)")
        if self.obstacle == "from-primary":
            if self.geometry == "double-sided":
                raise FieldError("obstacle", self.obstacle,
                                 "'from-primary' (seed 002) is defined for the single-sided and one-barrier "
                                 "geometries only")
            if self.offset >= self.gap:
                raise FieldError("offset", self.offset, f"must be < gap ({self.gap:g}) with obstacle = "
                                 "'from-primary' (the absorber would start inside the obstacle)")
        return self

    @property
    def walls(self) -> tuple[float, float]:
        """Relative positions ``(lo, hi)`` of the left and right contact surfaces:
        ``z_L = lo - u``, ``z_R = u - hi``; ``lo = -inf`` for a one-barrier absorber."""
        if self.geometry == "double-sided":
            return self.offset, self.offset + 2.0 * self.gap
        lo = -np.inf if self.geometry == "one-barrier" else 0.0
        if self.obstacle == "from-primary":
            return lo, self.gap
        return lo, self.offset + self.gap

    @property
    def start(self) -> float:
        """Initial relative position: D (single-sided, one-barrier) or V + C (double-sided)."""
        return self.offset + (self.gap if self.geometry == "double-sided" else 0.0)

    @property
    def spring_rest(self) -> float:
        """Rest offset of the linear spring."""
        return self.start if self.rest is None else self.rest

    columns: ClassVar[dict[str, str]] = {"stiffness": "k_lin", "damping": "damping"}
    derived: ClassVar[bool] = True

    def parameters(self) -> dict[str, float]:
        """The absorber's row by column name (``physics.absorbers.COLUMNS``): the spring and
        dashpot, the spring's rest offset, the contact constants and surfaces."""
        lo, hi = self.walls
        left = self.contact_left.constant if self.contact_left is not None else 0.0
        return {**super().parameters(), "rest": self.spring_rest, "k_left": left,
                "k_right": self.contact_right.constant, "wall_lo": lo, "wall_hi": hi}

    @property
    def spring(self) -> float:
        """Stiffness of the attachment's spring (see ``LinearAbsorber.spring``)."""
        return self.stiffness


#: Every absorber type, by its ``type``.
ABSORBERS = {"linear": LinearAbsorber, "cubic": CubicAbsorber, "impact": ImpactAbsorber,
             "hertz": HertzAbsorber, "bistable": BistableAbsorber, "geometric": GeometricAbsorber,
             "gap": GapAbsorber}
Absorber = Annotated[
    LinearAbsorber | CubicAbsorber | ImpactAbsorber | HertzAbsorber | BistableAbsorber | GeometricAbsorber
    | GapAbsorber,
    Field(discriminator="type"),
]
