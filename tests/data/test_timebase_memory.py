"""The time-base checks of a long record hold no temporary array of its length (issue 30: `nnfmu data check` on 10 M
CSV rows peaked at 1.17 GB, the peak in `check_uniform`/`fit_uniform`; `bench/csv_memory.py` measures the whole
command)."""

from __future__ import annotations

import tracemalloc

import numpy as np

from nnfmu.data.timebase import check_uniform, digits_resolution, measurement_axis, uniform_stamps

N = 2_000_000  # stamps: 16 MB of float64, eight chunks


def peak_bytes(work) -> int:
    """Peak of memory traced (numpy reports its arrays) while `work()` runs, beyond what was held before."""
    tracemalloc.start()
    try:
        tracemalloc.reset_peak()
        before, _ = tracemalloc.get_traced_memory()
        work()
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    return peak - before


def test_checking_a_long_uniform_axis_holds_only_chunks():
    time = 2.5 + np.arange(N) * 1e-3
    assert peak_bytes(lambda: check_uniform(time, "long.csv")) < time.nbytes / 4
    assert peak_bytes(lambda: measurement_axis(time, "long.csv")) < time.nbytes / 4


def test_a_printed_axis_is_checked_with_its_resolution_in_chunks_and_keeps_its_result():
    exact = np.arange(N) / 1024.0
    printed = np.round(exact, 6)  # 1024 Hz stamps printed to 6 decimals
    resolution = digits_resolution((10, 6), printed)
    assert peak_bytes(lambda: check_uniform(printed, "printed.csv", resolution)) < printed.nbytes / 4
    time, note = uniform_stamps(printed, "printed.csv", resolution)
    assert note is not None and "within their resolution (printed to 6 decimals" in note
    np.testing.assert_allclose(time, exact, rtol=0, atol=1e-9)
