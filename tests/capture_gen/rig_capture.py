#!/usr/bin/env python3
"""Independent generator of rig CAN protocol v1 captures (candump -L logs) with known content.

Written from the protocol document alone, so that end-to-end tests drive gearwatch with traffic
it did not produce itself. One capture per call; --json-summary writes the exact facts a
receiver must find in it (frames per id, samples per channel, tacho edges, life-counter values,
gaps, streams) and the analytic ICS2 of every amplitude-modulated noise component.
See docs/capture-gen.md for every option and the derivation of the closed form.
"""

import argparse
import hashlib
import json
import math
import sys

import numpy as np

# Protocol v1 default identifiers (can-protocol.md, "Frames").
VIBRATION_BASE_ID = 0x100
TACHO_BASE_ID = 0x180
STREAM_HEADER_ID = 0x1F0
OPERATING_CONDITION_ID = 0x1F1
LIFE_COUNTER_ID = 0x1F2
PROTOCOL_VERSION = 1

FD_SAMPLES_PER_FRAME = 30        # 64-byte FD payload: u32 + 30 x i16
CLASSIC_SAMPLES_PER_FRAME = 2    # 8-byte classic payload: u32 + 2 x i16
FULL_SCALE = 32767               # clipping is symmetric: -32768 is never produced
INDEX_MODULUS = 1 << 32

# Order of frames sharing one position on the sample clock: the samples that end there come
# first, then the stream header, the operating condition and the life counter that accounts for
# them; a tacho edge exactly on that position belongs after them (it is not yet counted).
PRIORITY_SAMPLES, PRIORITY_HEADER, PRIORITY_CONDITION, PRIORITY_LIFE, PRIORITY_TACHO = range(5)

HEX_DIGITS = np.frombuffer(b"0123456789ABCDEF", dtype=np.uint8)


class GeneratorError(Exception):
    pass


# ----------------------------------------------------------------------------------------------
# Command line

def parse_pair(text, what, second=float):
    try:
        left, right = text.split(":", 1)
        return int(left), second(right)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"{what}: expected CHANNEL:VALUE, got '{text}'") from exc


def parse_am_noise(text):
    try:
        low, high, std, depth = (float(v) for v in text.split(":"))
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"--am-noise: expected LOW:HIGH:STD:DEPTH, got '{text}'") from exc
    if not (0 <= low < high) or std < 0 or depth < 0:
        raise argparse.ArgumentTypeError(f"--am-noise: need 0 <= LOW < HIGH, STD >= 0, DEPTH >= 0, got '{text}'")
    return {"low_hz": low, "high_hz": high, "std": std, "depth": depth}


def parse_gap(text):
    try:
        start, samples = text.split(":")
        return {"time_s": float(start), "samples": int(samples)}
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"--gap: expected T:SAMPLES, got '{text}'") from exc


def parse_second_stream(text):
    try:
        start, stream_id, first_index = text.split(":")
        return {"time_s": float(start), "stream_id": int(stream_id, 0), "first_index": int(first_index, 0)}
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"--second-stream: expected T:STREAM_ID:FIRST_INDEX, got '{text}'") from exc


def parse_float_list(text):
    try:
        return [float(v) for v in text.split(",") if v.strip()]
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"expected a comma-separated list of numbers, got '{text}'") from exc


def parse_channel_list(text):
    try:
        channels = [int(v) for v in text.split(",") if v.strip()]
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"--channels: expected e.g. 0,1, got '{text}'") from exc
    if not channels or len(set(channels)) != len(channels) or not all(0 <= c <= 7 for c in channels):
        raise argparse.ArgumentTypeError(f"--channels: distinct channels 0..7 needed, got '{text}'")
    return channels


def build_parser():
    p = argparse.ArgumentParser(
        description="Write one rig CAN protocol v1 capture (candump -L) of known content.")
    p.add_argument("--out", help="capture file to write (candump -L lines)")
    p.add_argument("--json-summary", help="write the expected facts of the capture here (JSON)")
    p.add_argument("--self-test", action="store_true", help="check the generator's own output and exit")
    p.add_argument("--duration", type=float, default=1.0, help="seconds of samples (rounded up to whole frames)")
    p.add_argument("--sample-rate", type=int, default=100000, help="Hz (u32 of the stream header)")
    p.add_argument("--speed", type=float, default=10.0, help="input shaft speed, Hz (constant)")
    p.add_argument("--torque", type=float, default=20.0, help="input torque, N·m (operating-condition frame)")
    p.add_argument("--pinion-teeth", type=int, default=19, help="gear-mesh frequency = teeth x speed")
    p.add_argument("--scale", type=float, default=0.01,
                   help="physical units (m/s²) per LSB of the i16 samples, as [[channels]].scale of the config")
    p.add_argument("--channels", type=parse_channel_list, default=[0, 1], help="vibration channels sent, e.g. 0,1")
    p.add_argument("--header-channels", type=int, help="channel_count announced by the stream header (default: channels sent)")
    p.add_argument("--stream-id", type=lambda s: int(s, 0), default=1, help="u16 stream id")
    p.add_argument("--first-index", type=lambda s: int(s, 0), default=0, help="u32 index of the first sample")
    p.add_argument("--start-revs", type=int, default=0, help="life counter (input revolutions) at the first sample")
    p.add_argument("--tacho-phase", type=float, default=0.31415926535,
                   help="revolutions from the first sample to the first tacho edge, in [0, 1)")
    p.add_argument("--tacho-edges-per-rev", type=int, default=1,
                   help="tacho edges per revolution of the input shaft, evenly spaced from the first")
    p.add_argument("--no-tacho", action="store_true",
                   help="send no tacho frames (a recording with an accelerometer only)")
    p.add_argument("--tacho-rate-scale", type=float, default=1.0,
                   help="the tacho's edges come F times as often as the shaft's revolutions (a wrong "
                        "nameplate or a slipping belt: 1.0001 = 0.01 %% fast); the signal keeps the true angle")
    p.add_argument("--status-period", type=float, default=1.0,
                   help="at most this many seconds between stream header / operating condition / life counter frames (<= 1)")
    p.add_argument("--start-time", type=float, default=1700000000.0, help="log timestamp of the first sample (epoch s)")
    p.add_argument("--interface", default="can0", help="interface name written in the log")
    bus = p.add_mutually_exclusive_group()
    bus.add_argument("--fd", dest="fd", action="store_true", default=True, help="CAN FD, 30 samples per frame (default)")
    bus.add_argument("--classic", dest="fd", action="store_false", help="classic CAN, 2 samples per frame")
    p.add_argument("--seed", type=int, default=1, help="random seed: the same seed gives the same bytes")
    # Content (every channel; --channel-gain scales one).
    p.add_argument("--gmf-harmonics", type=parse_float_list, default=[],
                   help="peak amplitudes A1,A2,... of the gear-mesh harmonics, phase-locked to the tacho")
    p.add_argument("--am-noise", type=parse_am_noise, action="append", default=[],
                   help="LOW:HIGH:STD:DEPTH Gaussian noise in [LOW, HIGH] Hz times (1 + DEPTH cos 2π GMF t); repeatable")
    p.add_argument("--white-noise", type=float, default=0.0, help="std of white Gaussian noise (physical units)")
    p.add_argument("--channel-gain", type=lambda s: parse_pair(s, "--channel-gain"), action="append", default=[],
                   help="c:G multiplies channel c's signal by G; repeatable")
    # Faults.
    p.add_argument("--stop-channel", type=lambda s: parse_pair(s, "--stop-channel"), action="append", default=[],
                   help="c:T frames of channel c are not sent from time T on")
    p.add_argument("--flat-channel", type=lambda s: parse_pair(s, "--flat-channel"), action="append", default=[],
                   help="c:T channel c repeats its sample at time T from then on")
    p.add_argument("--saturate-channel", type=lambda s: parse_pair(s, "--saturate-channel"), action="append", default=[],
                   help="c:FRACTION that fraction of channel c's samples is set to ±32767")
    p.add_argument("--gap", type=parse_gap, action="append", default=[],
                   help="T:SAMPLES the frames of all channels covering SAMPLES samples from T are not sent; repeatable")
    p.add_argument("--second-stream", type=parse_second_stream, action="append", default=[],
                   help="T:STREAM_ID:FIRST_INDEX a new stream starts at T; tacho and life counter continue")
    # What the summary predicts for the ICS2 of the AM-noise components.
    p.add_argument("--ics2-harmonics", type=int, default=3, help="H of ICS2 (gearwatch's processing.ics2_harmonics)")
    p.add_argument("--ics2-tolerance-bins", type=int, default=3, help="± bins searched around each harmonic")
    p.add_argument("--ics2-analysis-seconds", type=float,
                   help="length of the analysed stretch for the predicted ICS2 scatter (default: the duration)")
    return p


# ----------------------------------------------------------------------------------------------
# ICS2 of amplitude-modulated noise: closed form, its numerical check, and the finite-length scatter

def squared_envelope_line_coefficients(depth):
    """Complex Fourier coefficients c_k of (1 + a cos ωt)², k = 0..2 (c_-k = c_k)."""
    return np.array([1.0 + depth * depth / 2.0, depth, depth * depth / 4.0])


def ics2_closed_form(depth, harmonics):
    """Σ_{h=1..H} |c_h|² / c_0²: (a² + a⁴/16) / (1 + a²/2)² for H >= 2."""
    c = squared_envelope_line_coefficients(depth)
    return float(sum(c[h] ** 2 for h in range(1, min(harmonics, 2) + 1)) / c[0] ** 2)


def ics2_closed_form_check(depth, harmonics):
    """The closed form against a direct computation: a carrier inside the band, modulated by
    (1 + a cos), its analytic signal by FFT, the DFT of the squared envelope, Eq. 4.3.
    A pure carrier has |analytic|² = 1, so this is the noise-free envelope. Returns |error|."""
    n, mod_bin, carrier_bin = 1 << 16, 64, 8000
    k = np.arange(n)
    x = (1.0 + depth * np.cos(2 * np.pi * mod_bin * k / n)) * np.cos(2 * np.pi * carrier_bin * k / n + 0.7)
    spectrum = np.fft.fft(x)
    spectrum[1:n // 2] *= 2.0
    spectrum[n // 2 + 1:] = 0.0
    envelope = np.abs(np.fft.ifft(spectrum)) ** 2
    ses = np.fft.fft(envelope) / n
    direct = sum(abs(ses[h * mod_bin]) ** 2 for h in range(1, harmonics + 1)) / abs(ses[0]) ** 2
    return abs(direct - ics2_closed_form(depth, harmonics))


def ics2_scatter_model(depth, bandwidth_hz, analysis_s, gmf_hz, harmonics, tolerance_bins, draws=20000):
    """Mean and standard deviation of ICS2 estimated from T = analysis_s seconds of AM noise.

    With n_a the analytic noise (E|n_a|² = P, bandwidth B, flat), the squared envelope is
    m²(t)·(P + w(t)), m² = Σ c_k e^{jkωt}. w = |n_a|² − P has the two-sided spectrum
    S_w(f) = (P²/B)(1 − |f|/B). On the analysis grid (bins of 1/T) the DFT of w is, for
    T·B >> 1, independent complex Gaussian W(b) with E|W(b)|² = S_w(b/T)/T, W(−b) = conj W(b).
    SES at bin hK + d (K = GMF·T) is P c_h [d = 0] + Σ_k c_k W((h − k)K + d); ICS2 takes the
    largest |SES|² within ±tolerance of each harmonic, as gearwatch does. This draws that
    Gaussian model (a fixed internal seed, so the prediction is deterministic)."""
    c = squared_envelope_line_coefficients(depth)
    coeff = {k: c[abs(k)] for k in range(-2, 3)}
    bins_per_gmf = int(round(gmf_hz * analysis_s))
    offsets = range(-tolerance_bins, tolerance_bins + 1)
    cells = [(0, 0)] + [(h, d) for h in range(1, harmonics + 1) for d in offsets]
    needed = sorted({abs((h - k) * bins_per_gmf + d) for h, d in cells for k in coeff})
    column = {b: i for i, b in enumerate(needed)}
    freq = np.array(needed, dtype=float) / analysis_s
    variance = np.clip(1.0 - freq / bandwidth_hz, 0.0, None) / bandwidth_hz / analysis_s  # P = 1
    rng = np.random.default_rng(20240607)
    w = (rng.standard_normal((draws, len(needed))) + 1j * rng.standard_normal((draws, len(needed)))) * np.sqrt(variance / 2)
    if needed[0] == 0:
        w[:, 0] = rng.standard_normal(draws) * np.sqrt(variance[0])  # the DC bin of a real signal is real

    def ses(h, d):
        value = np.full(draws, coeff.get(h, 0.0) if d == 0 else 0.0, dtype=complex)
        for k, ck in coeff.items():
            b = (h - k) * bins_per_gmf + d
            term = w[:, column[abs(b)]]
            value += ck * (term if b >= 0 else np.conj(term))
        return value

    dc = ses(0, 0).real
    total = np.zeros(draws)
    for h in range(1, harmonics + 1):
        total += np.max(np.stack([np.abs(ses(h, d)) ** 2 for d in offsets]), axis=0)
    ics2 = total / dc ** 2
    return float(ics2.mean()), float(ics2.std(ddof=1))


# ----------------------------------------------------------------------------------------------
# Signal

def band_limited_gaussian(rng, n, sample_rate, low_hz, high_hz, std):
    """Stationary Gaussian noise of variance std² with a flat spectrum on the FFT bins in
    [low, high] (brick wall; DC and Nyquist excluded), drawn in the frequency domain.
    For x = irfft(X), var x = 2 Σ E|X_k|² / n², hence the scale."""
    bins = np.arange(n // 2 + 1)
    freq = bins * sample_rate / n
    in_band = (freq >= low_hz) & (freq <= high_hz) & (bins > 0)
    if n % 2 == 0:
        in_band &= bins < n // 2
    count = int(in_band.sum())
    if count == 0:
        raise GeneratorError(f"--am-noise band [{low_hz}, {high_hz}] Hz holds no frequency bin")
    spectrum = np.zeros(n // 2 + 1, dtype=complex)
    spectrum[in_band] = rng.standard_normal(count) + 1j * rng.standard_normal(count)
    spectrum *= std * n / (2.0 * math.sqrt(count))
    return np.fft.irfft(spectrum, n), count * sample_rate / n


def channel_signals(args, n, shaft_angle_revs):
    """Physical signal of every channel (before quantisation) and the AM-noise bandwidths."""
    gmf_phase = 2 * np.pi * args.pinion_teeth * shaft_angle_revs
    common = np.zeros(n)
    for h, amplitude in enumerate(args.gmf_harmonics, start=1):
        if amplitude:
            common += amplitude * np.cos(h * gmf_phase)
    modulation_cos = np.cos(gmf_phase) if args.am_noise else None
    gains = dict(args.channel_gain)
    signals, bandwidths = {}, {}
    for c in args.channels:
        x = common.copy()
        for i, comp in enumerate(args.am_noise):
            rng = np.random.default_rng([args.seed, c, 1, i])
            noise, bandwidths[i] = band_limited_gaussian(rng, n, args.sample_rate, comp["low_hz"], comp["high_hz"], comp["std"])
            x += (1.0 + comp["depth"] * modulation_cos) * noise
        if args.white_noise > 0:
            x += np.random.default_rng([args.seed, c, 2]).standard_normal(n) * args.white_noise
        signals[c] = x * gains.get(c, 1.0)
    return signals, bandwidths


def quantise(x, scale):
    q = np.rint(x / scale)
    clipped = int(np.count_nonzero(np.abs(q) > FULL_SCALE))
    return np.clip(q, -FULL_SCALE, FULL_SCALE).astype(np.int16), clipped


# ----------------------------------------------------------------------------------------------
# candump -L lines, built as fixed-width byte rows (one numpy row per frame)

def decimal_digits(values, width):
    powers = 10 ** np.arange(width - 1, -1, -1, dtype=np.int64)
    return ((values[:, None] // powers) % 10 + ord("0")).astype(np.uint8)


def hex_digits(values, width):
    shifts = 4 * np.arange(width - 1, -1, -1, dtype=np.int64)
    return HEX_DIGITS[(values[:, None] >> shifts) & 0xF]


def candump_rows(time_us, can_id, payload, fd, interface):
    """Lines `(sec.usec) iface ID#HEX` (classic) or `ID##1HEX` (FD, bit-rate switch) for frames of
    equal payload length, as a numpy bytes array of one line per element."""
    rows = len(time_us)
    if rows == 0:
        return np.empty(0, dtype="S1")
    payload = np.ascontiguousarray(payload, dtype=np.uint8).reshape(rows, -1)
    length = payload.shape[1]
    iface = interface.encode()
    separator = b"##1" if fd else b"#"
    prefix_len = 1 + 10 + 1 + 6 + 2 + len(iface) + 1
    width = prefix_len + 3 + len(separator) + 2 * length + 1
    out = np.empty((rows, width), dtype=np.uint8)
    time_us = np.asarray(time_us, dtype=np.int64)
    out[:, 0] = ord("(")
    out[:, 1:11] = decimal_digits(time_us // 1_000_000, 10)
    out[:, 11] = ord(".")
    out[:, 12:18] = decimal_digits(time_us % 1_000_000, 6)
    out[:, 18:20] = np.frombuffer(b") ", dtype=np.uint8)
    out[:, 20:20 + len(iface)] = np.frombuffer(iface, dtype=np.uint8)
    out[:, prefix_len - 1] = ord(" ")
    out[:, prefix_len:prefix_len + 3] = hex_digits(np.broadcast_to(np.asarray(can_id, dtype=np.int64), (rows,)), 3)
    col = prefix_len + 3
    out[:, col:col + len(separator)] = np.frombuffer(separator, dtype=np.uint8)
    col += len(separator)
    out[:, col:col + 2 * length:2] = HEX_DIGITS[payload >> 4]
    out[:, col + 1:col + 2 * length:2] = HEX_DIGITS[payload & 0xF]
    out[:, -1] = ord("\n")
    return out.view(f"S{width}").reshape(rows)


# ----------------------------------------------------------------------------------------------
# The capture

def frame_boundary(time_s, sample_rate, per_frame, total):
    """A time as a sample position, rounded down to the frame grid and kept inside the capture."""
    k = int(math.floor(time_s * sample_rate + 1e-9))
    return min(max(k // per_frame * per_frame, 0), total)


def validate(args):
    if args.sample_rate <= 0 or args.sample_rate >= INDEX_MODULUS:
        raise GeneratorError("--sample-rate must be a positive u32")
    if args.duration <= 0 or args.speed <= 0 or args.scale <= 0 or args.pinion_teeth <= 0:
        raise GeneratorError("--duration, --speed, --scale and --pinion-teeth must be positive")
    if not 0 <= args.tacho_phase < 1:
        raise GeneratorError("--tacho-phase must be in [0, 1)")
    if args.tacho_edges_per_rev < 1:
        raise GeneratorError("--tacho-edges-per-rev must be at least 1")
    if not 0.5 < args.tacho_rate_scale < 2.0:
        raise GeneratorError("--tacho-rate-scale must be in (0.5, 2)")
    if not 0 < args.status_period <= 1:
        raise GeneratorError("--status-period must be in (0, 1] s: the protocol wants these frames at least once a second")
    if not 0 <= args.first_index < INDEX_MODULUS or not 0 <= args.stream_id < (1 << 16):
        raise GeneratorError("--first-index must be a u32 and --stream-id a u16")
    if args.start_revs < 0 or args.start_revs >= (1 << 64):
        raise GeneratorError("--start-revs must be a u64")
    header_channels = len(args.channels) if args.header_channels is None else args.header_channels
    if not 0 <= header_channels <= 255:
        raise GeneratorError("--header-channels must be a u8")
    for what, pairs in (("--channel-gain", args.channel_gain), ("--stop-channel", args.stop_channel),
                        ("--flat-channel", args.flat_channel), ("--saturate-channel", args.saturate_channel)):
        for c, _ in pairs:
            if c not in args.channels:
                raise GeneratorError(f"{what}: channel {c} is not among --channels")
    for _, fraction in args.saturate_channel:
        if not 0 <= fraction <= 1:
            raise GeneratorError("--saturate-channel: FRACTION must be in [0, 1]")
    for g in args.gap:
        if g["samples"] <= 0 or g["time_s"] < 0:
            raise GeneratorError("--gap: T >= 0 and SAMPLES > 0 needed")
    for s in args.second_stream:
        if not 0 <= s["first_index"] < INDEX_MODULUS or not 0 <= s["stream_id"] < (1 << 16) or s["time_s"] <= 0:
            raise GeneratorError("--second-stream: T > 0, a u16 stream id and a u32 first index needed")
    if args.ics2_harmonics < 1 or args.ics2_tolerance_bins < 0:
        raise GeneratorError("--ics2-harmonics >= 1 and --ics2-tolerance-bins >= 0 needed")
    return header_channels


def generate(args):
    """Builds the capture; returns (bytes of the log, summary dict)."""
    header_channels = validate(args)
    fs = args.sample_rate
    per_frame = FD_SAMPLES_PER_FRAME if args.fd else CLASSIC_SAMPLES_PER_FRAME
    # Whole frames only (an FD frame cannot carry an arbitrary sample count): round up.
    n = -(-int(math.ceil(args.duration * fs - 1e-9)) // per_frame) * per_frame
    samples_per_rev = fs / args.speed
    gmf_hz = args.pinion_teeth * args.speed

    # Shaft angle in revolutions since the first tacho edge: the edges sit at integer angles.
    k = np.arange(n)
    angle = k / samples_per_rev - args.tacho_phase
    signals, bandwidths = channel_signals(args, n, angle)
    del angle

    samples, clipped = {}, {}
    for c in args.channels:
        samples[c], clipped[c] = quantise(signals.pop(c), args.scale)
    saturated = {}
    for c, fraction in args.saturate_channel:
        count = int(round(fraction * n))
        where = np.random.default_rng([args.seed, c, 3]).choice(n, size=count, replace=False)
        samples[c][where] = np.where(samples[c][where] < 0, -FULL_SCALE, FULL_SCALE)
        saturated[c] = where
    flat = {}
    for c, t in args.flat_channel:
        start = min(max(int(math.floor(t * fs + 1e-9)), 0), n - 1)
        samples[c][start:] = samples[c][start]
        flat[c] = {"start_sample": start, "value": int(samples[c][start])}

    # Streams: segments of the sample clock, each with its own id and index origin.
    streams = [{"stream_id": args.stream_id, "first_index": args.first_index, "start_sample": 0}]
    for s in sorted(args.second_stream, key=lambda s: s["time_s"]):
        start = frame_boundary(s["time_s"], fs, per_frame, n)
        if start <= streams[-1]["start_sample"] or start >= n:
            raise GeneratorError(f"--second-stream at {s['time_s']} s does not fall after the previous stream, inside the capture")
        streams.append({"stream_id": s["stream_id"], "first_index": s["first_index"], "start_sample": start})
    for i, s in enumerate(streams):
        s["end_sample"] = streams[i + 1]["start_sample"] if i + 1 < len(streams) else n
    segment_starts = np.array([s["start_sample"] for s in streams])

    def stream_of(position):
        return np.searchsorted(segment_starts, position, side="right") - 1

    def index_of(sample):
        seg = stream_of(sample)
        origin = np.array([s["first_index"] for s in streams], dtype=np.int64)[seg]
        return (origin + sample - segment_starts[seg]) % INDEX_MODULUS

    # Frame grid: frame j carries samples [j·per_frame, (j+1)·per_frame); stream starts are on it.
    frame_start = np.arange(0, n, per_frame)
    dropped_all = np.zeros(len(frame_start), dtype=bool)
    gaps = []
    for g in args.gap:
        start = frame_boundary(g["time_s"], fs, per_frame, n)
        hit = (frame_start >= start) & (frame_start < start + g["samples"])
        if not hit.any():
            raise GeneratorError(f"--gap at {g['time_s']} s lies outside the capture")
        first, last = frame_start[hit][0], frame_start[hit][-1] + per_frame
        gaps.append({"start_sample": int(first), "samples": int(last - first), "first_missing_index": int(index_of(first)),
                     "stream_id": streams[int(stream_of(first))]["stream_id"]})
        dropped_all |= hit
    stopped = {c: frame_boundary(t, fs, per_frame, n) for c, t in args.stop_channel}

    positions, priorities, order, rows = [], [], [], []
    frames_by_id, samples_sent = {}, {}

    def add(rows_, pos, priority, seq, can_id, count):
        rows.append(rows_)
        positions.append(np.asarray(pos, dtype=float))
        priorities.append(np.full(len(rows_), priority))
        order.append(np.asarray(seq))
        frames_by_id[f"0x{can_id:03X}"] = frames_by_id.get(f"0x{can_id:03X}", 0) + count

    def time_us(pos):
        return int(round(args.start_time * 1e6)) + np.rint(np.asarray(pos, dtype=float) * 1e6 / fs).astype(np.int64)

    # Vibration frames, stamped when their last sample is complete.
    frame_dtype = np.dtype([("index", "<u4"), ("samples", "<i2", (per_frame,))])
    for rank, c in enumerate(args.channels):
        sent = ~dropped_all
        if c in stopped:
            sent &= frame_start < stopped[c]
        starts = frame_start[sent]
        payload = np.empty(len(starts), dtype=frame_dtype)
        payload["index"] = index_of(starts)
        payload["samples"] = samples[c].reshape(-1, per_frame)[sent]
        end = starts + per_frame
        add(candump_rows(time_us(end), VIBRATION_BASE_ID + c, payload.view(np.uint8), args.fd, args.interface),
            end, PRIORITY_SAMPLES, np.full(len(starts), rank), VIBRATION_BASE_ID + c, len(starts))
        samples_sent[c] = int(len(starts) * per_frame)
        if c in saturated:
            saturated[c] = {"samples": len(saturated[c]), "sent": int(np.count_nonzero(sent[saturated[c] // per_frame]))}

    # Tacho edges of the input shaft (shaft 0, E per revolution: edge j at angle j / E), at
    # fractional sample positions.
    # With --tacho-rate-scale F the edges are those of a shaft turning F times as fast.
    per_rev = args.tacho_edges_per_rev
    edge_rev = samples_per_rev / args.tacho_rate_scale
    edge_count = int(math.floor(((n - 1) / edge_rev - args.tacho_phase) * per_rev)) + 1 if (n - 1) / edge_rev >= args.tacho_phase else 0
    if args.no_tacho:
        edge_count = 0
    edge_pos = (np.arange(edge_count) / per_rev + args.tacho_phase) * edge_rev
    edge_whole = np.floor(edge_pos).astype(np.int64)
    edge_frac = np.minimum(np.floor((edge_pos - edge_whole) * INDEX_MODULUS), INDEX_MODULUS - 1).astype(np.uint64)
    tacho = np.empty(edge_count, dtype=[("index", "<u4"), ("frac", "<u4")])
    tacho["index"] = index_of(edge_whole)
    tacho["frac"] = edge_frac
    add(candump_rows(time_us(edge_pos), TACHO_BASE_ID, tacho.view(np.uint8), args.fd, args.interface),
        edge_pos, PRIORITY_TACHO, np.zeros(edge_count), TACHO_BASE_ID, edge_count)

    # Stream header, operating condition and life counter: at the start of every stream and then
    # every whole number of frames not longer than the status period, so that they sit on the frame
    # grid: the life counter then counts exactly the edges before the first sample not yet sent.
    period = max(1, int(math.floor(args.status_period * fs + 1e-9)) // per_frame) * per_frame
    status = np.concatenate([np.arange(s["start_sample"], s["end_sample"], period) for s in streams])
    status_stream = stream_of(status)
    header = np.empty(len(status), dtype=[("rate", "<u4"), ("channels", "u1"), ("version", "u1"), ("stream", "<u2")])
    header["rate"], header["channels"], header["version"] = fs, header_channels, PROTOCOL_VERSION
    header["stream"] = [streams[s]["stream_id"] for s in status_stream]
    add(candump_rows(time_us(status), STREAM_HEADER_ID, header.view(np.uint8), args.fd, args.interface),
        status, PRIORITY_HEADER, np.zeros(len(status)), STREAM_HEADER_ID, len(status))
    # Classic frames hold 8 bytes: the optional index of the operating condition only fits on FD.
    condition_fields = [("torque", "<f4"), ("speed", "<f4")] + ([("index", "<u4")] if args.fd else [])
    condition = np.empty(len(status), dtype=condition_fields)
    condition["torque"], condition["speed"] = args.torque, args.speed
    if args.fd:
        condition["index"] = index_of(status)
    add(candump_rows(time_us(status), OPERATING_CONDITION_ID, condition.view(np.uint8), args.fd, args.interface),
        status, PRIORITY_CONDITION, np.zeros(len(status)), OPERATING_CONDITION_ID, len(status))
    # Whole revolutions: every E-th edge (0, E, 2E, ...) strictly before the position completes one.
    life_values = [args.start_revs + (int(e) + per_rev - 1) // per_rev for e in np.searchsorted(edge_pos, status, side="left")]
    life = np.array(life_values, dtype="<u8")
    add(candump_rows(time_us(status), LIFE_COUNTER_ID, life.view(np.uint8), args.fd, args.interface),
        status, PRIORITY_LIFE, np.zeros(len(status)), LIFE_COUNTER_ID, len(status))

    lines = np.concatenate(rows)
    sort = np.lexsort((np.concatenate(order), np.concatenate(priorities), np.concatenate(positions)))
    log = b"".join(lines[sort].tolist())

    summary = {
        "protocol_version": PROTOCOL_VERSION,
        "fd": args.fd,
        "sample_rate_hz": fs,
        "samples_per_frame": per_frame,
        "samples_generated": n,
        "duration_s": n / fs,
        "speed_hz": args.speed,
        "torque_nm": args.torque,
        "gmf_hz": gmf_hz,
        "scale": args.scale,
        "channels": args.channels,
        "header_channels": header_channels,
        "frames_total": int(sum(frames_by_id.values())),
        "frames_by_id": frames_by_id,
        "samples_per_channel": {str(c): samples_sent[c] for c in args.channels},
        "samples_total": int(sum(samples_sent.values())),
        "clipped_samples": {str(c): clipped[c] for c in args.channels},
        "saturated_samples": {str(c): v for c, v in saturated.items()},
        "flat_channels": {str(c): v for c, v in flat.items()},
        "stopped_channels": {str(c): {"start_sample": v} for c, v in stopped.items()},
        "gaps": gaps,
        "streams": streams,
        "tacho_edges": edge_count,
        "tacho_edges_per_rev": per_rev,
        "tacho_first_edge_sample": float(edge_pos[0]) if edge_count else None,
        "status_samples": [int(s) for s in status],
        "life_counter_values": life_values,
        "gmf_harmonics": args.gmf_harmonics,
        "am_noise": [],
    }
    analysis_s = args.ics2_analysis_seconds or n / fs
    for i, comp in enumerate(args.am_noise):
        closed = ics2_closed_form(comp["depth"], args.ics2_harmonics)
        check = ics2_closed_form_check(comp["depth"], args.ics2_harmonics)
        if check > 1e-10 * max(closed, 1e-3):
            raise GeneratorError(f"ICS2 closed form disagrees with the direct envelope computation by {check}")
        mean, std = ics2_scatter_model(comp["depth"], bandwidths[i], analysis_s, gmf_hz,
                                       args.ics2_harmonics, args.ics2_tolerance_bins)
        summary["am_noise"].append(dict(comp, bandwidth_hz=bandwidths[i], ics2_closed_form=closed,
                                        ics2_closed_form_check_error=check, ics2_analysis_s=analysis_s,
                                        ics2_predicted_mean=mean, ics2_predicted_std=std))
    return log, summary


def write_outputs(args):
    log, summary = generate(args)
    with open(args.out, "wb") as f:
        f.write(log)
    if args.json_summary:
        with open(args.json_summary, "w") as f:
            json.dump(summary, f, indent=1)
            f.write("\n")


# ----------------------------------------------------------------------------------------------
# Self-test: decode the generator's own output frame by frame (a separate, line-by-line reader)

def read_capture(log):
    """Parses candump -L lines into (time_us, id, fd, payload bytes)."""
    frames = []
    for line in log.decode().splitlines():
        stamp, iface, frame = line.split(" ")
        assert stamp[0] == "(" and stamp[-1] == ")" and stamp[11] == "." and len(stamp) == 19, line
        time = int(stamp[1:11]) * 1_000_000 + int(stamp[12:18])
        if "##" in frame:
            ident, rest = frame.split("##")
            assert rest[0] == "1", line
            data = bytes.fromhex(rest[1:])
            assert len(data) in (0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64), line
            fd = True
        else:
            ident, rest = frame.split("#")
            data = bytes.fromhex(rest)
            assert len(data) <= 8, line
            fd = False
        assert len(ident) == 3, line
        frames.append((time, int(ident, 16), fd, data))
    return frames


def self_test_args(extra):
    return build_parser().parse_args(["--out", "unused"] + extra)


def self_test():
    checks = 0

    def check(condition, message):
        nonlocal checks
        checks += 1
        if not condition:
            raise AssertionError(message)

    def decode(extra):
        log, summary = generate(self_test_args(extra))
        frames = read_capture(log)
        times = [f[0] for f in frames]
        check(times == sorted(times), "timestamps must not go backwards")
        by_id = {}
        for f in frames:
            by_id.setdefault(f[1], []).append(f)
        counted = {f"0x{i:03X}": len(v) for i, v in by_id.items()}
        check(counted == {k: v for k, v in summary["frames_by_id"].items() if v}, f"frames per id {counted} vs summary")
        return frames, by_id, summary

    def vib(frame):
        first = int.from_bytes(frame[3][:4], "little")
        return first, np.frombuffer(frame[3][4:], dtype="<i2")

    # 1. A clean FD capture: counts, contiguous indices across the u32 wrap, the first frame a header.
    fs, speed = 20000, 10.0
    frames, by_id, s = decode(["--duration", "2.5", "--sample-rate", str(fs), "--speed", str(speed),
                               "--first-index", str(INDEX_MODULUS - 1000), "--start-revs", "5000000000",
                               "--gmf-harmonics", "5,2.5", "--channels", "0,1"])
    check(frames[0][1] == STREAM_HEADER_ID, "the stream header comes first")
    check(all(f[2] for f in frames), "--fd writes FD frames only")
    check(s["samples_generated"] == 50010, "whole frames only, rounded up")
    for c in (0, 1):
        idx = [vib(f)[0] for f in by_id[VIBRATION_BASE_ID + c]]
        expected = [(INDEX_MODULUS - 1000 + j * 30) % INDEX_MODULUS for j in range(len(idx))]
        check(idx == expected, "vibration indices advance by 30 and wrap at 2^32")
        check(len(idx) * 30 == s["samples_per_channel"][str(c)], "samples per channel")
    header = by_id[STREAM_HEADER_ID][0][3]
    check(header == (fs).to_bytes(4, "little") + bytes([2, 1]) + (1).to_bytes(2, "little"), "stream header layout")
    check(len(by_id[STREAM_HEADER_ID]) == 3, "a header at the start and twice more")
    cond = by_id[OPERATING_CONDITION_ID][1][3]
    torque, spd = np.frombuffer(cond[:8], dtype="<f4")
    check(len(cond) == 12 and torque == np.float32(20.0) and spd == np.float32(speed), "operating condition")
    # Status frames every 666 frames = 19 980 samples (the most whole frames in 1 s).
    check(s["status_samples"] == [0, 19980, 39960], f"status positions {s['status_samples']}")
    check(int.from_bytes(cond[8:], "little") == (INDEX_MODULUS - 1000 + 19980) % INDEX_MODULUS, "condition index")
    # Tacho: index + frac/2^32 relative to the first index equals (j + phase)·fs/speed.
    edges = [(int.from_bytes(f[3][:4], "little") - (INDEX_MODULUS - 1000)) % INDEX_MODULUS
             + int.from_bytes(f[3][4:], "little") / 2.0 ** 32 for f in by_id[TACHO_BASE_ID]]
    check(len(edges) == s["tacho_edges"] == 25, "one edge per revolution")
    check(max(abs(e - (j + 0.31415926535) * fs / speed) for j, e in enumerate(edges)) < 1e-6, "edge positions")
    lives = [int.from_bytes(f[3], "little") for f in by_id[LIFE_COUNTER_ID]]
    check(lives == [5000000000, 5000000010, 5000000020] == s["life_counter_values"], f"life counter {lives}")
    # Every life counter is preceded by exactly the edges it counts and the samples up to its position.
    seen_edges, samples_seen, status = 0, 0, iter(s["status_samples"])
    for f in frames:
        if f[1] == TACHO_BASE_ID:
            seen_edges += 1
        if f[1] == VIBRATION_BASE_ID:
            samples_seen += 30
        if f[1] == LIFE_COUNTER_ID:
            check(int.from_bytes(f[3], "little") == 5000000000 + seen_edges, "life counter after its edges")
            check(samples_seen == next(status), "life counter after the samples up to its position")
    # Content: mesh harmonics phase-locked to the tacho, at the requested amplitude.
    x = np.concatenate([vib(f)[1] for f in by_id[VIBRATION_BASE_ID]]).astype(float) * 0.01
    period = int(fs / speed)
    first_edge = int(math.ceil(edges[0]))
    revs = (len(x) - first_edge) // period
    seg = x[first_edge:first_edge + revs * period]
    spectrum = np.fft.rfft(seg) / len(seg) * 2
    for h, a in ((1, 5.0), (2, 2.5)):
        line = spectrum[h * 19 * revs]
        expected_phase = 2 * np.pi * h * 19 * (first_edge - edges[0]) / period
        check(abs(abs(line) - a) < 2e-3, f"harmonic {h} amplitude {abs(line)}")
        check(abs(np.angle(line * np.exp(-1j * expected_phase))) < 1e-3, f"harmonic {h} phase-locked to the tacho")

    # 2. Determinism: the same seed gives the same bytes, another seed other noise.
    base = ["--duration", "0.2", "--sample-rate", "20000", "--am-noise", "2000:5000:1:0.5", "--white-noise", "0.3"]
    digest = lambda extra: hashlib.sha256(generate(self_test_args(base + extra))[0]).hexdigest()
    check(digest(["--seed", "7"]) == digest(["--seed", "7"]), "same seed, same capture")
    check(digest(["--seed", "7"]) != digest(["--seed", "8"]), "another seed, another capture")

    # 3. Classic CAN, one channel, a header announcing more channels than are sent.
    frames, by_id, s = decode(["--classic", "--duration", "0.05", "--sample-rate", "10000", "--channels", "3",
                               "--header-channels", "2"])
    check(not any(f[2] for f in frames), "--classic writes classic frames only")
    check(all(len(f[3]) == 8 for f in frames), "classic payloads are 8 bytes (condition without index)")
    check(len(by_id[VIBRATION_BASE_ID + 3]) == 250 and s["samples_per_channel"]["3"] == 500, "2 samples per classic frame")
    check(by_id[STREAM_HEADER_ID][0][3][4] == 2, "header announces --header-channels")

    # 4. Faults: a gap, a stopped channel, a flat channel, saturation, a second stream.
    fs = 10000
    frames, by_id, s = decode(["--duration", "3", "--sample-rate", str(fs), "--channels", "0,1,2",
                               "--white-noise", "50", "--first-index", "100",
                               "--gap", "0.5:100", "--gap", "1.2:30", "--stop-channel", "2:2.0",
                               "--flat-channel", "1:0.25", "--saturate-channel", "0:0.01",
                               "--second-stream", "1.5:9:4000000000"])
    per_channel = {c: [vib(f) for f in by_id[VIBRATION_BASE_ID + c]] for c in (0, 1, 2)}
    index_to_sample = lambda i, stream: (i - stream["first_index"]) % INDEX_MODULUS + stream["start_sample"]
    # The second stream starts on the frame grid at 1.5 s = sample 15000 (a multiple of 30).
    check([(st["stream_id"], st["first_index"], st["start_sample"]) for st in s["streams"]]
          == [(1, 100, 0), (9, 4000000000, 15000)], f"streams {s['streams']}")
    for c in (0, 1, 2):
        sample_pos = []
        stream_no = 0
        for time, ident, _, data in frames:
            if ident == STREAM_HEADER_ID:
                stream_no = 0 if int.from_bytes(data[6:8], "little") == 1 else 1
            if ident == VIBRATION_BASE_ID + c:
                sample_pos.append(index_to_sample(int.from_bytes(data[:4], "little"), s["streams"][stream_no]))
        sample_pos = np.array(sample_pos)
        # Gaps: 0.5 s = sample 4980 on the grid (5000 rounded down to 30s), 100 samples -> 4 frames;
        # 1.2 s -> 12000, 30 samples -> 1 frame. Both missing on every channel, nothing else missing.
        missing = sorted(set(range(0, 30000 if c != 2 else 19980, 30)) - set(sample_pos.tolist()))
        check(missing == [4980, 5010, 5040, 5070, 12000], f"channel {c} missing frames {missing}")
        check(len(sample_pos) * 30 == s["samples_per_channel"][str(c)], "samples per channel with faults")
    check(s["gaps"] == [{"start_sample": 4980, "samples": 120, "first_missing_index": 5080, "stream_id": 1},
                        {"start_sample": 12000, "samples": 30, "first_missing_index": 12100, "stream_id": 1}],
          f"gaps {s['gaps']}")
    headers = [(int.from_bytes(f[3][6:8], "little"), f[0]) for f in frames if f[1] == STREAM_HEADER_ID]
    check([h[0] for h in headers] == [1, 1, 9, 9], f"headers {headers}")
    first_new = next(i for i, f in enumerate(frames) if f[1] == STREAM_HEADER_ID and int.from_bytes(f[3][6:8], "little") == 9)
    check(all(f[1] != VIBRATION_BASE_ID or int.from_bytes(f[3][:4], "little") < 4000000000 for f in frames[:first_new]),
          "no frame of the new stream before its header")
    check(vib([f for f in frames[first_new:] if f[1] == VIBRATION_BASE_ID][0])[0] == 4000000000, "new stream's first index")
    # Tacho and life counter continue physically across the stream change.
    lives = [int.from_bytes(f[3], "little") for f in by_id[LIFE_COUNTER_ID]]
    check(lives == [0, 10, 15, 25], f"life counter across the stream change {lives}")
    edge_positions, stream_no = [], 0
    for time, ident, _, data in frames:
        if ident == STREAM_HEADER_ID:
            stream_no = 0 if int.from_bytes(data[6:8], "little") == 1 else 1
        if ident == TACHO_BASE_ID:
            edge_positions.append(index_to_sample(int.from_bytes(data[:4], "little"), s["streams"][stream_no])
                                  + int.from_bytes(data[4:], "little") / 2.0 ** 32)
    check(np.max(np.abs(np.array(edge_positions) - (np.arange(30) + 0.31415926535) * 1000)) < 1e-6,
          "tacho edges keep their physical positions in the new stream's indices")
    check(len(by_id[TACHO_BASE_ID]) == 30, "30 tacho edges in 3 s at 10 Hz")
    # Channel 1 is flat from 0.25 s = sample 2500 (inside the frame of samples 2490..2519) on.
    first_values = np.concatenate([v for i, v in per_channel[1] if i == 100 + 2490])
    check(first_values[10] == s["flat_channels"]["1"]["value"] and first_values[9] != first_values[10], "flat from sample 2500")
    later = np.concatenate([v for i, v in per_channel[1] if i >= 100 + 2520])
    check(len(later) > 20000 and np.all(later == s["flat_channels"]["1"]["value"]), "flat channel constant, also in stream 9")
    # Channel 0: 1 % of 30000 samples at full scale (white noise of 5000 LSB never reaches it).
    ch0 = np.concatenate([v for _, v in per_channel[0]])
    check(s["saturated_samples"]["0"]["samples"] == 300, "1 % of 30000 samples saturated")
    check(np.count_nonzero(np.abs(ch0) == FULL_SCALE) == s["saturated_samples"]["0"]["sent"] > 290,
          "saturated samples in the frames sent")
    check(s["clipped_samples"]["0"] == 0, "no natural clipping")

    # 4b. A tacho 0.01 % fast: edge j at (j + phase)·fs/(speed·1.0001); none with --no-tacho.
    fs, speed, scale = 20000, 10.0, 1.0001
    _, by_id, s = decode(["--duration", "2.5", "--sample-rate", str(fs), "--speed", str(speed), "--channels", "0",
                          "--tacho-rate-scale", str(scale)])
    edges = [int.from_bytes(f[3][:4], "little") + int.from_bytes(f[3][4:], "little") / 2.0 ** 32 for f in by_id[TACHO_BASE_ID]]
    check(len(edges) == s["tacho_edges"] == 25, "one edge per (faster) revolution")
    check(max(abs(e - (j + 0.31415926535) * fs / (speed * scale)) for j, e in enumerate(edges)) < 1e-6, "scaled edge positions")
    _, by_id, s = decode(["--duration", "1", "--sample-rate", str(fs), "--channels", "0", "--no-tacho"])
    check(TACHO_BASE_ID not in by_id and s["tacho_edges"] == 0, "--no-tacho sends no tacho frame")

    # 5. Wrong options are refused with a reason.
    for bad in (["--stop-channel", "5:1"], ["--status-period", "2"], ["--gap", "9:30"], ["--tacho-phase", "1.5"],
                ["--tacho-rate-scale", "3"]):
        try:
            generate(self_test_args(["--duration", "1", "--sample-rate", "10000"] + bad))
            check(False, f"{bad} must be refused")
        except GeneratorError:
            checks += 1

    # 6. The ICS2 closed form against the direct noise-free envelope, and the scatter model
    #    against real AM noise put through a squared-envelope ICS2 (brick-wall band, ±3 bins).
    for a in (0.3, 0.5, 1.0):
        check(ics2_closed_form_check(a, 3) < 1e-12, f"closed form, a = {a}")
    check(abs(ics2_closed_form(0.5, 3) - 0.25390625 / 1.265625) < 1e-15, "closed form value at a = 0.5")
    fs, seconds, gmf, a, runs = 50000, 0.4, 190.0, 0.5, 48
    n = int(fs * seconds)
    t = np.arange(n) / fs
    values = []
    for r in range(runs):
        noise, bw = band_limited_gaussian(np.random.default_rng([99, r]), 2 * n, fs, 4000, 11000, 1.0)
        x = (1 + a * np.cos(2 * np.pi * gmf * t)) * noise[:n]   # a stretch of a longer stationary record
        spectrum = np.fft.fft(x)
        f = np.fft.fftfreq(n, 1 / fs)
        spectrum[(f < 2000) | (f > 13000)] = 0.0
        ses = np.fft.fft(np.abs(np.fft.ifft(2 * spectrum)) ** 2) / n
        k = int(round(gmf * seconds))
        values.append(sum(max(abs(ses[h * k + d]) ** 2 for d in range(-3, 4)) for h in (1, 2, 3)) / abs(ses[0]) ** 2)
    mean, std = ics2_scatter_model(a, bw, seconds, gmf, 3, 3)
    measured_mean, measured_std = float(np.mean(values)), float(np.std(values, ddof=1))
    # The mean of 48 draws is within 3 standard errors; the sample std of 48 Gaussian draws has a
    # relative standard error of 1/sqrt(2·47) = 10 %, so within 30 %.
    check(abs(measured_mean - mean) < 3 * std / math.sqrt(runs), f"ICS2 mean {measured_mean} vs model {mean} ± {std}")
    check(abs(measured_std / std - 1) < 0.3, f"ICS2 std {measured_std} vs model {std}")
    print(f"self-test: {checks} checks passed (ICS2 a=0.5 over {seconds} s: {runs} runs mean {measured_mean:.5f} "
          f"std {measured_std:.5f}; model mean {mean:.5f} std {std:.5f}; closed form {ics2_closed_form(a, 3):.5f})")


def main(argv=None):
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        if args.self_test:
            self_test()
            return 0
        if not args.out:
            parser.error("--out is required")
        write_outputs(args)
    except GeneratorError as exc:
        print(f"rig_capture: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
