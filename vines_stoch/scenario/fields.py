"""Field types shared by the scenario models: the base model, bounded numbers, floors."""

from __future__ import annotations

from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field

class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=False, frozen=False)


Positive = Annotated[float, Field(gt=0, allow_inf_nan=False)]
NonNegative = Annotated[float, Field(ge=0, allow_inf_nan=False)]
Real = Annotated[float, Field(allow_inf_nan=False)]


#: A floor number, 1 (lowest) to the roof; its range is checked against the primary's floors.
Floor = int
