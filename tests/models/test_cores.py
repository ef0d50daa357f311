"""SpareCores: a core is lent only while no training run holds it, and a lent task holds it until it returns."""

from __future__ import annotations

import threading

from nnfmu.models.cores import SpareCores, usable_cores


def test_no_core_is_lent_while_every_core_runs_a_fit():
    with SpareCores(2) as spare, spare.occupied(), spare.occupied():
        assert spare.lend(lambda: 1) is None


def test_a_core_left_idle_is_lent_and_held_until_its_task_returns():
    release = threading.Event()
    with SpareCores(2) as spare, spare.occupied():
        lent = spare.lend(lambda: release.wait(timeout=30) and "done")
        assert lent is not None
        assert spare.lend(lambda: 2) is None  # the idle core is taken by the running task
        release.set()
        assert lent.result(timeout=30) == "done"
        again = spare.lend(lambda: 3)  # free again once the task has returned, before its caller looks
        assert again is not None and again.result(timeout=30) == 3


def test_a_core_freed_by_a_finished_fit_is_lent():
    with SpareCores(2) as spare:
        with spare.occupied():
            pass
        with spare.occupied():
            lent = spare.lend(lambda: 4)
            assert lent is not None and lent.result(timeout=30) == 4


def test_a_single_core_lends_nothing_while_its_fit_runs():
    with SpareCores(1) as spare, spare.occupied():
        assert spare.lend(lambda: 5) is None


def test_usable_cores_is_at_least_one():
    assert usable_cores() >= 1
