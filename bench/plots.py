"""CPU time of the validation report's three PNG plots per channel (time window, PSD, rainflow exceedance), JSON on
the last line.

Usage: python bench/plots.py [DURATION_S] [REPEATS] [OUT_DIR]
A synthetic channel pair (band-limited random force at 1 kHz over DURATION_S, default 50 s; the result a slightly
scaled, noisy copy) is compared with the default `ValidationSettings` and plotted REPEATS times (default 5); the
median CPU time (process time: user + sys of this process, what 2 idle cores would see) of each plot is reported.
The PNGs of the last repeat stay in OUT_DIR (default a temporary folder) for a look.
"""

from __future__ import annotations

import json
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.signal import butter, sosfiltfilt

from nnfmu.data import Measurement
from nnfmu.validate.compare import ValidationSettings, compare
from nnfmu.validate.plots import plot_psd, plot_rainflow, plot_time_window


def channel_pair(duration: float, rate: float = 1000.0) -> tuple[Measurement, Measurement]:
    """A reference force and a result within a few per cent of it, `duration` [s] at `rate` [Hz]."""
    rng = np.random.default_rng(0)
    time_s = np.arange(int(duration * rate)) / rate
    force = sosfiltfilt(butter(4, 25.0, fs=rate, output="sos"), rng.normal(size=time_s.size)) * 3000.0
    result = 1.03 * force + rng.normal(scale=20.0, size=time_s.size)
    name = "damper_force"
    return (
        Measurement(time_s, {name: result}, {name: "N"}, source="result"),
        Measurement(time_s, {name: force}, {name: "N"}, source="reference"),
    )


def main(duration: float = 50.0, repeats: int = 5, out: Path | None = None) -> dict[str, float]:
    out = out or Path(tempfile.mkdtemp(prefix="nnfmu-plots-"))
    out.mkdir(parents=True, exist_ok=True)
    result, reference = channel_pair(duration)
    (comparison,) = compare(result, reference, ["damper_force"], ValidationSettings())
    seconds: dict[str, list[float]] = {"time": [], "psd": [], "rainflow": []}
    plots = {"time": plot_time_window, "psd": plot_psd, "rainflow": plot_rainflow}
    for _ in range(repeats):
        for kind, plot in plots.items():
            start = time.process_time()
            plot(comparison, out / f"damper_force_{kind}.png")
            seconds[kind].append(time.process_time() - start)
    figures = {f"{kind}_cpu_s": round(statistics.median(s), 4) for kind, s in seconds.items()}
    figures["channel_cpu_s"] = round(sum(figures.values()), 4)
    figures |= {"duration_s": duration, "repeats": repeats, "out": str(out)}
    return figures


if __name__ == "__main__":
    args = sys.argv[1:]
    print(
        json.dumps(
            main(
                float(args[0]) if args else 50.0,
                int(args[1]) if len(args) > 1 else 5,
                Path(args[2]) if len(args) > 2 else None,
            )
        )
    )
