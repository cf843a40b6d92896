"""``gyrotest fleet``: many gyros at once -- the acceptance campaigns of a lot of serials.

Pipeline::

    from gyrotest.fleet import run_fleet, fleet_sheet

    fleet = run_fleet(["lot/campaign_1101.toml", ...], jobs=4)   # or scheduler="local"
    fleet.to_dict()                      # JSON: per-campaign results, lot statistics, outliers
    sheet = fleet_sheet(fleet)           # the summary as a document (Markdown/HTML/PDF)

Modules: :mod:`.core` (one campaign -> its checked spec items; the lot: grouping by serial,
statistics, robust outliers), :mod:`.execute` (serial, process pool or Dask), :mod:`.charts`
(control charts), :mod:`.document` (the summary laid out with the report's renderers).
"""

from __future__ import annotations

from .core import Fleet, analyse_campaign, summarise
from .document import fleet_sheet
from .execute import run_fleet

__all__ = ["Fleet", "analyse_campaign", "fleet_sheet", "run_fleet", "summarise"]
