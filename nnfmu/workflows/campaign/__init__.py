"""Road-test campaigns: events x component variants co-simulated on Dask, scored by rainflow pseudo-damage into one
Parquet table, with a record of the inputs and an HTML summary (`nnfmu batch`)."""

from nnfmu.workflows.campaign.batch import CampaignRun, run_campaign
from nnfmu.workflows.campaign.errors import CampaignError
from nnfmu.workflows.campaign.spec import Campaign, read_campaign

__all__ = ["Campaign", "CampaignError", "CampaignRun", "read_campaign", "run_campaign"]
