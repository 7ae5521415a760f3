"""Near-duplicate clusters of a library, the pure logic of ``dedupe`` (never imports bpy, dask or matplotlib): a
signature k-NN graph on a common bone tuple (``common_entry``, ``knn_graph``; ``pair_sim`` is ``rank``'s sim^n), the
elastic check of its candidate pairs on the comparison time base (``check_pairs``, owned by ``dedupe_check``), the
thresholds (``relative_threshold``), the same take in another file (``take_vector``, ``is_conversion``: the search's
twin test), complete-linkage ``clusters``, which test a near miss failed (``DedupeResult.failed``) and which copy of
a cluster to keep (``choose_keeper``, owned by ``dedupe_keeper``). See docs/search.md, "Library report (dedupe)".
"""

import time
from dataclasses import dataclass, field, replace
from functools import lru_cache
from typing import Callable, Dict, List, Optional, Sequence, Tuple

import numpy as np

from ..elastic import DEFAULT_DEPTH
from ..errors import ShapeSigError
from ..measure_words import MEASURES, OPTIONS
from ..rigs import JOINTS
from ..signatures.signatures import ZERO_NORM
from .dedupe_check import check_pairs, elastic_check, pair_curves, prepared_pair, srvt_energy, time_map
from .dedupe_keeper import COMMON_RATES, KEEP_TIE, choose_keeper, copy_facts
from .local import take as take_mod
from .local.entry import Take
from .signature.entry import IndexEntry, entry_distance
from .signature.words import word_codes

__all__ = ["DEFAULT_K", "SIM_RATIO", "THRESHOLD_RATIO", "Edge", "DedupeResult", "common_entry", "pair_sim", "knn_graph",
           "pair_curves", "prepared_pair", "time_map", "srvt_energy", "elastic_check", "check_pairs", "relative_threshold", "sample_edges",
           "chain_components", "complete_linkage", "find_duplicates", "serial_map", "copy_facts", "choose_keeper",
           "KEEP_TIE", "COMMON_RATES"]

# neighbours per clip in the signature graph, and the sketch shortlist per clip (exact sim on these only)
DEFAULT_K = 8
POOL_FACTOR = 4
# the gates (measured: docs/search.md, "Library report"): sim^n <= SIM_RATIO * median sim^n of the k-NN edges,
# relative d_S* <= THRESHOLD_RATIO * its median over a sample of DISTRIBUTION_SAMPLE k-NN edges
SIM_RATIO = 0.3
THRESHOLD_RATIO = 0.5
DISTRIBUTION_SAMPLE = 100
# pairs up to CHECK_FACTOR * the sim gate get the elastic check (the near misses are shown in the report)
CHECK_FACTOR = 1.5
RELATIVE = MEASURES["relative"].status  # the second gate in the report's words (core.measure_words)


@dataclass(frozen=True)
class Edge:
    """A candidate pair ``i < j`` (indices into the library's entries) with its sim^n and, once checked, d_S*."""

    i: int
    j: int
    sim: float
    elastic: Optional[float] = None
    relative: Optional[float] = None  # d_S* / sqrt(|q_i|^2 + |q_j|^2) (``elastic_check``)
    take: Optional[float] = None  # the whole takes' distance (``take.take_distances``) when ``is_conversion``
    length: float = 0.0  # |log| of the ratio of the two durations


@dataclass
class DedupeResult:
    """``clusters``: lists of entry indices (two or more members, largest first); ``edges``: the k-NN graph
    (checked pairs carry d_S*); ``sim_threshold``, ``threshold``: the two gates (sim^n, relative d_S*);
    ``rule``: how they were set; ``extra``: pairs checked on demand by the linkage; ``components``: the
    connected components of the confirmed pairs (what chaining would give, for the report); ``take_threshold``:
    the take distance under which two files of other skeletons or formats of one length are one take."""

    clusters: List[List[int]]
    edges: List[Edge]
    sim_threshold: float
    threshold: float
    rule: str
    extra: List[Edge] = field(default_factory=list)
    components: List[List[int]] = field(default_factory=list)
    take_threshold: float = 0.0

    def copy(self, e: Edge) -> bool:
        """The copy test: both gates (sim^n, relative d_S*)."""
        return e.relative is not None and e.sim <= self.sim_threshold and e.relative <= self.threshold

    def twin(self, e: Edge) -> bool:
        """The same take in another file (``is_conversion``): one length, the takes near, the relative d_S* gate."""
        return (e.take is not None and e.relative is not None and e.length <= take_mod.SAME_LENGTH
                and e.take <= self.take_threshold and e.relative <= self.threshold)

    def confirmed(self, e: Edge) -> bool:
        return self.copy(e) or self.twin(e)

    def failed(self, e: Edge) -> str:
        """Which test a pair failed, in one line ('' when it passed): the copy test's first failed gate, and for
        files of other skeletons or formats the same-take test's."""
        if self.confirmed(e):
            return ""
        if e.relative is None:
            return "not checked"
        copy = (f"{MEASURES['sim'].status} {e.sim:.3g} > {self.sim_threshold:.3g}" if e.sim > self.sim_threshold
                else f"{RELATIVE} {e.relative:.3g} > {self.threshold:.3g}")
        if e.take is None:
            return f"copy test: {copy}; same-take test: one skeleton and format (only copies)"
        if e.length > take_mod.SAME_LENGTH:
            twin = f"lengths differ by {np.expm1(e.length):.0%}"
        elif e.take > self.take_threshold:
            twin = f"{MEASURES['take'].status} {e.take:.3g} > {self.take_threshold:.3g}"
        else:
            twin = f"{RELATIVE} {e.relative:.3g} > {self.threshold:.3g}"
        return f"copy test: {copy}; same-take test: {twin}"


# ---------------------------------------------------------------------------------------- stage 1

def _canonical_positions(bones) -> Optional[Tuple[int, ...]]:
    """Positions of ``bones`` in ``rigs.JOINTS`` when they are canonical joints in canonical order, else None."""
    where = {j: i for i, j in enumerate(JOINTS)}
    pos = [where.get(b) for b in bones]
    if any(p is None for p in pos) or any(b <= a for a, b in zip(pos, pos[1:])):
        return None
    return tuple(pos)


def common_entry(entry: IndexEntry) -> IndexEntry:
    """The entry on the common bone tuple ``rigs.JOINTS`` when its bones are canonical joints (see the module
    docstring: the direction is unchanged, only the moving joints' indices move), else the entry itself.
    The sketch is recomputed on the common tuple, so sketches of all mapped rigs are comparable."""
    from .signature.words import sketch

    pos = _canonical_positions(entry.bones)
    if pos is None or entry.bones == JOINTS:
        return entry
    moving = tuple(pos[j] for j in entry.moving)
    sk = entry.sketch if entry.direction is None else sketch(entry.direction, len(JOINTS), moving, entry.level)
    return replace(entry, bones=JOINTS, moving=moving, sketch=sk)


def _sketch_shortlist(group_entries, pool):
    """For each entry of one bone tuple, the indices (into the group) of its ``pool`` nearest by sketch."""
    S = np.stack([e.sketch for e in group_entries]).astype(np.float64)
    sq = (S * S).sum(axis=1)
    D = sq[:, None] + sq[None, :] - 2.0 * (S @ S.T)
    np.fill_diagonal(D, np.inf)
    pool = min(pool, len(group_entries) - 1)
    return np.argpartition(D, pool - 1, axis=1)[:, :pool]


@lru_cache(maxsize=64)
def _word_positions(n_bones, moving, level) -> np.ndarray:
    """Where the log-signature coordinates of ``moving`` sit among those of all ``n_bones`` joints: a word's
    global code (``index.words.word_codes``) does not depend on which other joints move, and a Lyndon word
    over a subset of the letters (kept in order) is one over all of them."""
    full = word_codes(n_bones, tuple(range(n_bones)), level)
    order = np.argsort(full, kind="stable")
    return order[np.searchsorted(full[order], word_codes(n_bones, moving, level))]


@lru_cache(maxsize=1024)
def _letter_positions(n_bones, moving, letters, level) -> np.ndarray:
    """Where the words over ``letters`` (a subset of ``moving``, joint indices in order) sit among the log-signature
    coordinates of ``moving``: its path on those joints alone has the same coordinates there."""
    full = word_codes(n_bones, moving, level)
    order = np.argsort(full, kind="stable")
    return order[np.searchsorted(full[order], word_codes(n_bones, letters, level))]


def pair_sim(a: IndexEntry, b: IndexEntry) -> float:
    """sim^n of two entries as ``rank_clips`` computes it. One bone tuple: ``index.entry_distance`` (entries with
    other moving joints by scattering both directions into the coordinates of all joints: one subtraction,
    positions cached per moving tuple, instead of intersecting word codes per pair). Rigs with other canonical
    joints (``common_entry``): on the joints both rigs have, as ``rank_clips`` compares other skeletons
    (``sim_from_increments`` of ``pair_increments`` on the shared bones; equal, tested): each direction's
    coordinates on the words of its shared moving joints (a Lyndon word over a subset of the letters is one over
    all, and its coordinate is the restricted path's), renormalized. inf for two skeletons without canonical
    joints."""
    if a.bones == b.bones:
        if a.moving == b.moving or a.norm == 0.0 or b.norm == 0.0:
            return entry_distance(a, b)
        return _scattered(len(a.bones), a.level, a.direction, b.direction, a.moving, b.moving)
    pa, pb = _canonical_positions(a.bones), _canonical_positions(b.bones)
    if pa is None or pb is None or a.level != b.level:
        return float("inf")
    n, shared = len(JOINTS), set(pa) & set(pb)
    ma, mb = tuple(pa[j] for j in a.moving), tuple(pb[j] for j in b.moving)  # on the common tuple
    la, lb = tuple(m for m in ma if m in shared), tuple(m for m in mb if m in shared)
    u = (np.asarray(a.direction, np.float64)[_letter_positions(n, ma, la, a.level)] if a.norm > 0 and la
         else np.zeros(0))
    v = (np.asarray(b.direction, np.float64)[_letter_positions(n, mb, lb, b.level)] if b.norm > 0 and lb
         else np.zeros(0))
    nu, nv = _norm(u), _norm(v)
    zu, zv = not nu > ZERO_NORM, not nv > ZERO_NORM
    if zu or zv:
        return 0.0 if (zu and zv) else 1.0  # as signatures.normalized_difference
    return _scattered(n, a.level, u / nu, v / nv, la, lb)


def _scattered(n, level, u, v, ma, mb) -> float:
    """|u - v| for directions ``u`` on the words of joints ``ma`` and ``v`` on those of ``mb`` (of ``n`` joints)."""
    pa, pb = _word_positions(n, tuple(ma), level), _word_positions(n, tuple(mb), level)
    diff = np.zeros(len(word_codes(n, tuple(range(n)), level)))
    diff[pa] = u
    diff[pb] -= v
    return _norm(diff)


def _norm(x) -> float:
    """|x| without BLAS (``np.linalg.norm``'s dot of 100,000 numbers took 27 ms among busy BLAS threads)."""
    return float(np.sqrt((x * x).sum())) if len(x) else 0.0


def take_vector(e: IndexEntry) -> Optional[Take]:
    """The whole take's signature of an entry (``take.take_entry``'s, from the entry's increments: the same curve
    on the same time base), or None for an entry without canonical joints."""
    pos = _canonical_positions(e.bones)
    if pos is None or e.increments is None:
        return None
    inc = np.asarray(e.increments, np.float64)
    dx = np.zeros((max(inc.shape[0], 1), take_mod.CHANNELS))
    for k, j in enumerate(e.moving):
        dx[:inc.shape[0], 3 * pos[j]:3 * pos[j] + 3] = inc[:, k]
    mask = np.zeros(len(JOINTS), np.uint8)
    mask[list(pos)] = 1
    from ..signatures.signatures import increments_log_signature

    return Take(increments_log_signature(dx, 2), mask, max(e.frames - 1, 1) / float(e.fps or 1.0))


def is_conversion(a: IndexEntry, b: IndexEntry) -> bool:
    """Two files that may hold one take converted (another format or skeleton): other mapped joints, or other
    file types. Two files of one skeleton and format are near-duplicates only as copies (the gates)."""
    ext = [str(e.source or e.name).rsplit(".", 1)[-1].split("#")[0].lower() for e in (a, b)]
    return a.bones != b.bones or tuple(a.rig_joints or ()) != tuple(b.rig_joints or ()) or ext[0] != ext[1]


def with_take(e: Edge, a: IndexEntry, b: IndexEntry, ta, tb) -> Edge:
    """``e`` with its takes' distance and length ratio when the pair ``is_conversion`` (``ta``/``tb``: their
    ``take_vector``s)."""
    if ta is None or tb is None or not is_conversion(a, b):
        return e
    length = abs(float(np.log(max(ta.seconds, 1e-9) / max(tb.seconds, 1e-9))))
    return replace(e, take=float(take_mod.take_distances(ta, [tb])[0]), length=length)


def knn_graph(entries: Sequence[IndexEntry], k=DEFAULT_K, pool=None) -> List[Edge]:
    """The candidate graph: for every entry its ``k`` nearest others by exact sim^n among its ``pool``
    (default ``POOL_FACTOR k``) nearest by sketch; entries are compared only within one bone tuple (after
    ``common_entry``), the union of the k-NN edges as Edges ``i < j``, sorted by sim. Entries must be loaded
    (direction in memory)."""
    k = int(k)
    if k < 1:
        raise ShapeSigError(f"k must be at least 1, got {k}")
    pool = max(int(pool or POOL_FACTOR * k), k)
    common = [common_entry(e) for e in entries]
    groups: Dict[tuple, List[int]] = {}
    for n, e in enumerate(common):
        groups.setdefault(e.bones, []).append(n)
    best: Dict[Tuple[int, int], float] = {}
    for members in groups.values():
        if len(members) < 2:
            continue
        short = _sketch_shortlist([common[n] for n in members], pool)
        for a, row in enumerate(short):
            i = members[a]
            dist = sorted((pair_sim(entries[i], entries[members[b]]), members[b]) for b in row)
            for d, j in dist[:k]:
                best[(min(i, j), max(i, j))] = d
    return sorted((Edge(i, j, d) for (i, j), d in best.items()), key=lambda e: (e.sim, e.i, e.j))


# ---------------------------------------------------------------------------------------- stage 2

def relative_threshold(values, ratio) -> float:
    """``ratio`` * the median of the finite values (0 when there are none)."""
    v = np.asarray([x for x in values if x is not None and np.isfinite(x)], np.float64)
    return float(ratio * np.median(v)) if v.size else 0.0


def sample_edges(edges: Sequence[Edge], size=DISTRIBUTION_SAMPLE, seed=0) -> List[Edge]:
    """A reproducible sample of ``size`` edges (all when there are fewer): the elastic distribution's estimate."""
    if len(edges) <= size:
        return list(edges)
    pick = np.random.default_rng(seed).choice(len(edges), size, replace=False)
    return [edges[i] for i in sorted(pick)]


# ---------------------------------------------------------------------------------------- clusters

def chain_components(n, linked_pairs) -> List[List[int]]:
    """Connected components of the confirmed pairs ``(i, j)``: the chaining rule (for comparison)."""
    parent = list(range(n))

    def find(x):
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    for i, j in linked_pairs:
        parent[find(i)] = find(j)
    out: Dict[int, List[int]] = {}
    for x in range(n):
        out.setdefault(find(x), []).append(x)
    return _largest_first(out.values())


def _largest_first(groups):
    return sorted((sorted(g) for g in groups if len(g) > 1), key=lambda g: (-len(g), g[0]))


def complete_linkage(n, linked_pairs, linked: Callable[[int, int], bool]) -> List[List[int]]:
    """Clusters by complete linkage on the confirmed pairs (in the given order, best first): groups A and B
    merge only when ``linked(x, y)`` holds for every x in A, y in B (``linked`` checks pairs that were not
    candidates on demand). Guards against chaining (module docstring)."""
    member = {x: [x] for x in range(n)}
    for i, j in linked_pairs:
        A, B = member[i], member[j]
        if A is B or not all(linked(x, y) for x in A for y in B):
            continue
        A.extend(B)
        for y in B:
            member[y] = A
    return _largest_first({id(g): g for g in member.values()}.values())


# ---------------------------------------------------------------------------------------- the search

def serial_map(fn, args):
    """The sequential mapper: ``[fn(a) for a in args]`` (the Dask layer passes a parallel one)."""
    return [fn(a) for a in args]


def _slim(e: IndexEntry) -> IndexEntry:
    """What a worker needs for the elastic check: the increments (not the direction, up to a MB)."""
    return replace(e, direction=None, sketch=np.zeros(0, np.float32))


def _check_chunk(task):
    pairs, depth = task
    return check_pairs(pairs, depth)


def find_duplicates(entries: Sequence[IndexEntry], k=DEFAULT_K, threshold=None, *, depth=DEFAULT_DEPTH,
                    sim_ratio=SIM_RATIO, ratio=THRESHOLD_RATIO, mapper=serial_map, chunk=16,
                    sample=DISTRIBUTION_SAMPLE, timings=None) -> DedupeResult:
    """Near-duplicate clusters of loaded entries (indices into ``entries``), the two stages of the module
    docstring: the k-NN graph; the sim gate ``sim_ratio`` * median sim^n of its edges; the elastic check of
    the pairs up to ``CHECK_FACTOR`` times the gate and of a sample of ``sample`` edges (``mapper(fn, tasks)``
    runs the checks, in chunks of ``chunk`` pairs); the relative-d_S* gate ``threshold`` (default ``ratio``
    * its median over the sample); complete-linkage clusters of the pairs that pass both gates. ``timings``:
    a dict that receives the seconds of the three stages ("graph", "checks", "linkage")."""
    timings = {} if timings is None else timings
    t0 = time.perf_counter()
    takes = [take_vector(e) for e in entries]
    edges = [with_take(e, entries[e.i], entries[e.j], takes[e.i], takes[e.j]) for e in knn_graph(entries, k)]
    timings["graph"] = time.perf_counter() - t0
    sim_tau = relative_threshold([e.sim for e in edges], sim_ratio)
    take_tau = relative_threshold([e.take for e in edges if e.take is not None], take_mod.TWIN_RATIO)
    picked = sample_edges(edges, sample)
    todo = {(e.i, e.j): e for e in edges if e.sim <= CHECK_FACTOR * sim_tau
            or (e.take is not None and e.take <= CHECK_FACTOR * take_tau and e.length <= take_mod.SAME_LENGTH)}
    todo.update(((e.i, e.j), e) for e in picked)
    todo = sorted(todo.values(), key=lambda e: (e.sim, e.i, e.j))
    tasks = [([(_slim(entries[e.i]), _slim(entries[e.j])) for e in todo[s:s + chunk]], depth)
             for s in range(0, len(todo), max(int(chunk), 1))]
    t0 = time.perf_counter()
    results = [dr for part in mapper(_check_chunk, tasks) for dr in part]
    timings["checks"] = time.perf_counter() - t0
    checked = {(e.i, e.j): replace(e, elastic=d, relative=r) for e, (d, r) in zip(todo, results)}
    edges = [checked.get((e.i, e.j), e) for e in edges]
    if threshold is None:
        tau = relative_threshold([checked[(e.i, e.j)].relative for e in picked], ratio)
        given = f"{ratio:g} x median over {len(picked)} sampled k-NN edges ({tau:.4g})"
    else:
        tau = float(threshold)
        given = f"{tau:g} (given)"
    level = f" ({OPTIONS['level'].status} {entries[0].level})" if entries else ""
    rule = (f"{MEASURES['sim'].status}{level} <= {sim_ratio:g} x median over the k-NN edges ({sim_tau:.4g}); "
            f"{RELATIVE} <= {given}; or, for files of other skeletons or formats, one length (within "
            f"{np.expm1(take_mod.SAME_LENGTH):.0%}), {MEASURES['take'].status} <= {take_mod.TWIN_RATIO:g} x median "
            f"over the k-NN edges ({take_tau:.4g}) and the {RELATIVE} gate")
    out = DedupeResult([], edges, sim_tau, tau, rule, take_threshold=take_tau)
    known = {(e.i, e.j): out.confirmed(e) for e in edges if e.relative is not None}

    def linked(i, j):
        key = (min(i, j), max(i, j))
        if key not in known:  # not a candidate: checked now (both tests)
            a, b = entries[key[0]], entries[key[1]]
            e = with_take(Edge(key[0], key[1], pair_sim(a, b)), a, b, takes[key[0]], takes[key[1]])
            if e.sim <= sim_tau or (e.take is not None and e.take <= take_tau and e.length <= take_mod.SAME_LENGTH):
                d, r = elastic_check(a, b, depth)
                e = replace(e, elastic=d, relative=r)
            out.extra.append(e)
            known[key] = out.confirmed(e)
        return known[key]

    t0 = time.perf_counter()
    confirmed = [(e.i, e.j) for e in sorted((e for e in edges if known.get((e.i, e.j))),
                                             key=lambda e: (e.relative, e.i, e.j))]
    out.clusters = complete_linkage(len(entries), confirmed, linked)
    out.components = chain_components(len(entries), confirmed)
    timings["linkage"] = time.perf_counter() - t0
    return out
