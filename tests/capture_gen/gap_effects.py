#!/usr/bin/env python3
"""Independent generator of sim-to-real gap effects on captures (candump -L, protocol v1).

It takes captures of the digital twin (e.g. `gearwatch simulate --physics twin`), adds ONE effect
drawn at random from textbook forms (or none), and writes the modified captures next to a
truth.json naming the form and its parameters in physical units. It is written from vibration
textbook formulas and the protocol document alone: it shares no code with gearwatch and was
written without reading the gap diagnosis's candidates or descriptive forms, so that
`gearwatch gap bench --generator independent` measures the diagnosis on forms it did not come from.
See docs/gap.md ("The independent effect generator") for every form and its parameters.

    gap_effects.py --in a.log b.log ... --out-dir DIR --seed N [--form NAME]
    gap_effects.py --self-test
"""

import argparse
import json
import math
import os
import sys

import numpy as np
from scipy import signal, special

VIBRATION_ID = 0x100      # channel 0 (can-protocol.md); channel c is 0x100 + c
TACHO_ID = 0x180          # the input shaft's tacho edges: u32 index, u32 fraction (/2^32)
HEADER_ID = 0x1F0         # u32 sample rate, u8 channels, u8 version, u16 stream id
CONDITION_ID = 0x1F1      # f32 torque, f32 speed (+ u32 index on FD)
FULL_SCALE = 32767

# The forms, in the order seeds cycle through them: seed s draws FORMS[s mod 9].
FORMS = ["none", "structural_resonance", "ghost_tone", "amplitude_modulation", "phase_modulation",
         "mount_resonance", "supply_tones", "floor_step", "path_tilt"]


class GeneratorError(Exception):
    pass


# ----------------------------------------------------------------------------------------------
# Captures: only the vibration frames' samples are rewritten; every other line is kept as it was.

class Capture:
    def __init__(self, path):
        self.path = path
        with open(path, "r", encoding="ascii") as f:
            self.lines = f.read().splitlines()
        self.rows, self.chunks = [], []   # line numbers of channel-0 frames and their samples
        edges, self.rate, self.speed, self.torque = [], None, None, None
        for n, line in enumerate(self.lines):
            parts = line.split()
            if len(parts) != 3 or "#" not in parts[2]:
                raise GeneratorError(f"{path}:{n + 1}: not a candump -L line")
            ident, data = parts[2].split("#", 1)
            ident = int(ident, 16)
            payload = bytes.fromhex(data[2:] if data.startswith("#") else data)
            if ident == VIBRATION_ID:
                self.rows.append(n)
                self.chunks.append(np.frombuffer(payload[4:], dtype="<i2").astype(np.int64))
            elif ident == TACHO_ID:
                edges.append(int.from_bytes(payload[0:4], "little") + int.from_bytes(payload[4:8], "little") / 2**32)
            elif ident == HEADER_ID and self.rate is None:
                self.rate = int.from_bytes(payload[0:4], "little")
            elif ident == CONDITION_ID and self.speed is None:
                self.torque, self.speed = (float(v) for v in np.frombuffer(payload[0:8], dtype="<f4"))
        if not self.rows or self.rate is None or self.speed is None:
            raise GeneratorError(f"{path}: needs channel-0 vibration frames, a stream header and an operating condition")
        self.counts = [len(c) for c in self.chunks]
        self.samples = np.concatenate(self.chunks)
        self.edges = np.asarray(edges)

    def input_revolutions(self):
        """Input-shaft revolutions at every sample: the tacho edges (one per revolution) joined
        linearly, extended at the ends at the nominal speed."""
        n = np.arange(len(self.samples), dtype=float)
        if len(self.edges) < 2:
            return n * self.speed / self.rate
        revs = np.arange(len(self.edges), dtype=float)
        theta = np.interp(n, self.edges, revs)
        slope = self.speed / self.rate
        theta = np.where(n < self.edges[0], (n - self.edges[0]) * slope, theta)
        return np.where(n > self.edges[-1], revs[-1] + (n - self.edges[-1]) * slope, theta)

    def write(self, path, samples):
        out = list(self.lines)
        at = 0
        for row, count in zip(self.rows, self.counts):
            head, data = out[row].rsplit("#", 1)
            flags = data[0] if head.endswith("#") else ""
            hexdata = data[1:] if flags else data
            index = bytes.fromhex(hexdata[:8])
            body = samples[at:at + count].astype("<i2").tobytes()
            out[row] = head + "#" + flags + (index + body).hex().upper()
            at += count
        tmp = path + ".tmp"
        with open(tmp, "w", encoding="ascii") as f:
            f.write("\n".join(out) + "\n")
        os.replace(tmp, path)


def quantise(x, scale):
    q = np.round(x / scale)
    clipped = int(np.count_nonzero(np.abs(q) > FULL_SCALE))
    return np.clip(q, -FULL_SCALE, FULL_SCALE).astype(np.int64), clipped


# ----------------------------------------------------------------------------------------------
# Transfer functions, and the path model that applies them to a finite record.

def resonance_gain(f, fn, zeta, peak_gain):
    """A structural resonance added to the path: H = 1 + (g - 1) B, B the band-pass of a
    single-degree-of-freedom oscillator normalised to 1 at fn (B = j2ζr / (1 - r² + j2ζr))."""
    r = f / fn
    b = 2j * zeta * r / (1 - r**2 + 2j * zeta * r)
    return 1 + (peak_gain - 1) * b


def mount_transmissibility(f, fn, zeta):
    """Base-excitation transmissibility of a sensor on a compliant mount (SDOF):
    T = (1 + j2ζr) / (1 - r² + j2ζr)."""
    r = f / fn
    return (1 + 2j * zeta * r) / (1 - r**2 + 2j * zeta * r)


def tilt_gain(f, slope_db_per_octave, f_ref):
    """A transfer-path tilt: slope dB per octave about f_ref (gain 1 there), held below 10 Hz."""
    return 10 ** (slope_db_per_octave * np.log2(np.maximum(f, 10.0) / f_ref) / 20)


def filtered(x, fs, gain_of_f):
    """Circular filtering by one FFT over the record: right for noise, whose record has no edges
    to speak of, wrong for strong lines (see on_the_path)."""
    f = np.fft.rfftfreq(len(x), 1 / fs)
    return np.fft.irfft(np.fft.rfft(x) * gain_of_f(f), n=len(x))


# A stationary line stands this far (amplitude, dB) over the record's median Blackman-Harris level.
LINE_EXCESS_DB = 20.0
LINE_SEARCH_ROUNDS = 3
ZERO_PADDING = 16


def phasors(omega, n, sign):
    """exp(sign·i·ω·k) for k < n, one row per ω: the product of a coarse and a fine table, so that
    only about 2√n exponentials are taken per frequency."""
    block = int(math.sqrt(n)) + 1
    fine = np.exp(sign * 1j * np.outer(omega, np.arange(block)))
    coarse = np.exp(sign * 1j * np.outer(omega, np.arange(0, n, block)))
    return (coarse[:, :, None] * fine[:, None, :]).reshape(len(omega), -1)[:, :n]


def transform_and_derivatives(weighted, omega):
    """X(ω) = Σ_k w_k x_k e^(−iωk) and its first two derivatives in ω, at each ω."""
    n = len(weighted)
    k = np.arange(n, dtype=float)
    moments = np.stack([weighted, -1j * k * weighted, -(k * k) * weighted], axis=1)
    out = np.empty((len(omega), 3), dtype=complex)
    for i in range(0, len(omega), 16):
        out[i:i + 16] = phasors(omega[i:i + 16], n, -1) @ moments
    return out


def synthesised(omega, amp, n):
    """Σ Re(a·e^(iωk)) over the lines."""
    y = np.zeros(n)
    for i in range(0, len(omega), 16):
        y += (amp[i:i + 16, None] * phasors(omega[i:i + 16], n, 1)).real.sum(axis=0)
    return y


def fitted_lines(rest, window, omega):
    """Each peak moved to the top of |X|² by Newton steps, and its complex amplitude there."""
    weighted = rest * window
    for _ in range(3):
        d = transform_and_derivatives(weighted, omega)
        x0, x1, x2 = d[:, 0], d[:, 1], d[:, 2]
        slope = 2 * (np.conj(x0) * x1).real
        curvature = 2 * (np.abs(x1) ** 2 + (np.conj(x0) * x2).real)
        bin_width = 2 * np.pi / len(rest)
        step = np.where(curvature < 0, -slope / np.where(curvature < 0, curvature, -1), 0.0)
        omega = omega + np.clip(step, -0.5 * bin_width, 0.5 * bin_width)
    return omega, 2 * transform_and_derivatives(weighted, omega)[:, 0] / window.sum()


def spectral_lines(x):
    """The record's stationary lines as (angular frequency in rad/sample, complex amplitude), and
    what is left: the peaks of its zero-padded Blackman-Harris spectrum LINE_EXCESS_DB over the
    median level, each moved to the top of its peak and fitted; searched again on what is left, so
    that a strong line's sidelobes are never taken for lines."""
    n = len(x)
    window = signal.windows.blackmanharris(n, sym=False)
    lines_omega, lines_amp = np.empty(0), np.empty(0, dtype=complex)
    rest = x.copy()
    strongest = None
    for _ in range(LINE_SEARCH_ROUNDS):
        level = np.abs(np.fft.rfft(rest * window, n=ZERO_PADDING * n))
        k = np.arange(1, len(level) - 1)
        # Lines 90 dB under the strongest are under a 16-bit capture's rounding and would be
        # confused with its Blackman-Harris sidelobes (-92 dB): they are left to the FFT.
        strongest = level.max() if strongest is None else strongest
        threshold = max(np.median(level) * 10 ** (LINE_EXCESS_DB / 20), 10 ** (-90 / 20) * strongest)
        top = k[(level[k] > threshold) & (level[k] >= level[k - 1]) & (level[k] > level[k + 1])]
        # A line's main lobe spans ±4 bins: keep the highest peak in each lobe.
        top = top[np.argsort(level[top])[::-1]]
        kept = []
        for t in top:
            if all(abs(t - u) > 4 * ZERO_PADDING for u in kept):
                kept.append(t)
        if not kept:
            break
        kept = np.sort(np.asarray(kept))
        a, b, c = (np.log(level[kept + d]) for d in (-1, 0, 1))
        omega = 2 * np.pi * (kept + 0.5 * (a - c) / (a - 2 * b + c)) / (ZERO_PADDING * n)
        omega, amp = fitted_lines(rest, window, omega)
        rest = rest - synthesised(omega, amp, n)
        lines_omega, lines_amp = np.concatenate([lines_omega, omega]), np.concatenate([lines_amp, amp])
    return lines_omega, lines_amp, rest


def on_the_path(x, fs, gain_of_f):
    """The record as it reads through a linear transfer path H, taken as a window of a stationary
    signal: each stationary line comes out as its steady state, the line times H at its own
    frequency, and only what is left (noise) is filtered by FFT. Filtering the whole record by one
    FFT would act on its periodic extension, whose jump at the ends a narrow resonance rings at."""
    omega, amp, rest = spectral_lines(x)
    gain = gain_of_f(omega * fs / (2 * np.pi))
    return synthesised(omega, amp * gain, len(x)) + filtered(rest, fs, gain_of_f)


# ----------------------------------------------------------------------------------------------
# The forms. Each takes (x, fs, theta_in, context, params) and returns the modified x.

def read_between_samples(x, where, half_width=64, kaiser_beta=10.0):
    """x read at fractional sample positions `where` by band-limited interpolation (the sampling
    theorem's sinc, Kaiser-windowed over 2*half_width samples): a re-timed record keeps its lines'
    amplitudes up to near Nyquist, where a cubic spline between samples would lower them by a
    fraction-dependent amount. Samples beyond the record's ends are taken as its end samples."""
    base = np.floor(where).astype(np.int64)
    frac = where - base
    y = np.zeros(len(where))
    for k in range(-half_width + 1, half_width + 1):
        u = frac - k                                     # distance from sample base + k
        taper = np.i0(kaiser_beta * np.sqrt(np.clip(1 - (u / half_width) ** 2, 0, None))) / np.i0(kaiser_beta)
        y += x[np.clip(base + k, 0, len(x) - 1)] * np.sinc(u) * taper
    return y


def apply_effect(form, p, x, fs, theta, ctx):
    t = np.arange(len(x)) / fs
    if form == "none":
        return x.copy()
    if form == "structural_resonance":
        return on_the_path(x, fs, lambda f: resonance_gain(f, p["frequency_hz"], p["damping_ratio"], 10 ** (p["peak_gain_db"] / 20)))
    if form == "mount_resonance":
        return on_the_path(x, fs, lambda f: mount_transmissibility(f, p["frequency_hz"], p["damping_ratio"]))
    if form == "path_tilt":
        return on_the_path(x, fs, lambda f: tilt_gain(f, p["slope_db_per_octave"], p["reference_hz"]))
    if form == "ghost_tone":
        return x + p["amplitude_m_s2"] * np.cos(2 * np.pi * p["order"] * theta + p["phase_rad"])
    if form == "supply_tones":
        y = x.copy()
        for h, a, ph in zip(p["harmonics"], p["amplitudes_m_s2"], p["phases_rad"]):
            y += a * np.cos(2 * np.pi * h * p["frequency_hz"] * t + ph)
        return y
    if form == "amplitude_modulation":
        shaft = theta * ctx["shaft_ratio"][p["shaft"]]
        return x * (1 + p["index"] * np.cos(2 * np.pi * shaft + p["phase_rad"]))
    if form == "phase_modulation":
        # The mesh phase 2π z1 θ deviates by β sin(2π θ_shaft + φ): the angle is shifted by
        # β / (2π z1) revolutions; the record is read at the sample where the shaft is there.
        shaft = theta * ctx["shaft_ratio"][p["shaft"]]
        delta_revs = p["index_rad"] / (2 * np.pi * ctx["pinion_teeth"]) * np.sin(2 * np.pi * shaft + p["phase_rad"])
        where = np.arange(len(x), dtype=float) + delta_revs * fs / ctx["speed_hz"]
        return read_between_samples(x, where)
    if form == "floor_step":
        rng = np.random.default_rng(p["noise_seed"])
        noise = rng.standard_normal(len(x)) * math.sqrt(p["psd_m2_s4_per_hz"] * fs / 2)
        return x + filtered(noise, fs, lambda f: (f >= p["corner_hz"]).astype(float))
    raise GeneratorError(f"unknown form '{form}'")


def draw_parameters(form, rng, ctx):
    """Random parameters of one draw in physical units. ctx: fs, the speeds, the teeth, the
    records' RMS and the quantisation floor."""
    fs, nyq = ctx["fs"], ctx["fs"] / 2
    rms = ctx["rms_m_s2"]
    def db_to_amp(db):
        return rms * math.sqrt(2) * 10 ** (db / 20)   # peak amplitude of a tone db under the RMS
    if form == "none":
        return {}
    if form == "structural_resonance":
        # Between two mesh harmonics at the middle speed, narrow (10-40 Hz half-power bandwidth).
        gmf = ctx["pinion_teeth"] * float(np.median(ctx["speeds_hz"]))
        k = int(rng.integers(4, max(5, int(0.6 * nyq / gmf))))
        fn = (k + 0.5) * gmf
        bw = rng.uniform(10, 40)
        return {"frequency_hz": fn, "damping_ratio": bw / (2 * fn), "peak_gain_db": rng.uniform(8, 16),
                "half_power_bandwidth_hz": bw}
    if form == "mount_resonance":
        return {"frequency_hz": rng.uniform(0.45, 0.8) * nyq, "damping_ratio": rng.uniform(0.03, 0.1)}
    if form == "path_tilt":
        return {"slope_db_per_octave": float(rng.choice([-1, 1]) * rng.uniform(1, 3)), "reference_hz": 1000.0}
    if form == "ghost_tone":
        z1 = ctx["pinion_teeth"]
        while True:
            order = rng.uniform(2.2, 3 * z1)
            if 0.2 < order % 1 < 0.8:
                break
        level = rng.uniform(-25, -10)
        return {"order": order, "shaft": "input", "level_db_re_rms": level, "amplitude_m_s2": db_to_amp(level),
                "phase_rad": rng.uniform(0, 2 * np.pi)}
    if form == "supply_tones":
        f0 = float(rng.choice([50.0, 60.0]))
        level = rng.uniform(-30, -15)
        decay = rng.uniform(0.3, 0.7)
        harmonics = [1, 2, 3]
        amps = [db_to_amp(level) * decay ** (h - 1) for h in harmonics]
        return {"frequency_hz": f0, "harmonics": harmonics, "level_db_re_rms": level, "amplitudes_m_s2": amps,
                "phases_rad": [float(v) for v in rng.uniform(0, 2 * np.pi, 3)]}
    if form == "amplitude_modulation":
        return {"shaft": str(rng.choice(["input", "output"])), "index": rng.uniform(0.05, 0.3),
                "phase_rad": rng.uniform(0, 2 * np.pi)}
    if form == "phase_modulation":
        return {"shaft": str(rng.choice(["input", "output"])), "index_rad": rng.uniform(0.1, 0.8),
                "phase_rad": rng.uniform(0, 2 * np.pi)}
    if form == "floor_step":
        # The step is the rise of the written capture's floor above the corner over its floor below
        # it. Below the corner that floor is two roundings: the twin's capture was rounded once, and
        # rounding it again with the noise added (white over the whole band, however the noise is
        # filtered) adds a second; so the noise's PSD is (10^(step/10) - 1) times both.
        step = rng.uniform(10, 30)
        written_floor = 2 * ctx["floor_psd_m2_s4_per_hz"]
        return {"corner_hz": rng.uniform(0.1, 0.4) * nyq, "step_db": step,
                "psd_m2_s4_per_hz": written_floor * (10 ** (step / 10) - 1),
                "noise_seed": int(rng.integers(1, 2**31))}
    raise GeneratorError(f"unknown form '{form}'")


def context_of(captures, pinion_teeth, gear_teeth, scale):
    fs = captures[0].rate
    if any(c.rate != fs for c in captures):
        raise GeneratorError("the captures have different sample rates")
    x = np.concatenate([c.samples * scale for c in captures])
    return {"fs": fs, "speeds_hz": [c.speed for c in captures], "pinion_teeth": pinion_teeth, "gear_teeth": gear_teeth,
            "shaft_ratio": {"input": 1.0, "output": pinion_teeth / gear_teeth},
            "rms_m_s2": float(np.sqrt(np.mean(x**2))),
            # Uniform rounding error (scale²/12) spread evenly over 0..fs/2: the captures' own floor.
            "floor_psd_m2_s4_per_hz": scale**2 / 12 / (fs / 2)}


def jsonable(v):
    if isinstance(v, dict):
        return {k: jsonable(w) for k, w in v.items()}
    if isinstance(v, (list, tuple)):
        return [jsonable(w) for w in v]
    if isinstance(v, np.generic):
        return v.item()
    return v


def generate(args):
    captures = [Capture(p) for p in args.inputs]
    ctx = context_of(captures, args.pinion_teeth, args.gear_teeth, args.scale)
    form = args.form or FORMS[args.seed % len(FORMS)]
    rng = np.random.default_rng(args.seed)
    params = draw_parameters(form, rng, ctx)
    os.makedirs(args.out_dir, exist_ok=True)
    records = []
    for c in captures:
        y = apply_effect(form, params, c.samples * args.scale, ctx["fs"], c.input_revolutions(),
                         dict(ctx, speed_hz=c.speed))
        q, clipped = quantise(y, args.scale)
        out = os.path.join(args.out_dir, os.path.basename(c.path))
        c.write(out, q)
        records.append({"capture": out, "source": c.path, "speed_hz": c.speed, "torque_nm": c.torque, "clipped_samples": clipped})
    truth = {"seed": args.seed, "form": form, "parameters": params, "sample_rate_hz": ctx["fs"],
             "pinion_teeth": args.pinion_teeth, "gear_teeth": args.gear_teeth, "records": records,
             "rms_m_s2": ctx["rms_m_s2"]}
    with open(os.path.join(args.out_dir, "truth.json"), "w", encoding="ascii") as f:
        json.dump(jsonable(truth), f, indent=1)


# ----------------------------------------------------------------------------------------------
# Self-test: each form's parameters recovered in closed form from a synthetic signal.

def amplitude_at(x, fs, f):
    """Single-sided amplitude of the DFT bin at f (tones placed on bins)."""
    k = int(round(f * len(x) / fs))
    return 2 * abs(np.fft.rfft(x)[k]) / len(x)


def check(name, got, want, tol):
    if not abs(got - want) <= tol:
        raise GeneratorError(f"self-test {name}: got {got:.6g}, want {want:.6g} (tolerance {tol:g})")


def self_test():
    fs, n, speed, z1, z2 = 50000, 50000, 10.0, 19, 23
    t = np.arange(n) / fs
    theta = speed * t
    ctx = {"fs": fs, "shaft_ratio": {"input": 1.0, "output": z1 / z2}, "pinion_teeth": z1, "speed_hz": speed}
    carrier = np.cos(2 * np.pi * z1 * theta)   # the mesh at 190 Hz
    # Resonance on the path: a tone at fn comes out g times larger, one at fn(1 + ζ) by |H| there
    # (to 1e-6: the path model reads each line's frequency from the record).
    p = {"frequency_hz": 5000.0, "damping_ratio": 0.002, "peak_gain_db": 12.0}
    y = apply_effect("structural_resonance", p, np.cos(2 * np.pi * 5000 * t), fs, theta, ctx)
    check("resonance peak", amplitude_at(y, fs, 5000), 10 ** 0.6, 1e-6)
    y = apply_effect("structural_resonance", p, np.cos(2 * np.pi * 5010 * t), fs, theta, ctx)
    r = 5010 / 5000
    b = 0.004j * r / (1 - r * r + 0.004j * r)
    check("resonance flank", amplitude_at(y, fs, 5010), abs(1 + (10 ** 0.6 - 1) * b), 1e-6)
    # Mount: static gain 1, at fn 1/(2ζ) (to first order in ζ: |1 + j2ζ| / 2ζ).
    p = {"frequency_hz": 20000.0, "damping_ratio": 0.05}
    y = apply_effect("mount_resonance", p, np.cos(2 * np.pi * 20000 * t) + np.cos(2 * np.pi * 100 * t), fs, theta, ctx)
    check("mount at fn", amplitude_at(y, fs, 20000), math.sqrt(1 + 0.1**2) / 0.1, 1e-6)
    check("mount low", amplitude_at(y, fs, 100), abs((1 + 0.1j * 0.005) / (1 - 0.005**2 + 0.1j * 0.005)), 1e-6)
    # Tilt: 2 dB/octave over 3 octaves is 6 dB.
    p = {"slope_db_per_octave": 2.0, "reference_hz": 1000.0}
    y = apply_effect("path_tilt", p, np.cos(2 * np.pi * 1000 * t) + np.cos(2 * np.pi * 8000 * t), fs, theta, ctx)
    check("tilt", 20 * math.log10(amplitude_at(y, fs, 8000) / amplitude_at(y, fs, 1000)), 6.0, 1e-6)
    # Ghost tone at order 7.3 of the input shaft: 73 Hz at 10 Hz.
    p = {"order": 7.3, "amplitude_m_s2": 0.25, "phase_rad": 0.4}
    check("ghost tone", amplitude_at(apply_effect("ghost_tone", p, np.zeros(n), fs, theta, ctx), fs, 73), 0.25, 1e-9)
    # Supply tones: 50, 100, 150 Hz at their amplitudes.
    p = {"frequency_hz": 50.0, "harmonics": [1, 2, 3], "amplitudes_m_s2": [0.3, 0.15, 0.05], "phases_rad": [0, 1, 2]}
    y = apply_effect("supply_tones", p, np.zeros(n), fs, theta, ctx)
    for h, a in zip([1, 2, 3], [0.3, 0.15, 0.05]):
        check(f"supply {h}", amplitude_at(y, fs, 50 * h), a, 1e-9)
    # AM at the input shaft: sidebands at GMF ± speed of m/2 the carrier.
    p = {"shaft": "input", "index": 0.2, "phase_rad": 0.0}
    y = apply_effect("amplitude_modulation", p, carrier, fs, theta, ctx)
    check("AM index", 2 * amplitude_at(y, fs, 190 + 10) / amplitude_at(y, fs, 190), 0.2, 1e-9)
    # PM at the input shaft: sideband / carrier = J1(β) / J0(β) (Bessel expansion of cos(ωt + β sin)).
    p = {"shaft": "input", "index_rad": 0.5, "phase_rad": 0.0}
    y = apply_effect("phase_modulation", p, carrier, fs, theta, ctx)
    check("PM sideband", amplitude_at(y, fs, 200) / amplitude_at(y, fs, 190), special.jv(1, 0.5) / special.jv(0, 0.5), 1e-4)
    # The re-timing near Nyquist: a tone at f is delayed as the mesh is, so its index is β·f/f_mesh;
    # its carrier keeps J0 and each first sideband J1 of that index, at 0.40 and 0.46 of fs alike
    # (a spline between samples lowers them there by several per cent).
    p = {"shaft": "input", "index_rad": 0.005, "phase_rad": 0.0}
    for f in (20000.0, 23000.0):
        y = apply_effect("phase_modulation", p, np.cos(2 * np.pi * f * t), fs, theta, ctx)
        x = 0.005 * f / 190.0
        check(f"PM carrier at {f:.0f} Hz", amplitude_at(y[5000:-5000], fs, f), special.jv(0, x), 1e-3)
        check(f"PM sideband at {f:.0f} Hz", amplitude_at(y[5000:-5000], fs, f + 10), special.jv(1, x), 1e-3)
    # Floor step: Welch PSD above the corner at the drawn level, below it none.
    p = {"corner_hz": 10000.0, "psd_m2_s4_per_hz": 1e-4, "noise_seed": 3}
    y = apply_effect("floor_step", p, np.zeros(4 * n), fs, np.zeros(4 * n), ctx)
    f, psd = signal.welch(y, fs, nperseg=4096)
    check("floor level", float(np.mean(psd[(f > 12000) & (f < 24000)])) / 1e-4, 1.0, 0.03)
    check("floor below", float(np.mean(psd[(f > 1000) & (f < 8000)])) / 1e-4, 0.0, 1e-3)
    self_test_path_on_a_window()
    self_test_floor_step_as_written()
    self_test_capture_round_trip()
    print("gap_effects self-test: all checks passed")


def self_test_path_on_a_window():
    """A narrow resonance on the path of a stationary signal, read in a window. The truth: lines
    and white noise over a record six times as long, filtered by one FFT over all of it (its own
    ends ring far from the middle), the middle window kept. The path model on that window alone
    matches it: each line's amplitude within 1e-4 of the truth's, and the power at f_n over its
    surroundings (the lines removed by least squares at their known frequencies) within 1 dB, and
    its difference from the truth under 1e-3 of one FFT's over the window alone."""
    fs, n, fn, zeta, peak_db = 50000, 50000, 5000.7, 0.0015, 14.0
    rng = np.random.default_rng(7)
    freqs = 171.3 * np.arange(1, 41) + rng.uniform(-0.3, 0.3, 40)
    freqs[28] = fn - 33.0                                  # a strong line just under f_n
    amps = rng.uniform(0.1, 3.0, 40) * np.exp(2j * np.pi * rng.uniform(size=40))
    amps[28] = 3.0
    omega = 2 * np.pi * freqs / fs
    long = synthesised(omega, amps, 6 * n) + 1e-3 * rng.standard_normal(6 * n)
    gain = lambda f: resonance_gain(f, fn, zeta, 10 ** (peak_db / 20))
    middle = slice(5 * n // 2, 7 * n // 2)
    truth = filtered(long, fs, gain)[middle]
    window = long[middle]
    model, circular = on_the_path(window, fs, gain), filtered(window, fs, gain)
    k = np.arange(n)
    basis = np.concatenate([np.cos(np.outer(k, omega)), np.sin(np.outer(k, omega))], axis=1)
    coef = {name: np.linalg.lstsq(basis, y, rcond=None)[0] for name, y in (("truth", truth), ("model", model))}
    check("path model lines", float(np.max(np.abs(coef["model"] - coef["truth"]))) / 3.0, 0.0, 1e-4)

    def excess_db(y):
        r = y - basis @ np.linalg.lstsq(basis, y, rcond=None)[0]
        f = np.fft.rfftfreq(n, 1 / fs)
        p = np.abs(np.fft.rfft(r * np.hanning(n))) ** 2
        return 10 * math.log10(p[abs(f - fn) < 6].mean() / p[(f > fn + 60) & (f < fn + 200)].mean())
    check("path model at f_n", excess_db(model) - excess_db(truth), 0.0, 1.0)
    # The check has teeth: one FFT over the window alone is far from the truth.
    check("path model against one FFT", float(np.std(model - truth) / np.std(circular - truth)), 0.0, 1e-3)


def self_test_floor_step_as_written():
    """The drawn step_db is what the written capture shows: a capture rounded once (a mesh tone, no
    floor but its rounding), the step drawn and added, rounded again as generate() does; the floor
    above the corner over the floor below it (Welch, median of its segments' bins, the tones' bins
    away) is step_db within 0.3 dB, and each floor is its roundings' closed form within 5 %."""
    fs, n, scale = 50000, 400000, 0.01
    t = np.arange(n) / fs
    rounded = np.round(200 * np.cos(2 * np.pi * 190 * t) + 57 * np.cos(2 * np.pi * 3800 * t + 1))
    q = scale**2 / 12 / (fs / 2)
    ctx = {"fs": fs, "floor_psd_m2_s4_per_hz": q, "rms_m_s2": 1.0}
    p = draw_parameters("floor_step", np.random.default_rng(11), ctx)
    p["corner_hz"] = 12000.0
    y, _ = quantise(apply_effect("floor_step", p, rounded * scale, fs, None, ctx), scale)
    clean = (200 * np.cos(2 * np.pi * 190 * t) + 57 * np.cos(2 * np.pi * 3800 * t + 1)) * scale
    f, psd = signal.welch(y * scale - clean, fs, nperseg=4096, average="median")
    below = float(np.mean(psd[(f > 5000) & (f < 11000)]))
    above = float(np.mean(psd[(f > 13000) & (f < 24000)]))
    check("floor step as written", 10 * math.log10(above / below), p["step_db"], 0.3)
    check("floor below as written", below / (2 * q), 1.0, 0.05)
    check("floor above as written", above / (2 * q + p["psd_m2_s4_per_hz"]), 1.0, 0.05)


def self_test_capture_round_trip():
    """A small capture written by hand: decoding, the tacho angle and rewriting keep every other
    line and put the samples back exactly."""
    import tempfile
    fs, speed = 10000, 10.0
    lines = ["(1700000000.000000) can0 1F0#1027000001010100",
             "(1700000000.000000) can0 1F1##0" + np.array([20.0, speed], "<f4").tobytes().hex().upper() + "00000000"]
    x = (1000 * np.sin(np.arange(600) / 7)).astype(np.int64)
    for k in range(20):
        body = k.to_bytes(4, "little").hex() + x[30 * k:30 * k + 30].astype("<i2").tobytes().hex()
        lines.append(f"(1700000000.{k * 3000:06d}) can0 100##1{body.upper()}")
    lines.append("(1700000000.025000) can0 180#" + (250).to_bytes(4, "little").hex().upper() + (2**31).to_bytes(4, "little").hex().upper())
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "a.log")
        with open(path, "w") as f:
            f.write("\n".join(lines) + "\n")
        c = Capture(path)
        check("decoded samples", float(np.max(np.abs(c.samples - x))), 0.0, 0.0)
        check("decoded rate", c.rate, 10000, 0)
        check("decoded speed", c.speed, speed, 0)
        check("angle at the edge", float(c.input_revolutions()[250] - c.input_revolutions()[0]), 250 * speed / fs, 1e-12)
        c.write(os.path.join(d, "b.log"), x + 1)
        back = Capture(os.path.join(d, "b.log"))
        check("rewritten samples", float(np.max(np.abs(back.samples - (x + 1)))), 0.0, 0.0)
        same = [a == b for a, b in zip(c.lines, back.lines) if "100##" not in a]
        check("other lines kept", float(all(same) and len(c.lines) == len(back.lines)), 1.0, 0.0)


def main(argv):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--in", dest="inputs", nargs="+", help="captures of the twin (channel 0 is modified)")
    p.add_argument("--out-dir", help="where the modified captures and truth.json go")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--form", choices=FORMS, help="the form (default FORMS[seed mod 9])")
    p.add_argument("--pinion-teeth", type=int, default=19)
    p.add_argument("--gear-teeth", type=int, default=52)
    p.add_argument("--scale", type=float, default=0.01, help="m/s2 per LSB")
    p.add_argument("--self-test", action="store_true")
    args = p.parse_args(argv)
    try:
        if args.self_test:
            self_test()
            return 0
        if not args.inputs or not args.out_dir:
            raise GeneratorError("--in and --out-dir are required")
        generate(args)
        return 0
    except (GeneratorError, OSError, ValueError) as e:
        print(f"gap_effects: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
