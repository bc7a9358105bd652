#!/usr/bin/env python3
"""Whether filtering a whole finite capture by one FFT (circular, as gap_effects.py's `filtered`)
makes a narrow path resonance look like something a path resonance on a stationary signal is not.

A strong line whose frequency is not periodic over the record leaks across every FFT bin (the
rectangular window's sidelobes); a resonance lifts that leakage near f_n. Compared with each line
filtered exactly by H at its own frequency (an LTI filter's steady state), the rest (white noise)
filtered by FFT in both. The lines are then removed by least squares at their known frequencies,
as the synchronous averages would, and the residual's power at f_n is read against its
surroundings. Prints both, in dB.

    circular_filter_check.py
"""
import numpy as np

FS, SECONDS = 50000.0, 2.5
FN, ZETA, PEAK_DB = 2256.25, 0.0025, 14.87
# A mesh harmonic 33 Hz under f_n, another above, and a weak shaft line 3 Hz above f_n.
LINES = [(2223.0, 1.0), (2394.3, 0.5), (2259.1, 0.05)]


def path_gain(f):
    """1 + (g − 1)·B, B the single-degree-of-freedom band-pass normalised to 1 at f_n."""
    r = f / FN
    b = 2j * ZETA * r / (1 - r * r + 2j * ZETA * r)
    return 1 + (10 ** (PEAK_DB / 20) - 1) * b


def fft_filtered(y):
    f = np.fft.rfftfreq(y.size, 1 / FS)
    return np.fft.irfft(np.fft.rfft(y) * path_gain(f), n=y.size)


def without_lines(y, t):
    columns = []
    for f, _ in LINES:
        columns += [np.cos(2 * np.pi * f * t), np.sin(2 * np.pi * f * t)]
    a = np.array(columns).T
    c, *_ = np.linalg.lstsq(a, y, rcond=None)
    return y - a @ c


def band_power(y, lo, hi):
    f = np.fft.rfftfreq(y.size, 1 / FS)
    p = np.abs(np.fft.rfft(y * np.hanning(y.size))) ** 2
    return p[(f >= lo) & (f < hi)].mean()


def main():
    t = np.arange(int(FS * SECONDS)) / FS
    noise = fft_filtered(1e-3 * np.random.default_rng(1).standard_normal(t.size))
    lines = sum(a * np.cos(2 * np.pi * f * t + 0.3) for f, a in LINES)
    exact = sum(a * abs(path_gain(f)) * np.cos(2 * np.pi * f * t + 0.3 + np.angle(path_gain(f))) for f, a in LINES)
    for name, y in (("FFT-filtered (circular)", fft_filtered(lines) + noise), ("each line by H(f_line)", exact + noise)):
        r = without_lines(y, t)
        excess = 10 * np.log10(band_power(r, FN - 6, FN + 6) / band_power(r, FN + 60, FN + 200))
        print(f"{name}: residual at f_n ± 6 Hz over 60-200 Hz away: {excess:.1f} dB")
    print(f"the path's peak gain: {PEAK_DB:.1f} dB")


if __name__ == "__main__":
    main()
