"""The loop report's headline in an engineer's words: what the model was missing, how much of its error that
explained, the error before -> after against the target; the diagnosis's internal test names stay in the details."""

from __future__ import annotations

from collections.abc import Sequence

from nnfmu.diagnosis import Diagnosis, DiagnosisError, find_effect
from nnfmu.validate.verdict import Target, percent, verdict
from nnfmu.workflows.loop.results import Iteration


def effect_words(name: str) -> str:
    """What an effect is, in words, with its library name: `damping fade with oil temperature (temperature)`."""
    try:
        return f"{find_effect(name).description} ({name})"
    except DiagnosisError:  # an effect the library does not know: its name is all there is
        return name


def _join(parts: Sequence[str]) -> str:
    return parts[0] if len(parts) == 1 else ", ".join(parts[:-1]) + " and " + parts[-1]


def headline(
    output: str,
    iterations: Sequence[Iteration],
    last: Diagnosis,
    before: float | None,
    after: float | None,
    target: Target,
) -> str:
    """What was missing, how much it explained, the test-part NRMSE before -> after against `target`, and what the
    last diagnosis still finds (in words; its test names are in the report's details)."""
    kept = [it for it in iterations if it.accepted]
    if kept:
        parts = []
        for k, it in enumerate(kept):
            of = "the model's residual variance" if k == 0 else "what was left"
            share = f" ({percent(it.explained_variance)} of {of})" if it.explained_variance is not None else ""
            parts.append(_join([effect_words(e) for e in it.effects]) + share)
        text = "The model was missing " + ", then ".join(parts) + "."
    elif last.consistent_with_noise:
        text = "Nothing was missing: the model's residual is consistent with noise."
    else:
        text = "Nothing was added: no effect in the library explained the model's residual well enough to add."
    where = " on the held-out test part"
    text += " " + verdict(output.capitalize(), after, target, before if kept else None, where) + "."
    added = {name for it in kept for name in it.effects}
    still = [e for e in last.significant if e.name not in added]
    if still:
        words = [f"{effect_words(e.name)}, {percent(e.additional_explained_variance or 0.0)}" for e in still]
        text += f" Still missing after the loop: {_join(words)} of what is left."
    return text
