"""The iteration itself, on any plant that maps a drive record to response records (the co-simulated virtual car
in `run.py`, a numpy filter in tests): identify with noise, first drive from the regularised inverse, then
drive_{k+1} = drive_k + g·H⁺·(target − response_k) inside the band, each drive faded from and back to rest and
scaled back where a full step would exceed an actuator limit."""

from __future__ import annotations

import time as clock
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from nnfmu.validate.damage import pseudo_damage_ratio
from nnfmu.validate.metrics import nrmse, rms, rms_ratio
from nnfmu.workflows.iterate.identify import Frf, Spectra, cross_spectra, estimate_frf
from nnfmu.workflows.iterate.inverse import apply_inverse, regularised_inverse
from nnfmu.workflows.iterate.settings import IterateError, IterateSettings
from nnfmu.workflows.iterate.signals import (
    band_filter,
    band_noise,
    fade_weights,
    largest_step,
    limit_ratios,
)

Plant = Callable[[np.ndarray], np.ndarray]  # drive (n, m) [m] every dt -> responses (n, p) on the same times
Log = Callable[[str], None]
RMS_ALARM_DB = 3.0  # the road-test lab's alarm on a channel's RMS level


@dataclass(frozen=True)
class Iteration:
    """One played drive (n, m) [m], the response (n, p) it gave, its metrics per channel, the step it took (the
    fraction of the correction the actuator limits allowed) and the drive's peaks as fractions of the limits."""

    index: int
    drive: np.ndarray
    response: np.ndarray
    metrics: dict[str, dict[str, float]]
    step_taken: float
    limit_use: dict[str, float]
    frf_reestimated: bool


@dataclass
class Outcome:
    """All iterations, the best one (lowest worst-channel NRMSE relative to its tolerance), whether every channel
    met its tolerance, the noise run's FRF and the last one used, and the seconds spent."""

    iterations: list[Iteration]
    best: int
    converged: bool
    frf_noise: Frf
    frf_last: Frf
    noise_scale: float
    seconds: float
    notes: list[str] = field(default_factory=list)


def channel_metrics(response: np.ndarray, target: np.ndarray, slope: float) -> dict[str, float]:
    """NRMSE, RMS ratio [dB], the global RMS error and the pseudo-damage ratio of one channel against its target."""
    ratio = rms_ratio(response, target)
    return {
        "nrmse": nrmse(response, target),
        "rms_ratio_db": float(20.0 * np.log10(ratio)) if ratio > 0 else float("-inf"),
        "global_rms_error": rms(response - target) / rms(target) if rms(target) > 0 else float("nan"),
        "pseudo_damage_ratio": pseudo_damage_ratio(response, target, slope),
    }


def _score(metrics: dict[str, dict[str, float]], settings: IterateSettings) -> float:
    return max(m["nrmse"] / settings.tolerance_of(name) for name, m in metrics.items())


def iterate(
    plant: Plant,
    target: np.ndarray,
    dt: float,
    names: Sequence[str],
    actuators: int,
    settings: IterateSettings,
    log: Log = lambda _: None,
) -> Outcome:
    """Iterate a drive of `actuators` posts for `plant` until its responses match `target` (n, p) [channel units]
    sampled every `dt` [s], channel names `names` (see the module docstring)."""
    started = clock.perf_counter()
    n, p = target.shape
    if p < actuators:
        raise IterateError(
            f"{p} target channel(s) for {actuators} actuators: the drive is not determined; give at least "
            f"{actuators} channels"
        )
    if n * dt < 1.0 / settings.resolution:
        raise IterateError(
            f"the target's {n * dt:g} s are shorter than one FRF segment ({1.0 / settings.resolution:g} s at "
            f"{settings.resolution:g} Hz resolution); coarsen the resolution or give a longer target"
        )
    in_band = band_filter(target - target.mean(axis=0), dt, settings.band)
    scale = np.sqrt(np.mean(in_band**2, axis=0))
    flat = [name for name, s in zip(names, scale) if not s > 0]
    if flat:
        raise IterateError(f"target channel(s) {', '.join(flat)} carry nothing in the band {settings.band} Hz")
    weights = 1.0 / scale
    notes = []

    noise_n = round(settings.noise_duration / dt)
    noise = band_noise(noise_n, dt, settings.band, settings.noise_level, actuators, settings.seed)
    noise *= fade_weights(noise_n, dt, settings.fade)[:, None]
    use = max(limit_ratios(noise, dt, settings.limits).values())
    noise_scale = min(1.0, 1.0 / use)
    if noise_scale < 1.0:
        notes.append(f"identification noise scaled by {noise_scale:.3g} to stay within the actuator limits")
        noise *= noise_scale
    log(f"identification: {settings.noise_duration:g} s of band-limited noise on {actuators} actuator(s)")
    noise_spectra = cross_spectra(noise, plant(noise), dt, settings.resolution)
    frf_noise = frf = estimate_frf(noise_spectra)
    inside = (frf.frequency >= settings.band[0]) & (frf.frequency <= settings.band[1])
    log(
        "coherence in the band (mean): "
        + ", ".join(f"{name} {np.mean(frf.coherence[inside, i]):.3f}" for i, name in enumerate(names))
    )
    inverse = regularised_inverse(frf, weights, settings.regularisation, settings.band)
    fade = fade_weights(n, dt, settings.fade)[:, None]

    drive = np.zeros((n, actuators))
    error = target
    gain = 1.0  # the first drive is the inverse's whole estimate
    iterations: list[Iteration] = []
    reestimated = False
    for index in range(1, settings.iterations + 1):
        delta = gain * fade * apply_inverse(inverse, frf.frequency, error, dt, settings.band)
        step = largest_step(drive, delta, dt, settings.limits)
        drive = drive + step * delta
        response = plant(drive)
        metrics = {
            name: channel_metrics(response[:, i], target[:, i], settings.basquin_slope) for i, name in enumerate(names)
        }
        iterations.append(
            Iteration(index, drive, response, metrics, step, limit_ratios(drive, dt, settings.limits), reestimated)
        )
        worst = max(metrics, key=lambda name: metrics[name]["nrmse"] / settings.tolerance_of(name))
        log(
            f"iteration {index}: NRMSE "
            + ", ".join(f"{name} {m['nrmse']:.4f}" for name, m in metrics.items())
            + f"; worst {worst}"
            + (f"; step limited to {step:.3g} by the actuator limits" if step < 1.0 else "")
        )
        if _score(metrics, settings) <= 1.0:
            break
        if step == 0.0:
            notes.append(f"iteration {index}: stalled at the actuator limits (no part of the correction fits)")
            log(notes[-1])
            break
        error = target - response
        gain = settings.gain
        reestimated = False
        if settings.reestimate:
            recent = iterations[-settings.reestimate :]
            spectra: Spectra = noise_spectra
            for it in recent:
                spectra = spectra + cross_spectra(it.drive, it.response, dt, settings.resolution)
            frf = estimate_frf(spectra)
            inverse = regularised_inverse(frf, weights, settings.regularisation, settings.band)
            reestimated = True
    best = min(range(len(iterations)), key=lambda k: _score(iterations[k].metrics, settings))
    converged = _score(iterations[best].metrics, settings) <= 1.0
    return Outcome(iterations, best, converged, frf_noise, frf, noise_scale, clock.perf_counter() - started, notes)
