"""Field types shared by the scenario models: the base model, bounded numbers, floors."""

from __future__ import annotations

from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True, frozen=False)


#: The largest magnitude of a number in a scenario: squares and products of two stay far from
#: overflow in the energy sums (use other units past it).
LARGEST = 1e15

#: The smallest mass, ``1 / LARGEST``: with every stiffness at most ``LARGEST``, the ratios
#: ``k / m`` of the eigenproblem and the accelerations stay below 1e30 (below about 1e-293 they can
#: overflow: the frequencies are then not defined, and every realisation diverges).
SMALLEST_MASS = 1.0 / LARGEST

Positive = Annotated[float, Field(gt=0, le=LARGEST, allow_inf_nan=False)]
Mass = Annotated[float, Field(ge=SMALLEST_MASS, le=LARGEST, allow_inf_nan=False)]
NonNegative = Annotated[float, Field(ge=0, le=LARGEST, allow_inf_nan=False)]
Real = Annotated[float, Field(ge=-LARGEST, le=LARGEST, allow_inf_nan=False)]

#: Sizes that cannot be meant: nesting of tables and arrays, absorbers, loads, limits, floors, sweep
#: points, realisations a sweep point (a row each in the results) and steps a path.
MAX_DEPTH = 12
MAX_ABSORBERS = 100
MAX_LOADS = 100
MAX_LIMITS = 100
MAX_FLOORS = 200
MAX_POINTS = 10_000
MAX_REALIZATIONS = 10_000_000
MAX_STEPS = 1_000_000_000


#: A floor number, 1 (lowest) to the roof; its range is checked against the primary's floors
#: (``model.floor_mistakes``: beside the file's other mistakes).
Floor = int
