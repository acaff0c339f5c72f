"""Distributions of uncertain parameters (``[uncertain]``).

A realisation draws each parameter, in file order, as one number of its parameter stream
(``streams.PARAMETERS``): a standard normal where the distribution's ``normal`` is set, else a
uniform on ``[0, 1)`` (``kernels.chunk.parameter_draws``, a chunk's draws in one compiled call),
and ``value`` turns the draw into the parameter's value.
"""

from __future__ import annotations

import math
from typing import Annotated, ClassVar, Literal

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

    normal: ClassVar[bool] = True

    def value(self, z: np.ndarray) -> np.ndarray:
        """The values of standard normal draws ``z``."""
        return self.mean + self.std * z


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

    normal: ClassVar[bool] = True

    def value(self, z: np.ndarray) -> np.ndarray:
        """The values of standard normal draws ``z`` (``math.exp`` a value: the same bits on
        every machine, where numpy's vector ``exp`` differs by a SIMD target)."""
        s = math.sqrt(math.log1p(self.cov ** 2))
        flat = np.asarray(z, dtype=float).ravel()
        return np.array([self.median * math.exp(s * zk) for zk in flat]).reshape(np.shape(z))


class _Bounded(_Model):
    low: Real
    high: Real
    normal: ClassVar[bool] = False

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

    def value(self, u: np.ndarray) -> np.ndarray:
        """The values of uniform draws ``u``."""
        return self.low + (self.high - self.low) * u


class TruncatedNormalDistribution(_Bounded):
    """``mean + std Z`` conditioned on ``[low, high]`` (drawn by inverting its CDF)."""

    distribution: Literal["truncated-normal"]
    mean: Real
    std: Positive

    def value(self, u: np.ndarray) -> np.ndarray:
        """The values of uniform draws ``u``."""
        from scipy.stats import truncnorm

        a, b = (self.low - self.mean) / self.std, (self.high - self.mean) / self.std
        return truncnorm.ppf(u, a, b, loc=self.mean, scale=self.std)


Distribution = Annotated[
    NormalDistribution | LognormalDistribution | UniformDistribution | TruncatedNormalDistribution,
    Field(discriminator="distribution"),
]
