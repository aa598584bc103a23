"""Quantiles from order statistics, with distribution-free intervals.

The interval's ranks come from ``Bin(n, p)`` (:func:`ranks`, :func:`coverage`); Monte Carlo
selects the order statistics of every chunk's kept values at the end without sorting them
(:func:`select_lanes`). Derivation and the selection:
docs/statistics.md#order-statistics-and-their-ranks.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence

import numpy as np

LEVEL = 0.95
#: ``quantiles: 3sigma``: the median and the 3-sigma envelope (the probabilities of a
#: Gaussian's mean -+ 3 std).
#: scipy.stats.norm.cdf(-3), 0.5, norm.cdf(3), as literals so importing this module does not
#: import scipy.stats (tests/test_startup.py checks them against scipy).
THREE_SIGMA = (0.0013498980316300933, 0.5, 0.9986501019683699)


def resolve_levels(value: list[float] | str | None) -> tuple[float, ...] | None:
    """The config's ``quantiles`` as sorted probabilities (``"3sigma"`` expanded)."""
    if value is None:
        return None
    if isinstance(value, str):
        return THREE_SIGMA
    return tuple(sorted(dict.fromkeys(float(p) for p in value)))


def ranks(n: int, p: float, level: float = LEVEL) -> tuple[int, int, int]:
    """1-based ranks ``(r, l, u)`` of the estimate and of the interval's ends (``l`` may be 0,
    ``u`` may be ``n + 1``: unbounded ends)."""
    r = min(max(int(np.ceil(n * p - 1e-12)), 1), n)
    a = (1.0 - level) / 2.0
    lo = binomial_ppf(a, n, p)
    hi = binomial_ppf(1.0 - a, n, p) + 1
    return r, lo, hi


def binomial_ppf(q: float, n: int, p: float) -> int:
    """The smallest ``k`` with ``P(Bin(n, p) <= k) >= q``, as ``scipy.stats.binom.ppf`` (whose
    import cost a Monte Carlo run 0.8 s)."""
    from scipy.special import bdtr

    if q <= 0.0:
        return -1
    if q >= 1.0:
        return n
    def cdf(k: int) -> float:
        return float(bdtr(k, n, p)) if k < n else 1.0

    # start at the normal approximation, then walk to the exact point
    sd = float(np.sqrt(n * p * (1.0 - p)))
    from statistics import NormalDist

    k = min(max(int(np.floor(n * p + NormalDist().inv_cdf(q) * sd)), 0), n)
    step = max(1, int(sd) // 8)
    while k > 0 and cdf(k - 1) >= q:  # too high: move down
        k = max(k - step, 0)
    while cdf(k) < q:  # too low: move up
        k = min(k + step, n)
    # cdf(k) >= q here; refine down to the smallest such k by bisection over the last step
    lo_k = max(k - step, -1)  # cdf(lo_k) < q, or lo_k = -1
    while k - lo_k > 1:
        mid = (k + lo_k) // 2
        if cdf(mid) >= q:
            k = mid
        else:
            lo_k = mid
    return k


def coverage(n: int, p: float, level: float = LEVEL) -> float:
    """Exact coverage of the interval of :func:`ranks` for any continuous distribution."""
    _, lo, hi = ranks(n, p, level)
    from scipy import stats as _st

    return float(_st.binom.cdf(hi - 1, n, p) - _st.binom.cdf(lo - 1, n, p))


def order_statistic_quantiles(y: np.ndarray | Sequence[np.ndarray], levels: tuple[float, ...],
                              level: float = LEVEL) -> tuple[np.ndarray, np.ndarray]:
    """Quantiles ``(q, ...)`` of ``y (n, ...)`` along axis 0 and their intervals
    ``(2, q, ...)``. ``y`` may also be a list of chunks ``(n_i, ...)``, taken as their
    concatenation (which is never built). NaN values (none expected: failed runs are left out
    before) sort last."""
    chunks = [y] if isinstance(y, np.ndarray) else list(y)
    return lane_quantiles(_lane_major(chunks), chunks[0].shape[1:], levels, level)


def lane_quantiles(lanes: Sequence[np.ndarray], shape: tuple[int, ...],
                   levels: tuple[float, ...], level: float = LEVEL
                   ) -> tuple[np.ndarray, np.ndarray]:
    """:func:`order_statistic_quantiles` of values given lane-major: chunks ``(L, n_i)`` whose
    row ``l`` holds the runs of the flattened value ``l`` of ``shape`` (``L = prod(shape)``);
    how Monte Carlo workers hand over the series values they keep for the quantiles."""
    n = sum(c.shape[1] for c in lanes)
    shape = tuple(shape)
    q = len(levels)
    vals = np.full((q,) + shape, np.nan)
    ci = np.full((2, q) + shape, np.nan)
    if n == 0:
        return vals, ci
    rk = [ranks(n, p, level) for p in levels]
    wanted = sorted({k - 1 for r in rk for k in r if 1 <= k <= n})
    values = select_lanes(lanes, wanted).reshape((len(wanted),) + shape)
    picked = dict(zip(wanted, values, strict=True))
    for i, (r, lo, hi) in enumerate(rk):
        vals[i] = picked[r - 1]
        ci[0, i] = picked[lo - 1] if lo >= 1 else -np.inf
        ci[1, i] = picked[hi - 1] if hi <= n else np.inf
    return vals, ci


def _lane_major(chunks: Sequence[np.ndarray]) -> list[np.ndarray]:
    return [np.ascontiguousarray(c.reshape(c.shape[0], -1).T) for c in chunks]


#: stride of the subsample that brackets the wanted ranks; 4 binomial standard deviations of
#: the subsample's rank on each side make a miss (and the fallback) a 1-in-1e4 event per lane.
_STRIDE = 64
_MARGIN_SD = 4.0


def select_order_statistics(chunks: Sequence[np.ndarray], positions: list[int]) -> np.ndarray:
    """``np.sort(np.concatenate(chunks), axis=0)[positions]`` (0-based, ascending positions),
    exactly, without the concatenation or the sort (:func:`select_lanes` of the chunks made
    lane-major)."""
    shape = chunks[0].shape[1:]
    return select_lanes(_lane_major(chunks), positions).reshape((len(positions),) + shape)


def select_lanes(lanes: Sequence[np.ndarray], positions: list[int]) -> np.ndarray:
    """The order statistics at ``positions`` (0-based, ascending) of each row of the
    lane-major chunks ``(L, n_i)`` joined along the runs: ``(len(positions), L)``, exactly.

    Positions closer together than a bracket's width share it. Small inputs and a bracket
    that misses fall back to ``np.partition``; NaN values sort last (as there): they are
    neither below nor inside any bracket, so a wanted rank among them fails the count check
    and takes the fallback.
    """
    n_lanes = lanes[0].shape[0]
    n = sum(c.shape[1] for c in lanes)
    out = np.empty((len(positions), n_lanes))
    if n < 16 * _STRIDE:
        part = np.partition(np.concatenate(lanes, axis=1), positions, axis=1)
        return np.ascontiguousarray(part[:, positions].T)
    sub = np.concatenate([c[:, ::_STRIDE] for c in lanes], axis=1)
    m = sub.shape[1]
    groups = _groups(positions, n, m)
    brackets = [_bracket(group[0], group[-1], n, m) for group in groups]
    # only the brackets' ends need their places (a partition: half a sort's time)
    ends = sorted({i for ab in brackets for i in ab if 0 <= i < m})
    if ends:  # (none when every bracket is unbounded: few runs, wide margins)
        sub = np.partition(sub, ends, axis=1)
    edges = []
    for a, b in brackets:
        low = sub[:, a] if a >= 0 else np.full(n_lanes, -np.inf)
        high = sub[:, b] if b < m else np.full(n_lanes, np.inf)
        # Any values make a bracket (the counts check it) if low <= high, which the inside
        # mask relies on: a NaN end (the subsample's NaN go last) becomes +inf.
        low = np.nan_to_num(low, nan=np.inf, posinf=np.inf, neginf=-np.inf)
        edges.append((low, np.maximum(low, np.nan_to_num(high, nan=np.inf, posinf=np.inf,
                                                         neginf=-np.inf))))
    below, inside = _scan(lanes, edges)
    row = {k: i for i, k in enumerate(positions)}
    for j in range(n_lanes):
        seg = np.concatenate(inside[j])
        for group, (low, high), under in zip(groups, edges, below, strict=True):
            at = [row[k] for k in group]
            # brackets may share an end value (ties), so a value can sit in two of them
            mine = seg if len(groups) == 1 else seg[(seg >= low[j]) & (seg <= high[j])]
            k = np.asarray(group) - under[j]
            if k[0] >= 0 and k[-1] < mine.size:
                out[at, j] = np.partition(mine, k)[k]
            else:  # the bracket missed (a 1-in-1e4 event per lane): select from the lane
                lane = np.concatenate([c[j] for c in lanes])
                out[at, j] = np.partition(lane, group)[group]
    return out


#: columns compared at once, whatever the chunking, so a bracket's compares reuse a block from
#: cache; with many lanes fewer (``_BLOCK_VALUES`` values, at least ``_MIN_COLUMNS`` columns),
#: chunks then only cut, never joined, so no buffer grows with the lanes. Measured:
#: docs/statistics.md#order-statistics-and-their-ranks.
_BLOCK_COLUMNS = 65536
_BLOCK_VALUES = 1 << 20
_MIN_COLUMNS = 8192


def _scan(lanes: Sequence[np.ndarray], edges: list[tuple[np.ndarray, np.ndarray]]
          ) -> tuple[np.ndarray, list[list[np.ndarray]]]:
    """One pass over the values: per bracket ``(low, high)`` (each ``(L,)``, ``low <= high``)
    the count of each lane's values below ``low``, and per lane the values inside any
    bracket (in run order)."""
    n_lanes = lanes[0].shape[0]
    below = np.zeros((len(edges), n_lanes), dtype=np.int64)
    inside: list[list[np.ndarray]] = [[] for _ in range(n_lanes)]
    n = sum(c.shape[1] for c in lanes)
    width = min(max(min(_BLOCK_COLUMNS, _BLOCK_VALUES // n_lanes), _MIN_COLUMNS), n)
    join = n_lanes * width <= _BLOCK_VALUES
    lt, le, keep = (np.empty((n_lanes, width), dtype=bool) for _ in range(3))
    cols = [(low[:, None], high[:, None]) for low, high in edges]
    for block in _blocks(lanes, width, join):
        w = block.shape[1]
        lt_b, le_b, keep_b = lt[:, :w], le[:, :w], keep[:, :w]
        for g, (low, high) in enumerate(cols):
            np.less(block, low, out=lt_b)
            np.less_equal(block, high, out=le_b)
            # a 1-D count_nonzero is a fast popcount; with an axis it is a slow sum
            below[g] += [np.count_nonzero(r) for r in lt_b]
            # low <= high: lt implies le, so le & ~lt is le != lt, one op
            if g == 0:
                np.not_equal(le_b, lt_b, out=keep_b)
            else:
                np.not_equal(le_b, lt_b, out=le_b)
                np.logical_or(keep_b, le_b, out=keep_b)
        for j in range(n_lanes):
            inside[j].append(block[j][keep_b[j]])
    return below, inside


def _blocks(lanes: Sequence[np.ndarray], width: int, join: bool = True
            ) -> Iterator[np.ndarray]:
    """The columns of the chunks in order, as blocks ``(L, <= width)``: views of chunks at
    least ``width`` wide, consecutive narrower chunks joined into one buffer (reused: a block
    is valid until the next is asked for), or each left as it is if not ``join``."""
    buf = np.empty((lanes[0].shape[0], width)) if join else None
    fill = 0
    for c in lanes:
        at, n = 0, c.shape[1]
        while at < n:
            if buf is None or (fill == 0 and n - at >= width):
                yield c[:, at:at + width]
                at += width
                continue
            take = min(width - fill, n - at)
            buf[:, fill:fill + take] = c[:, at:at + take]
            fill, at = fill + take, at + take
            if fill == width:
                yield buf
                fill = 0
    if buf is not None and fill:
        yield buf[:, :fill]


def _bracket(lo_k: int, hi_k: int, n: int, m: int) -> tuple[int, int]:
    """Subsample positions (of ``m``) whose values bracket full-sample positions
    ``lo_k..hi_k`` (of ``n``) with high probability; -1 and ``m`` mean unbounded."""
    def sd(k: int) -> float:
        p = min(max(k / n, 0.0), 1.0)
        return float(np.sqrt(m * p * (1.0 - p)))

    a = int(np.floor(lo_k * m / n - _MARGIN_SD * sd(lo_k))) - 2
    b = int(np.ceil(hi_k * m / n + _MARGIN_SD * sd(hi_k))) + 2
    return max(a, -1), min(b, m)


def _groups(positions: list[int], n: int, m: int) -> list[list[int]]:
    """Wanted positions, split where their brackets would not overlap."""
    groups: list[list[int]] = []
    for k in sorted(positions):
        if groups and _bracket(k, k, n, m)[0] <= _bracket(groups[-1][-1], groups[-1][-1],
                                                         n, m)[1]:
            groups[-1].append(k)
        else:
            groups.append([k])
    return groups


def level_name(p: float) -> str:
    """Column name of a quantile level: ``q0.05``, ``q0.99865``."""
    return f"q{p:.6g}"
