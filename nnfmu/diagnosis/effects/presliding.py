"""Seal friction with pre-sliding stiffness: a Jenkins element (spring in series with a Coulomb slider), the seal
sticking and deflecting elastically after each reversal until it breaks away and slides (the stop-operator family
read as an elastic-plastic loop)."""

from __future__ import annotations

from nnfmu.diagnosis.effects.stop_family import StopFamily


class PreslidingFriction(StopFamily):
    """F = k·stop(x, F_s/k): after a reversal the force changes at the pre-sliding stiffness, then saturates at the
    break-away force; a bank of stops covers a spread of break-away travels."""

    name = "presliding_friction"
    description = "seal friction with pre-sliding stiffness: stick, elastic deflection, then sliding (Jenkins element)"
    shape = "elastic_plastic"
    meaning = "seal friction with pre-sliding stiffness (Jenkins elements, stiff then sliding after each reversal)"
    state_meaning = "the seal's elastic deflection before it breaks away (Jenkins-element states)"
