"""splitray.KDTree: nearest neighbours with scipy.spatial.cKDTree's names and answers."""

import numbers

import numpy as np

from . import _core

_ALL = -1


def _workers(workers):
    if not isinstance(workers, numbers.Integral) or isinstance(workers, bool):
        raise TypeError(f"workers: expected an int, got {type(workers).__name__}")
    if workers == -1:
        return _ALL
    if workers < 1:
        raise ValueError(f"workers: {workers} is not a worker count (a positive int, or -1 for all cores)")
    return int(workers)


def _queries(x):
    """x as (queries, leading shape); a single point has leading shape ()."""
    try:
        a = np.asarray(x)
    except Exception as e:  # noqa: BLE001 - anything numpy refuses is the caller's type error
        raise TypeError(f"x: not convertible to a NumPy array ({e})") from None
    if a.dtype.kind not in "fiu":
        raise TypeError(f"x: expected an array of numbers, got dtype {a.dtype}")
    if a.ndim == 0 or a.shape[-1] != 3:
        raise ValueError(f"x: expected shape (..., 3), got {a.shape}")
    lead = a.shape[:-1]
    return a.reshape(-1, 3), lead


def _only_euclidean(p, eps):
    if p != 2:
        raise ValueError(f"p: only the Euclidean distance (p=2) is supported, got {p}")
    if eps != 0:
        raise ValueError(f"eps: only exact answers (eps=0) are supported, got {eps}")


class KDTree:
    """A point kd-tree with the interface of ``scipy.spatial.cKDTree``.

    data: (n, 3) array of points (float32 C-contiguous arrays are used in place, others are
    converted to float32 once: distances are computed in float32, as the C++ library's).
    leafsize: points per leaf. builder: one of :func:`neighbor_index_names` ("vvh", the
    default: the paper's volume-visibility heuristic; "sah", "median", "brute").
    Distances are Euclidean; ties in distance go to the smaller index. Only 3-D points,
    p=2 and eps=0 are supported.
    """

    def __init__(self, data, leafsize=10, builder="vvh"):
        self._core = _core._KDTree(data, int(leafsize), builder)
        self.leafsize = int(leafsize)

    @property
    def n(self):
        """Number of points."""
        return self._core.n

    @property
    def m(self):
        """Dimension of the points (3)."""
        return 3

    @property
    def data(self):
        """The (n, 3) float32 array the tree indexes (not a copy)."""
        return self._core.data

    @property
    def builder(self):
        return self._core.builder

    @property
    def build_ms(self):
        """Build time in milliseconds."""
        return self._core.build_ms

    def query(self, x, k=1, eps=0, p=2, distance_upper_bound=np.inf, workers=1):
        """The k nearest points of each point of x (shape (..., 3)), as scipy's cKDTree.query.

        k: an int (k=1 drops the last axis of the answer) or a sequence of the 1-based ranks
        wanted. Returns (d, i): float64 distances and int64 indices; a neighbour missing
        (fewer than k points, or none closer than distance_upper_bound) is (inf, n).
        workers: threads, -1 = all cores; answers never depend on it.
        """
        _only_euclidean(p, eps)
        threads = _workers(workers)
        if isinstance(k, numbers.Integral) and not isinstance(k, bool):
            if k < 1:
                raise ValueError(f"k: must be at least 1, got {k}")
            ranks, squeeze = np.arange(1, int(k) + 1), k == 1
        else:
            ranks = np.asarray(k)
            if ranks.ndim != 1 or ranks.size == 0 or ranks.dtype.kind not in "iu" or ranks.min() < 1:
                raise ValueError(f"k: expected an int >= 1 or a sequence of ranks >= 1, got {k!r}")
            squeeze = False
        bound = float(distance_upper_bound)
        if np.isnan(bound):
            raise ValueError("distance_upper_bound: is NaN")
        q, lead = _queries(x)
        kmax = int(ranks.max())
        kq = min(kmax, self.n)
        d, i = self._core.query(q, kq, bound, threads)
        if kq < kmax:  # scipy's answer for ranks beyond n
            d = np.concatenate([d, np.full((len(q), kmax - kq), np.inf)], axis=1)
            i = np.concatenate([i, np.full((len(q), kmax - kq), self.n, dtype=np.int64)], axis=1)
        if not (len(ranks) == kmax and ranks[-1] == kmax and np.all(ranks == np.arange(1, kmax + 1))):
            d, i = d[:, ranks - 1], i[:, ranks - 1]
        if squeeze:
            d, i = d[:, 0], i[:, 0]
            return (d.reshape(lead), i.reshape(lead)) if lead else (d[0], i[0])
        shape = lead + (len(ranks),)
        return (d.reshape(shape), i.reshape(shape)) if lead else (d[0], i[0])

    def query_ball_point(self, x, r, p=2.0, eps=0, workers=1, return_sorted=None,
                         return_length=False):
        """Indices of the points within distance r (d <= r) of each point of x, as scipy's.

        r: a radius, or an array broadcast against x's leading shape. For a single point,
        a list; else an object array of lists, shaped like x's leading shape. return_sorted:
        True sorts each list by index, False leaves it nearest first; None (scipy's default)
        sorts multi-point answers only. return_length: the counts instead of the lists.
        """
        _only_euclidean(p, eps)
        threads = _workers(workers)
        q, lead = _queries(x)
        by_index = bool(return_sorted) if return_sorted is not None else bool(lead)
        radii = np.asarray(r, dtype=np.float64)
        if radii.dtype.kind != "f" or np.any(np.isnan(radii)) or np.any(radii < 0):
            raise ValueError(f"r: expected radii >= 0, got {r!r}")
        if radii.ndim == 0:
            out = self._core.query_ball_point(q, float(radii), threads, by_index, return_length)
        else:
            try:
                radii = np.broadcast_to(radii, lead).reshape(-1)
            except ValueError:
                raise ValueError(f"r: shape {radii.shape} does not broadcast to x's {lead}") from None
            out = np.empty(len(q), dtype=np.int64 if return_length else object)
            for value in np.unique(radii):  # one batched search per distinct radius
                rows = np.nonzero(radii == value)[0]
                out[rows] = self._core.query_ball_point(q[rows], float(value), threads, by_index,
                                                        return_length)
        return out.reshape(lead) if lead else out[0]
