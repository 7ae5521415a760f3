"""The search's rows in the window manager's results (Blender layer): ``store_results`` writes ranked rows into
``properties.results_of`` in the ranking's order, each with what it names (an action of this file by its read hash
at the search, or a clip file by its identity: ``_row_sources``, through the library item each result came from,
``RankResult.item``)
and the frames it matched; ``SIM_COLUMN``, ``ELASTIC_COLUMN`` and ``LOCAL_COLUMN`` are the keys of the column the
rows are ordered by. See docs/dev/blender_layer.md.
"""

import json

from ..core.io import sources
from .library import ActionItem
from ..properties import results_of

__all__ = ["store_results", "SIM_COLUMN", "ELASTIC_COLUMN", "LOCAL_COLUMN"]


def _row_sources(results):
    """(is_action, clip file spec, target identity, name) per result, through the library item it came from
    (``RankResult.item``): an action's read hash at the search and its name now (a cached entry keeps the name it
    was indexed under: an action renamed since is named as it is now), a file's ``sources.file_identity``."""
    out = []
    for r in results:
        item = r.item
        if isinstance(item, ActionItem):
            out.append((True, "", item.action_key.read_hash if item.action_key is not None else "", item.action))
            continue
        # a whole .blend or .glb holds several clips: FILE#ACTION names this one
        spec = sources.clip_address(item.source if item is not None else r.source, r.name, r.source)[0]
        out.append((False, spec, sources.file_identity(spec), r.name))
    return out


# the results' columns, by the measure's key (their words: core.measure_words); local: the local search's score
# (core.search.local.features.combine)
SIM_COLUMN, ELASTIC_COLUMN, LOCAL_COLUMN = "sim", "elastic", "local"


def store_results(settings, results, query_name, order_by=SIM_COLUMN, query_bones=0, seconds=0.0):
    """Write ranked rows into the window manager's results (``properties.results_of``), in ``results``' order,
    which is ascending in the column ``order_by`` (SIM_COLUMN, ELASTIC_COLUMN or LOCAL_COLUMN) within each tier
    (whole-body matches, then partial ones)."""
    out = results_of()
    kinds = _row_sources(results)
    labels = sources.unique_labels([kind[1] for kind in kinds if not kind[0]])[::-1]
    out.results.clear()
    for r, (is_action, spec, target, name) in zip(results, kinds):
        d = r.as_dict()  # the one row serialiser (core.search.rows): what ``rank --json`` prints for the row
        row = out.results.add()
        row.name = row.clip_name = name
        row.label = name if is_action else labels.pop()
        row.distance = r.distance  # the float itself: the JSON's is None when not finite
        row.has_elastic, row.elastic = d["elastic"] is not None, d["elastic"] or 0.0
        row.approximate, row.frames, row.shared, row.partial = r.approximate, r.frames, r.shared, d["partial"]
        row.is_action, row.spec, row.target, row.written = is_action, spec, target, ""
        row.source = name if is_action else spec
        row.coverage = d["coverage"]  # joints compared / joints both rigs have (core.rigs)
        row.unmapped = ", ".join(d["unmapped"])
        # the matched window, when the ranking reports one (else 0..0: the whole clip, ``frames`` long)
        row.frame_first, row.frame_last = d.get("start") or 0, d.get("end") or 0
        row.window_action = ""
        row.explain = json.dumps(r.explain) if r.explain else ""
        # kept / read apart from the moment's window: Assign and Preview of a trimmed clip give the whole action
        kept, cut = d["trim"], d["trimmed"]
        trimmed = kept is not None  # a trim record: the frames compared when trimming cut some
        row.kept_first, row.kept_last = kept if trimmed else (0, 0)
        row.read_first, row.read_last = (kept[0] - cut[0], kept[1] + cut[1]) if trimmed else (0, 0)
    out.results_index, out.query_name, out.order_by = 0, query_name, order_by
    out.query_bones, out.seconds = query_bones, seconds
