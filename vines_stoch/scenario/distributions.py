"""Distributions of uncertain parameters (``[uncertain]``)."""

from __future__ import annotations

import math
from typing import Annotated, Literal

import numpy as np
from pydantic import Field, model_validator

from .errors import FieldError
from .fields import Positive, Real, _Model

#: Standard deviations of a normal variable that its draws reach in practice: beyond them the
#: probability is 1.5e-23 a draw (1e-12 in the largest run the limits allow, 1e11 draws).
REACH = 10.0


class NormalDistribution(_Model):
    """``mean + std Z``."""

    distribution: Literal["normal"]
    mean: Real
    std: Positive

    def support(self) -> tuple[float, float]:
        return -math.inf, math.inf

    def reach(self) -> tuple[float, float]:
        """The range of the draws in practice: ``REACH`` standard deviations."""
        return self.mean - REACH * self.std, self.mean + REACH * self.std

    def draw(self, gen: np.random.Generator) -> float:
        return self.mean + self.std * gen.standard_normal()


class LognormalDistribution(_Model):
    """``median exp(s Z)`` with ``s^2 = ln(1 + cov^2)`` (``cov``: coefficient of variation)."""

    distribution: Literal["lognormal"]
    median: Positive
    cov: Positive

    def support(self) -> tuple[float, float]:
        return 0.0, math.inf

    def reach(self) -> tuple[float, float]:
        """The range of the draws in practice: ``ln X`` within ``REACH`` standard deviations."""
        s = math.sqrt(math.log1p(self.cov ** 2))
        return self.median * math.exp(-REACH * s), self.median * math.exp(min(REACH * s, 700.0))

    def draw(self, gen: np.random.Generator) -> float:
        return self.median * math.exp(math.sqrt(math.log1p(self.cov ** 2)) * gen.standard_normal())


class _Bounded(_Model):
    low: Real
    high: Real

    @model_validator(mode="after")
    def _order(self) -> _Bounded:
        if not self.low < self.high:
            raise FieldError("high", self.high, f"must be > low ({self.low:g})")
        return self

    def support(self) -> tuple[float, float]:
        return self.low, self.high

    def reach(self) -> tuple[float, float]:
        return self.low, self.high


class UniformDistribution(_Bounded):
    """Uniform on ``[low, high]``."""

    distribution: Literal["uniform"]

    def draw(self, gen: np.random.Generator) -> float:
        return self.low + (self.high - self.low) * gen.random()


class TruncatedNormalDistribution(_Bounded):
    """``mean + std Z`` conditioned on ``[low, high]`` (drawn by inverting its CDF)."""

    distribution: Literal["truncated-normal"]
    mean: Real
    std: Positive

    def draw(self, gen: np.random.Generator) -> float:
        from scipy.stats import truncnorm

        a, b = (self.low - self.mean) / self.std, (self.high - self.mean) / self.std
        return float(truncnorm.ppf(gen.random(), a, b, loc=self.mean, scale=self.std))


Distribution = Annotated[
    NormalDistribution | LognormalDistribution | UniformDistribution | TruncatedNormalDistribution,
    Field(discriminator="distribution"),
]
