"""The standard tests run on a truth law directly (the rig simulators' physics, finely integrated), so a model's
characteristic can be judged against the physics it was trained on (bench, tests)."""

from __future__ import annotations

from nnfmu.data.rigs import BushingChannelTruth, DamperTruth
from nnfmu.workflows.characterise.model import TestRun
from nnfmu.workflows.characterise.signals import SineTest, sine_motion

SUBSTEPS = 10  # the truth's integration step: a tenth of the model's sample period


def damper_truth_runs(truth: DamperTruth, tests: list[SineTest], period: float) -> list[TestRun]:
    """Each test's motion at `period`/SUBSTEPS [s] and the truth's force along it (`DamperTruth.simulate`)."""
    runs = []
    for test in tests:
        motion = sine_motion(test, period / SUBSTEPS)
        force, _ = truth.simulate(period / SUBSTEPS, motion.position, motion.rate, motion.acceleration)
        runs.append(TestRun(test, motion, force))
    return runs


def bushing_truth_runs(truth: BushingChannelTruth, tests: list[SineTest], period: float) -> list[TestRun]:
    """Each test's motion at `period`/SUBSTEPS [s] and the channel truth's force along it (exact for a position
    linear between samples)."""
    runs = []
    for test in tests:
        motion = sine_motion(test, period / SUBSTEPS)
        force, _ = truth.simulate(period / SUBSTEPS, motion.position)
        runs.append(TestRun(test, motion, force))
    return runs
