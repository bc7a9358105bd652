#!/usr/bin/env python3
"""Independent writer of DAQ recordings for the `gearwatch import` tests (tests/test_daq_import.cpp).

Writes one known signal in the forms a test bench's recorder gives, with Python's own `wave`
module, numpy text output, scipy.io.savemat (MATLAB v5) and h5py (MATLAB v7.3): nothing here shares code with
gearwatch's readers (libsndfile, libmatio) or its capture writer.

The signal: a 23-tooth pinion at a constant SPEED_HZ; gear-mesh harmonics 2.4, 1.2, 0.6 m/s^2
and 0.5 m/s^2 (rms) of seeded white noise, sampled at FS_HZ. A once-per-revolution tacho: a
rectangular pulse, high for the first quarter of each revolution counted from TACHO_PHASE
revolutions after the first sample, so its rising edges are at (k + TACHO_PHASE) * FS_HZ / SPEED_HZ.

Files written into --out DIR:
  accel.f64       the signal in m/s^2 (little-endian float64), the reference of every comparison
  codes.i16       round(accel / 0.01): the samples a capture at 0.01 m/s^2 per LSB carries
  edges.f64       the tacho's true rising-edge positions in samples
  rec.wav         16-bit PCM, 2 channels: codes (full scale 32768 codes = 327.68 m/s^2) and the tacho (0 / 16384)
  rec.mat         v5: accel (N x 1 double, codes * 0.01 m/s^2), fs (scalar), info (a struct)
  rec73.mat       v7.3 (HDF5 through h5py): accel and fs as in rec.mat
  rows.mat        v5: wide (2 x 1000 int16): row 0 = codes[:1000], row 1 = -codes[:1000]; rate 51200
  semicolon.csv   no header, ';' between cells: sample index / 51200 s, codes[:1000] * 0.01
  rec.csv         header time,accel_g,tacho_V: time i/fs, the signal in g (17 digits), tacho 0 / 5 V
and the refused ones: rate8k.wav (8 kHz), short.wav (0.5 s), clipped.wav (one sample at +32767),
bad_cell.csv (a cell "abc" on line 7), nan.csv (a "nan" on line 5).
"""

import argparse
import math
import os
import wave

import h5py
import numpy as np
import scipy.io

FS_HZ = 25600
SPEED_HZ = 25.3
PINION_TEETH = 23
HARMONICS = (2.4, 1.2, 0.6)
NOISE_RMS = 0.5
TACHO_PHASE = 0.3
STANDARD_GRAVITY = 9.80665
LSB = 0.01


def signal(n, seed):
    t = np.arange(n) / FS_HZ
    x = np.zeros(n)
    for h, a in enumerate(HARMONICS, start=1):
        x += a * np.sin(2 * math.pi * h * PINION_TEETH * SPEED_HZ * t + 0.7 * h)
    return x + np.random.default_rng(seed).normal(0.0, NOISE_RMS, n)


def tacho(n):
    revs = np.arange(n) * SPEED_HZ / FS_HZ - TACHO_PHASE
    return (revs >= 0) & (np.mod(revs, 1.0) < 0.25)


def true_edges(n):
    per_rev = FS_HZ / SPEED_HZ
    k = np.arange(0, int((n - 1) / per_rev - TACHO_PHASE) + 1)
    return (k + TACHO_PHASE) * per_rev


def write_wav(path, rate, channels):
    frames = np.stack(channels, axis=1).astype("<i2")
    with wave.open(path, "wb") as w:
        w.setnchannels(frames.shape[1])
        w.setsampwidth(2)
        w.setframerate(rate)
        w.writeframes(frames.tobytes())


def write_mat73(path, variables):
    """MATLAB v7.3 as its documented layout: an HDF5 file behind a 512-byte user block holding the
    MAT header (116 bytes of text, 8 of subsystem offset, version 0x0200, endian mark "IM"); each
    variable a dataset in MATLAB's column-major order (so an N x 1 column is stored as 1 x N) with
    the attribute MATLAB_class."""
    with h5py.File(path, "w", userblock_size=512) as f:
        for name, value in variables.items():
            d = f.create_dataset(name, data=np.asarray(value, dtype=np.float64).T)
            # A scalar fixed-length ASCII string, null-terminated (the terminator counted in its size).
            kind = h5py.h5t.C_S1.copy()
            kind.set_size(len(b"double") + 1)
            kind.set_strpad(h5py.h5t.STR_NULLTERM)
            attr = h5py.h5a.create(d.id, b"MATLAB_class", kind, h5py.h5s.create(h5py.h5s.SCALAR))
            attr.write(np.array(b"double", dtype="S7"))
    text = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Thu Jan  1 00:00:00 2026 HDF5 schema 1.00 ."
    header = text.ljust(116, b" ") + b" " * 8 + (0x0200).to_bytes(2, "little") + b"IM"
    with open(path, "r+b") as f:
        f.write(header.ljust(512, b"\0"))


def write_csv(path, header, rows):
    with open(path, "w") as f:
        f.write(header + "\n")
        for r in rows:
            f.write(r + "\n")


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", required=True, help="directory to write into")
    p.add_argument("--seconds", type=float, default=4.5)
    p.add_argument("--seed", type=int, default=1)
    a = p.parse_args()
    os.makedirs(a.out, exist_ok=True)
    n = int(round(a.seconds * FS_HZ))
    x = signal(n, a.seed)
    codes = np.round(x / LSB).astype(np.int16)
    pulse = tacho(n)
    x.astype("<f8").tofile(os.path.join(a.out, "accel.f64"))
    codes.astype("<i2").tofile(os.path.join(a.out, "codes.i16"))
    true_edges(n).astype("<f8").tofile(os.path.join(a.out, "edges.f64"))

    write_wav(os.path.join(a.out, "rec.wav"), FS_HZ, [codes, np.where(pulse, 16384, 0)])
    scipy.io.savemat(os.path.join(a.out, "rec.mat"),
                     {"accel": (codes.astype(np.float64) * LSB).reshape(-1, 1), "fs": float(FS_HZ),
                      "info": {"rig": "test bench", "teeth": PINION_TEETH}},
                     format="5")
    write_mat73(os.path.join(a.out, "rec73.mat"),
                {"accel": (codes.astype(np.float64) * LSB).reshape(-1, 1), "fs": np.array([[float(FS_HZ)]])})
    scipy.io.savemat(os.path.join(a.out, "rows.mat"),
                     {"wide": np.stack([codes[:1000], -codes[:1000]]).astype(np.int16), "Fs": 51200.0}, format="5")
    write_csv(os.path.join(a.out, "semicolon.csv"), "%.9f;%.2f" % (0.0, codes[0] * LSB),
              ["%.9f;%.2f" % (i / 51200, codes[i] * LSB) for i in range(1, 1000)])
    rows = ["%.9f,%.17g,%d" % (i / FS_HZ, x[i] / STANDARD_GRAVITY, 5 if pulse[i] else 0) for i in range(n)]
    write_csv(os.path.join(a.out, "rec.csv"), "time,accel_g,tacho_V", rows)

    write_wav(os.path.join(a.out, "rate8k.wav"), 8000, [codes[:3 * 8000]])
    write_wav(os.path.join(a.out, "short.wav"), FS_HZ, [codes[:FS_HZ // 2]])
    clipped = codes.copy()
    clipped[1000] = 32767
    write_wav(os.path.join(a.out, "clipped.wav"), FS_HZ, [clipped])
    bad = list(rows)
    bad[5] = bad[5].split(",")[0] + ",abc,0"     # line 7: the header is line 1
    write_csv(os.path.join(a.out, "bad_cell.csv"), "time,accel_g,tacho_V", bad)
    nan = list(rows)
    nan[3] = nan[3].split(",")[0] + ",nan,0"     # line 5
    write_csv(os.path.join(a.out, "nan.csv"), "time,accel_g,tacho_V", nan)


if __name__ == "__main__":
    main()
