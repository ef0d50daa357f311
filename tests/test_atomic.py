"""Temporaries made by `nnfmu.atomic` are removed however their block ends, also when an interrupt lands in the
instant between their creation and the armed cleanup (a SIGTERM there left a build folder behind in CI)."""

from __future__ import annotations

import signal
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest

from nnfmu import atomic
from nnfmu.stopping import interrupts_deferred


@pytest.fixture(autouse=True)
def python_sigint_handler() -> Iterator[None]:
    """These tests raise SIGINT in the worker itself, so they need Python's own handler: in one CI run an earlier test
    in the same xdist worker left another disposition behind, and the raised SIGINT never arrived."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous if previous is not None else signal.default_int_handler)


def interrupt_right_after(monkeypatch: pytest.MonkeyPatch, name: str) -> None:
    """Make tempfile.`name` raise SIGINT in this process the moment the temporary exists."""
    real = getattr(tempfile, name)

    def made_then_interrupted(*args: object, **kwargs: object) -> object:
        made = real(*args, **kwargs)
        signal.raise_signal(signal.SIGINT)
        return made

    monkeypatch.setattr(tempfile, name, made_then_interrupted)


def test_an_interrupt_inside_a_deferred_block_arrives_when_it_ends() -> None:
    reached = []
    with pytest.raises(KeyboardInterrupt), interrupts_deferred():
        signal.raise_signal(signal.SIGINT)
        reached.append("after the signal")
    assert reached == ["after the signal"]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_a_scratch_folder_interrupted_as_it_is_made_is_removed(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    interrupt_right_after(monkeypatch, "mkdtemp")
    with pytest.raises(KeyboardInterrupt), atomic.scratch_dir("nnfmu-test-", tmp_path):
        pytest.fail("the block ran though the interrupt came first")
    assert list(tmp_path.iterdir()) == []


def test_a_staging_folder_is_removed_when_its_block_fails(tmp_path: Path) -> None:
    with pytest.raises(RuntimeError), atomic.staging_dir(tmp_path, ".out.staging-") as staging:
        (staging / "half.csv").write_text("t [s]\n", encoding="utf-8")
        raise RuntimeError("failed midway")
    assert list(tmp_path.iterdir()) == []


def test_an_atomic_file_interrupted_as_it_is_made_leaves_nothing(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    interrupt_right_after(monkeypatch, "mkstemp")
    with pytest.raises(KeyboardInterrupt), atomic.atomic_path(tmp_path / "result.csv"):
        pytest.fail("the block ran though the interrupt came first")
    assert list(tmp_path.iterdir()) == []


def test_nnfmu_makes_its_temporary_folders_through_scratch_dir() -> None:
    """tempfile.TemporaryDirectory has the gap between mkdtemp and its finaliser that scratch_dir closes."""
    package = Path(atomic.__file__).parent
    users = [p.relative_to(package) for p in package.rglob("*.py") if "TemporaryDirectory(" in p.read_text("utf-8")]
    assert users == []
