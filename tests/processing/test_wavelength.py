"""Dominant wavelength of synthetic sines of known wavelength and amplitude."""

from __future__ import annotations

import numpy as np
import pytest

from processing.wavelength import dominant_wavelengths


@pytest.mark.parametrize("wavelength", [333.0, 640.0, 1250.0])
def test_single_sine_on_a_tilt(wavelength: float) -> None:
    x = np.arange(0, 100) * 50.0  # 5 m at 50 mm spacing
    h = 2.5 * np.sin(2 * np.pi * x / wavelength + 0.7) + 0.004 * x + 1.0
    peaks = dominant_wavelengths(x, h)
    assert peaks[0].wavelength_mm == pytest.approx(wavelength, rel=0.02)
    assert peaks[0].amplitude_um == pytest.approx(2.5, rel=0.05)


def test_two_sines_in_noise_are_both_found() -> None:
    rng = np.random.default_rng(3)
    x = np.arange(0, 200) * 20.0
    h = 3.0 * np.sin(2 * np.pi * x / 640.0) + 1.0 * np.sin(2 * np.pi * x / 230.0 + 1) + rng.normal(0, 0.1, x.size)
    p = dominant_wavelengths(x, h)
    assert p[0].wavelength_mm == pytest.approx(640.0, rel=0.02)
    assert p[1].wavelength_mm == pytest.approx(230.0, rel=0.02)
    assert p[0].amplitude_um == pytest.approx(3.0, rel=0.08)
    assert p[1].amplitude_um == pytest.approx(1.0, rel=0.15)


def test_flat_and_short_profiles_give_nothing() -> None:
    x = np.arange(10) * 100.0
    assert dominant_wavelengths(x, 0.01 * x) == []
    assert dominant_wavelengths(x[:3], np.array([0.0, 1.0, 0.0])) == []


@pytest.mark.parametrize("n", [10, 37, 200])
def test_spectrum_is_scipys_periodogram(n: int) -> None:
    """The rfft shortcut equals scipy.signal.periodogram(boxcar, spectrum) on the LS residual."""
    from scipy.signal import periodogram

    from processing.reference_lines import least_squares_line
    from processing.wavelength import spectrum

    rng = np.random.default_rng(n)
    x = np.arange(n) * 25.0
    h = rng.normal(0, 1, n) + 0.01 * x
    f, amp, dx = spectrum(x, h)
    nfft = round(1.0 / (f[1] * 25.0))  # the FFT length the implementation chose
    assert nfft >= 64 * n
    f_ref, p_ref = periodogram(least_squares_line(x, h).deviations_um, fs=1 / 25.0, window="boxcar",
                               nfft=nfft, detrend=False, scaling="spectrum")
    np.testing.assert_allclose(f, f_ref)
    np.testing.assert_allclose(amp, np.sqrt(2 * p_ref), atol=1e-12)


@pytest.mark.parametrize("h", [
    [0.359, 1.322, -0.014, 1.042, 1.402, 1.15, -2.365],
    [-1.902, -0.109, -0.804, 1.08, -0.289, 0.083, -0.85, -0.511, -0.012, -1.485],
])
def test_only_wavelengths_below_the_measured_length_are_reported(h: list[float]) -> None:
    from scipy.signal import periodogram

    from processing.reference_lines import least_squares_line

    x = np.arange(len(h)) * 100.0
    length = x[-1] - x[0]
    # scipy's periodogram of the detrended profile has a peak at a wavelength of at least the
    # measured length (between one record, n spacings, and n - 1 spacings) ...
    f, p = periodogram(least_squares_line(x, np.array(h)).deviations_um, fs=0.01, window="boxcar",
                       nfft=64 * len(h), detrend=False, scaling="spectrum")
    peak = np.flatnonzero((p[1:-1] >= p[:-2]) & (p[1:-1] > p[2:])) + 1
    assert any(1.0 / f[k] >= length for k in peak)
    # ... which is not reported; the shorter peaks are
    got = [q.wavelength_mm for q in dominant_wavelengths(x, np.array(h))]
    assert got and all(w < length for w in got)
