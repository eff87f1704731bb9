"""Dominant wavelengths of a straightness profile (seed 001: a guideway base
surface usually shows a sine-like profile with a characteristic wavelength).

The profile is detrended by its least-squares line and analysed by the
periodogram of ``scipy.signal.periodogram(window="boxcar", scaling="spectrum")``
(computed here with ``numpy.fft.rfft`` directly, which is the same sum without
that function's segment machinery: 20x faster at 1e6 samples; numpy's rfft gives
the same bits as ``scipy.fft.rfft`` and imports in a fraction of the time) at the mean
station spacing, zero-padded to up to 64 times its length (at most about 2^21
points) so the peak frequency is located between the DFT bins.  With that scaling a sine of amplitude A gives a
peak of A^2/2, so the amplitude reported is sqrt(2 P).  The frequency
resolution is one cycle per record length: wavelengths not shorter than the
measured length (x[-1] - x[0]) and shorter than two spacings (Nyquist) are not
reported.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .reference_lines import least_squares_line

ZERO_PAD = 64
MAX_FFT = 2**21


def next_fast_len(target: int) -> int:
    """The smallest 2^a 3^b 5^c >= ``target`` (>= 1): a length the FFT does fast (what
    ``scipy.fft.next_fast_len(target, real=True)`` returns)."""
    best = 1 << max(0, (int(target) - 1).bit_length())  # the power of two is always a candidate
    p5 = 1
    while p5 < best:
        p35 = p5
        while p35 < best:
            n = p35
            while n < target:  # the smallest power of two times p35 that reaches the target
                n *= 2
            best = min(best, n)
            p35 *= 3
        p5 *= 5
    return best


@dataclass(frozen=True)
class Peak:
    wavelength_mm: float
    amplitude_um: float


def spectrum(x_mm: np.ndarray, h_um: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """(frequency 1/mm, amplitude um, spacing mm) of the LS-detrended profile."""
    x = np.asarray(x_mm, dtype=float)
    n = len(x)
    dx = (x[-1] - x[0]) / (n - 1)
    if not dx > 0:
        raise ValueError("profile positions must increase")
    resid = least_squares_line(x, h_um).deviations_um
    nfft = next_fast_len(n * max(1, min(ZERO_PAD, MAX_FFT // n)))
    # one-sided power spectrum: |X_k|^2 / n^2, doubled except at DC (and Nyquist for even nfft)
    p = np.abs(np.fft.rfft(resid, nfft)) ** 2 / float(n) ** 2
    p[1:] *= 2.0
    if nfft % 2 == 0:
        p[-1] /= 2.0
    f = np.fft.rfftfreq(nfft, d=dx)
    return f, np.sqrt(2.0 * p), dx


def dominant_wavelengths(x_mm: np.ndarray, h_um: np.ndarray, count: int = 3) -> list[Peak]:
    """Up to ``count`` spectral peaks, largest first, at least one resolution apart, with
    wavelengths shorter than the measured length x[-1] − x[0] (and longer than two spacings).

    Needs at least 4 points; returns [] for a profile with no variation.
    """
    if len(x_mm) < 4:
        return []
    f, amp, dx = spectrum(x_mm, h_um)
    n = len(x_mm)
    record = n * dx
    length = (n - 1) * dx  # the measured length: a wavelength that long is not resolved
    ok = (f > 1.0 / length) & (f < 0.5 / dx)
    i = np.flatnonzero(ok)
    if len(i) < 3 or np.max(amp[i]) <= 1e-9 * (1.0 + np.max(np.abs(h_um))):  # numerically flat
        return []
    a = amp[i]
    is_peak = np.r_[False, (a[1:-1] >= a[:-2]) & (a[1:-1] > a[2:]), False]
    cand = i[is_peak][np.argsort(-a[is_peak])]
    peaks: list[Peak] = []
    chosen: list[float] = []
    for k in cand:
        if any(abs(f[k] - c) < 1.0 / record for c in chosen):
            continue
        chosen.append(float(f[k]))
        peaks.append(Peak(float(1.0 / f[k]), float(amp[k])))
        if len(peaks) == count:
            break
    return peaks
