"""A damper FMU on the vendor quarter car, coupled the way a user's own master couples it, and the same car solved
monolithically as the reference: the yardstick of "precision that survives the user's master".

- `road(t)`: a smooth random road (24 sines, 0.7-25 Hz, about 4 mm rms) with a 30 mm pothole at 1 s.
- `monolithic(truth, duration, dt)`: the vendor car's equations (tests/vendor/quarter_car.c) with the damper truth
  law inside, one classic RK4 over all states: damper force and body acceleration every `dt`.
- `plain_loop(car, damper, duration, h, scheme)`: fmpy alone, no nnfmu code: Gauss-Seidel (the car steps on the
  held damper force, the damper on the car's new velocity) or Jacobi (both on the values at the step's start).
- `libcosim_loop(...)`: the same system in libcosim (Jacobi, its fixed-step algorithm).
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

sys.path.insert(0, str(Path(__file__).parents[1] / "cosim"))  # the plain fmpy replay of the co-simulation tests
from plain_master import plain_replay, port_names  # noqa: E402

from nnfmu.data.rigs import DamperTruth  # noqa: E402

M_S, M_U, K_S, K_T = 400.0, 40.0, 20e3, 200e3  # the vendor car's defaults (vendor_fmu.REALS)
_FREQUENCIES = np.geomspace(0.7, 25.0, 24)
_AMPLITUDES = 0.004 / _FREQUENCIES**0.8
_PHASES = np.random.default_rng(3).uniform(0.0, 2.0 * np.pi, len(_FREQUENCIES))
POTHOLE = (1.0, 0.05, 0.03)  # start [s], length [s], depth [m]


def road(t: np.ndarray) -> np.ndarray:
    """Road displacement [m] under the tyre at times `t` [s]; 0 at t = 0."""
    t = np.atleast_1d(np.asarray(t, dtype=float))
    phase = 2.0 * np.pi * _FREQUENCIES[:, None] * t[None, :] + _PHASES[:, None]
    z = (_AMPLITUDES[:, None] * (np.sin(phase) - np.sin(_PHASES[:, None]))).sum(axis=0)
    start, length, depth = POTHOLE
    inside = (t > start) & (t < start + length)
    return z - np.where(inside, depth * np.sin(np.pi * (t - start) / length) ** 2, 0.0)


def monolithic(truth: DamperTruth, duration: float, dt: float) -> np.ndarray:
    """(n + 1, 4) at t = k dt of the car with `truth` inside: damper force [N], body acceleration [m/s^2], damper
    velocity [m/s] and displacement [m]."""

    def rates(t: float, y: np.ndarray) -> tuple[np.ndarray, float]:
        x, v = y[0] - y[2], y[1] - y[3]
        force = float(truth.force(y[4:], x, v, 0.0))
        zr = road(t)[0]
        dy = np.empty_like(y)
        dy[0], dy[1] = y[1], (-K_S * x - force) / M_S
        dy[2], dy[3] = y[3], (K_S * x + force - K_T * (y[2] - zr)) / M_U
        dy[4:] = truth.derivatives(t, y[4:], x, v)
        return dy, force

    n = round(duration / dt)
    y = np.concatenate([np.zeros(4), truth.initial_state()])
    out = np.empty((n + 1, 4))
    dy, force = rates(0.0, y)
    out[0] = force, dy[1], 0.0, 0.0
    for k in range(n):
        t = k * dt
        k1 = dy
        k2, _ = rates(t + dt / 2, y + dt / 2 * k1)
        k3, _ = rates(t + dt / 2, y + dt / 2 * k2)
        k4, _ = rates(t + dt, y + dt * k3)
        y = y + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        dy, force = rates(t + dt, y)
        out[k + 1] = force, dy[1], y[1] - y[3], y[0] - y[2]
    return out


def replay(damper_fmu: Path, velocity: np.ndarray, displacement: np.ndarray, h: float) -> np.ndarray:
    """Damper force [N] at t = k h of `damper_fmu` (fmpy alone, `plain_replay`) fed the motion sample k before the
    step ending at t_k: the open loop, the FMU's own error with no coupling in it."""
    motion = {"velocity": velocity, "displacement": displacement}
    return plain_replay(damper_fmu, {name: motion[name] for name in port_names(damper_fmu, "input")}, h, "force")


def _open(path: Path, name: str) -> tuple[FMU2Slave, dict[str, int]]:
    """An initialised FMI 2 instance of `path` at its default parameters, and its value references by name; `_close`
    ends it and removes the folder it was unpacked into."""
    md = read_model_description(path)
    slave = FMU2Slave(
        guid=md.guid, unzipDirectory=extract(path), modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name
    )
    references = {v.name: v.valueReference for v in md.modelVariables}
    slave.instantiate()
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.exitInitializationMode()
    return slave, references


def plain_loop(car_fmu: Path, damper_fmu: Path, duration: float, h: float, scheme: str) -> np.ndarray:
    """(n + 1, 2): damper force [N] and body acceleration [m/s^2] at t = k h from a plain fmpy master."""
    car, cv = _open(car_fmu, "car")
    try:
        damper, dv = _open(damper_fmu, "damper")
    except BaseException:
        _close(car)
        raise
    try:
        return _loop(car, cv, damper, dv, duration, h, scheme)
    finally:
        for slave in (car, damper):
            _close(slave)


def _loop(
    car: FMU2Slave, cv: dict[str, int], damper: FMU2Slave, dv: dict[str, int], duration: float, h: float, scheme: str
) -> np.ndarray:
    """`plain_loop`'s steps on open instances."""
    n = round(duration / h)
    zr = road(np.arange(n + 1) * h)
    out = np.empty((n + 1, 2))
    force = damper.getReal([dv["force"]])[0]
    velocity = car.getReal([cv["v_damper"]])[0]
    out[0] = force, car.getReal([cv["a_body"]])[0]
    for k in range(n):
        t = k * h
        if scheme == "jacobi":
            damper.setReal([dv["velocity"]], [velocity])
        car.setReal([cv["zr"], cv["F_damper"]], [zr[k], force])
        car.doStep(t, h)
        velocity = car.getReal([cv["v_damper"]])[0]
        if scheme == "gauss-seidel":
            damper.setReal([dv["velocity"]], [velocity])
        damper.doStep(t, h)
        force = damper.getReal([dv["force"]])[0]
        car.setReal([cv["F_damper"]], [force])  # a_body feeds through the force: read it with the new one
        out[k + 1] = force, car.getReal([cv["a_body"]])[0]
    return out


def _close(slave: FMU2Slave) -> None:
    """Terminate and free an instance from `_open`, then remove its unpacked FMU."""
    try:
        slave.terminate()
    finally:
        slave.freeInstance()
    shutil.rmtree(slave.unzipDirectory, ignore_errors=True)


def libcosim_loop(car_fmu: Path, damper_fmu: Path, duration: float, h: float) -> np.ndarray:
    """(n, 2): damper force [N] and body acceleration [m/s^2] at t = k h, k >= 1, from libcosim (Jacobi)."""
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimManipulator import CosimManipulator
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave

    log_output_level(CosimLogLevel.ERROR)
    execution = CosimExecution.from_step_size(round(h * 1e9))
    car = execution.add_local_slave(CosimLocalSlave(fmu_path=str(car_fmu), instance_name="car"))
    damper = execution.add_local_slave(CosimLocalSlave(fmu_path=str(damper_fmu), instance_name="damper"))
    cv = {v.name.decode(): v.reference for v in execution.slave_variables(car)}
    dv = {v.name.decode(): v.reference for v in execution.slave_variables(damper)}
    execution.connect_real_variables(car, cv["v_damper"], damper, dv["velocity"])
    execution.connect_real_variables(damper, dv["force"], car, cv["F_damper"])
    manipulator = CosimManipulator.create_override()
    observer = CosimObserver.create_last_value()
    execution.add_manipulator(manipulator)
    execution.add_observer(observer)
    n = round(duration / h)
    zr = road(np.arange(n + 1) * h)
    out = np.empty((n, 2))
    for k in range(n):
        manipulator.slave_real_values(car, [cv["zr"]], [float(zr[k])])
        assert execution.step(1), f"libcosim step {k} failed"
        out[k] = observer.last_real_values(damper, [dv["force"]])[0], observer.last_real_values(car, [cv["a_body"]])[0]
    return out


def nrmse(got: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Per column: rms of the error over rms of the reference."""
    return np.sqrt(np.mean((got - reference) ** 2, axis=0) / np.mean(reference**2, axis=0))
