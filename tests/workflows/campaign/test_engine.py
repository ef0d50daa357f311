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


def test_a_cluster_whose_only_worker_died_ends_in_a_clear_error(quarter_car, tmp_path, monkeypatch):
    """Tasks sent to a scheduler without workers would wait forever: after WAIT_FOR_WORKERS seconds with none the run
    stops with CampaignError naming the wait and how to resume."""
    distributed = pytest.importorskip("distributed")
    import time

    from campaign_helpers import campaign_text, write_campaign

    from nnfmu.workflows.campaign import CampaignError, engine, read_campaign
    from nnfmu.workflows.campaign.cases import expand_cases

    campaign = read_campaign(write_campaign(tmp_path, campaign_text(quarter_car, events=1, variants=("linear",))))
    monkeypatch.setattr(engine, "WAIT_FOR_WORKERS", 2.0)
    with (
        distributed.LocalCluster(n_workers=1, processes=False, dashboard_address=None) as cluster,
        distributed.Client(cluster) as client,
    ):
        client.retire_workers(close_workers=True)
        while client.nthreads():
            time.sleep(0.05)
        started = time.monotonic()
        with pytest.raises(CampaignError, match=r"no workers .*2 s.*run the campaign again"):
            engine.run_dask(client, expand_cases(campaign), campaign.blobs, lambda case, outcome: None)
        assert time.monotonic() - started < 30
