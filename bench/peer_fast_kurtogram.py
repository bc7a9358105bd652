#!/usr/bin/env python3
"""Times a peer's fast kurtogram on the record bench_indicators uses, in FFT-equivalents of its
own ecosystem (one numpy 2^20-point rfft), for the comparison line of bench_indicators.

Usage: peer_fast_kurtogram.py PEER_MODULE RECORD_F64 NLEVEL FS

PEER_MODULE is a fast_kurtogram.py exposing Fast_Kurtogram(x, nlevel, Fs) and the kurtogram
proper K_wpQ (e.g. the repository mozhenling/dbtree, dbtpy/filters/fast_kurtogram.py, the
implementation behind shared/reference/fast-kurtogram). It is run as it is, not copied: its
plotting is given no-op stand-ins and its interactive question is answered 0. The time of the
kurtogram proper (every call of its K_wpQ, which is the tree with the kurtosis criterion) is what
is compared; the whole Fast_Kurtogram call (which also filters the optimal band) is printed too.
Prints one line: PEER name=... tree_s=... whole_s=... rfft_s=... tree_per_fft=... whole_per_fft=...
"""
import builtins
import importlib.util
import sys
import time
import types

import numpy as np


def stub_module(name):
    class Anything:
        def __call__(self, *args, **kwargs):
            return Anything()

        def __getattr__(self, attr):
            return Anything()

    module = types.ModuleType(name)
    module.__getattr__ = lambda attr: Anything()
    return module


def main():
    peer_path, record_path, nlevel, fs = sys.argv[1], sys.argv[2], int(sys.argv[3]), float(sys.argv[4])
    for name in ("matplotlib", "matplotlib.pyplot", "matplotlib.colors"):
        sys.modules[name] = stub_module(name)
    builtins.input = lambda prompt="": "0"
    spec = importlib.util.spec_from_file_location("peer_fast_kurtogram", peer_path)
    peer = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(peer)

    x = np.fromfile(record_path, dtype=np.float64)

    tree_time = [0.0]
    original = peer.K_wpQ

    def timed_k_wpq(*args, **kwargs):
        t0 = time.perf_counter()
        result = original(*args, **kwargs)
        tree_time[0] += time.perf_counter() - t0
        return result

    peer.K_wpQ = timed_k_wpq

    n = 1 << 20
    signal = np.random.default_rng(2).standard_normal(n)
    np.fft.rfft(signal)
    rfft = min(timed(lambda: np.fft.rfft(signal)) for _ in range(20))

    best_tree, best_whole = float("inf"), float("inf")
    out = sys.stdout
    for _ in range(3):
        tree_time[0] = 0.0
        sys.stdout = open("/dev/null", "w")  # its summary print
        try:
            whole = timed(lambda: peer.Fast_Kurtogram(x, nlevel, fs))
        finally:
            sys.stdout.close()
            sys.stdout = out
        best_tree, best_whole = min(best_tree, tree_time[0]), min(best_whole, whole)
    print(f"PEER name=fast_kurtogram_dbtree samples={x.size} nlevel={nlevel} tree_s={best_tree:.4f} "
          f"whole_s={best_whole:.4f} rfft_s={rfft:.5f} tree_per_fft={best_tree / rfft:.1f} "
          f"whole_per_fft={best_whole / rfft:.1f}")


def timed(f):
    t0 = time.perf_counter()
    f()
    return time.perf_counter() - t0


if __name__ == "__main__":
    main()
