"""Spectra of an ensemble's responses (``[output] spectra``, spectra.parquet): each realisation's
one-sided power spectral density over the metrics window by Welch's method, averaged over the
realisations, with a 95 % confidence band from their spread.

Welch's method (Welch, IEEE Trans. Audio Electroacoust. 15 (1967) 70, DOI 10.1109/TAU.1967.1161901;
``scipy.signal.welch``): Hann-windowed segments overlapping by half, each detrended by its mean,
their periodograms averaged.  The density is one-sided and per rad/s (``S(omega)``, with
``integral_0^inf S d omega`` the variance): scipy's density per Hz over ``2 pi``.  A
realisation's estimate is one draw of an estimator; the realisations' estimates are
independent, so their mean has the standard error ``std / sqrt(R)`` whatever the response's law
(impacts included), and the band is the mean plus or minus Student's ``t`` (95 %, ``R - 1``
degrees of freedom) standard errors.

The realisations are added one at a time in realisation order (``Spectrum.add``: running sums
by ``np.cumsum``, which adds left to right), so that the numbers depend on no chunk size or
worker count.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

#: Segments of a realisation's window by default (overlapping by half): ``segment`` is the
#: window over ``(SEGMENTS + 1) / 2``.
SEGMENTS = 15


def segment_steps(window_steps: int, segment: float | None, dt: float) -> int:
    """Steps of one Welch segment: ``segment`` seconds, or the window's ``2 / (SEGMENTS + 1)``;
    at least 8, at most the window."""
    steps = round(segment / dt) if segment else (2 * window_steps) // (SEGMENTS + 1)
    return max(8, min(int(steps), window_steps))


def frequencies(steps: int, dt: float) -> np.ndarray:
    """The angular frequencies (rad/s) of Welch estimates with segments of ``steps`` samples."""
    return 2.0 * math.pi * np.fft.rfftfreq(steps, dt)


def periodograms(paths: np.ndarray, dt: float, steps: int) -> tuple[np.ndarray, np.ndarray]:
    """The Welch estimates of rows of ``paths`` (``(..., n)``: samples every ``dt``) with segments
    of ``steps`` samples: ``omega`` (rad/s) and the one-sided densities per rad/s ``(..., omega)``."""
    from scipy.signal import welch

    f, p = welch(paths, fs=1.0 / dt, window="hann", nperseg=steps, noverlap=steps // 2,
                 detrend="constant", scaling="density", axis=-1)
    return 2.0 * math.pi * f, p / (2.0 * math.pi)


@dataclass
class Spectrum:
    """Running sums of the realisations' estimates of one sweep point (``(signals, omega)``)."""

    count: int = 0
    total: np.ndarray | None = None
    squares: np.ndarray | None = None

    def add(self, estimates: np.ndarray) -> None:
        """Add the estimates ``(signals, omega, m)`` of the next ``m`` realisations, in order."""
        if estimates.shape[-1] == 0:
            return
        rows = np.moveaxis(estimates, -1, 0)
        start = np.zeros((1, *rows.shape[1:])) if self.total is None else self.total[np.newaxis]
        start_sq = np.zeros((1, *rows.shape[1:])) if self.squares is None else self.squares[np.newaxis]
        self.total = np.cumsum(np.concatenate([start, rows]), axis=0)[-1]
        self.squares = np.cumsum(np.concatenate([start_sq, rows * rows]), axis=0)[-1]
        self.count += rows.shape[0]

    def to_arrays(self) -> dict[str, np.ndarray]:
        """The sums as named arrays (a checkpoint's content; ``from_arrays`` takes them back)."""
        out = {"count": np.array(self.count)}
        if self.total is not None:
            out.update(total=self.total, squares=self.squares)
        return out

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray]) -> Spectrum:
        return cls(int(arrays["count"]), arrays.get("total"), arrays.get("squares"))

    def frame(self, omega: np.ndarray, signals: tuple[str, ...]) -> pd.DataFrame:
        """Rows ``signal, omega, psd, psd_lo, psd_hi`` (NaN band below two realisations)."""
        from scipy.stats import t as student_t

        n = self.count
        shape = (len(signals), omega.size)
        mean = self.total / n if n else np.full(shape, np.nan)
        if n > 1:
            var = np.maximum(self.squares - n * mean * mean, 0.0) / (n - 1)
            half = float(student_t.ppf(0.975, n - 1)) * np.sqrt(var / n)
        else:
            half = np.full(shape, np.nan)
        return pd.DataFrame({"signal": np.repeat(signals, omega.size), "omega": np.tile(omega, len(signals)),
                             "psd": mean.reshape(-1), "psd_lo": (mean - half).reshape(-1),
                             "psd_hi": (mean + half).reshape(-1)})


#: The wavelet of ``scalogram``: a complex Morlet of bandwidth 1.5 and centre frequency 1
#: (PyWavelets' ``cmor1.5-1.0``): its Gaussian envelope's standard deviation is about 0.87 cycles
#: of the analysed frequency.
WAVELET = "cmor1.5-1.0"


def scalogram(signal: np.ndarray, dt: float, omega: np.ndarray, wavelet: str = WAVELET) -> np.ndarray:
    """The local amplitude of ``signal`` (samples ``dt`` apart) at each angular frequency of
    ``omega`` (rad/s) and each sample, ``(len(omega), len(signal))``: the continuous wavelet
    transform (``pywt.cwt``; Torrence and Compo, Bull. Am. Meteorol. Soc. 79 (1998) 61, DOI
    10.1175/1520-0477(1998)079<0061:APGTWA>2.0.CO;2) at the scales that put the wavelet's centre
    frequency at ``omega``, as ``2 |W| / sqrt(scale)``: a sinusoid of amplitude ``A`` and frequency
    ``w`` gives a ridge of height ``A`` at ``omega = w``.  Within two or three periods of the
    longest analysed wave from either end the record's edges bias it.  Needs PyWavelets (the ``report``
    extra)."""
    import pywt

    omega = np.asarray(omega, dtype=np.float64)
    if omega.ndim != 1 or not (omega > 0).all():
        raise ValueError("scalogram: omega must be a list of angular frequencies > 0 (rad/s)")
    scales = pywt.central_frequency(wavelet) * 2.0 * math.pi / (omega * dt)
    x = np.asarray(signal, dtype=np.float64)
    coefficients, _ = pywt.cwt(x - x.mean(), scales, wavelet, sampling_period=dt, method="fft")
    return 2.0 * np.abs(coefficients) / np.sqrt(scales)[:, None]
