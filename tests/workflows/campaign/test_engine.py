"""How the engine cuts a campaign into Dask tasks: consecutive cases in groups, several groups per worker thread."""

from __future__ import annotations

import pytest

from nnfmu.workflows.campaign.engine import GROUPS_PER_THREAD, MAX_GROUP, group_cases


@pytest.mark.parametrize(("cases", "threads", "size"), [(16, 2, 2), (60, 2, 8), (10_000, 8, MAX_GROUP), (3, 4, 1)])
def test_groups_keep_the_order_and_give_every_thread_several(cases, threads, size):
    groups = group_cases(list(range(cases)), threads)
    assert [case for group in groups for case in group] == list(range(cases))
    assert {len(group) for group in groups[:-1]} <= {size} and 0 < len(groups[-1]) <= size
    assert len(groups) >= min(cases, GROUPS_PER_THREAD * threads)
