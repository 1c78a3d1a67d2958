"""splitray.KDTree against brute force (bit for bit) and scipy's cKDTree (its conventions)."""

import numpy as np
import pytest
from scipy.spatial import cKDTree

import splitray

BUILDERS = [b for b in splitray.neighbor_index_names() if b in ("vvh", "sah", "median", "brute")]


def distances_squared(points, queries):
    """Our distance in float32 as the library defines it: (dx² + dy²) + dz², no FMA."""
    d = queries[:, None, :] - points[None, :, :]
    sq = d * d
    return (sq[..., 0] + sq[..., 1]) + sq[..., 2]


def brute_knn(points, queries, k):
    """The k nearest by (distance², index), exactly: ties go to the smaller index."""
    d2 = distances_squared(points, queries)
    order = np.lexsort((np.broadcast_to(np.arange(len(points)), d2.shape), d2), axis=-1)[:, :k]
    return np.sqrt(np.take_along_axis(d2, order, 1)), order


@pytest.fixture(scope="module")
def cloud(horse):
    """The horse's vertices (real, clustered, with duplicates) and random queries around them."""
    points = horse[0]
    rng = np.random.default_rng(7)
    lo, hi = points.min(0), points.max(0)
    queries = (lo + rng.random((700, 3)) * (hi - lo)).astype(np.float32)
    queries[:100] = points[rng.integers(0, len(points), 100)]  # queries on data points
    return points, queries


@pytest.mark.parametrize("builder", BUILDERS)
@pytest.mark.parametrize("k", [1, 8])
def test_query_equals_brute_force(cloud, builder, k):
    points, queries = cloud
    d, i = splitray.KDTree(points, builder=builder).query(queries, k=k)
    bd, bi = brute_knn(points, queries, k)
    if k == 1:
        bd, bi = bd[:, 0], bi[:, 0]
    assert d.dtype == np.float64 and i.dtype == np.int64 and d.shape == bd.shape
    np.testing.assert_array_equal(i, bi)
    np.testing.assert_array_equal(d, bd.astype(np.float64))


def test_query_agrees_with_scipy(cloud):
    points, queries = cloud
    ours = splitray.KDTree(points, leafsize=16)
    theirs = cKDTree(points.astype(np.float64), leafsize=16)
    for k in (1, 5, [1, 3, 5]):
        d, i = ours.query(queries, k=k, workers=-1)
        sd, si = theirs.query(queries.astype(np.float64), k=k, workers=-1)
        assert d.shape == sd.shape and i.shape == si.shape and i.dtype == si.dtype
        np.testing.assert_allclose(d, sd, rtol=2e-6, atol=1e-7)
        # Indices differ only where scipy's float64 distances tie with ours in float32.
        differ = i != si
        np.testing.assert_allclose(np.linalg.norm(points[i[differ]] - queries[np.nonzero(differ)[0]], axis=-1),
                                   np.linalg.norm(points[si[differ]] - queries[np.nonzero(differ)[0]], axis=-1),
                                   rtol=1e-5)
        assert differ.mean() < 0.01


def test_query_shapes_bounds_and_missing_neighbours(cloud):
    points, queries = cloud
    tree, ref = splitray.KDTree(points), cKDTree(points)
    d, i = tree.query(queries[0])
    sd, si = ref.query(queries[0])
    assert np.ndim(d) == 0 and np.ndim(i) == 0 and i == si
    d, i = tree.query(queries[0], k=3)
    assert d.shape == (3,) and i.shape == (3,)
    grid = queries[:600].reshape(20, 30, 3)
    d, i = tree.query(grid, k=2)
    assert d.shape == (20, 30, 2)
    bound = float(np.median(ref.query(queries, k=4)[0][:, 3]))
    d, i = tree.query(queries, k=4, distance_upper_bound=bound)
    sd, si = ref.query(queries, k=4, distance_upper_bound=bound)
    np.testing.assert_array_equal(np.isinf(d), np.isinf(sd))
    np.testing.assert_array_equal(i[np.isinf(d)], len(points))
    small = splitray.KDTree(points[:3])
    d, i = small.query(queries[:2], k=5)
    sd, si = cKDTree(points[:3]).query(queries[:2], k=5)
    np.testing.assert_array_equal(i, si)
    np.testing.assert_array_equal(np.isinf(d), np.isinf(sd))


def test_workers_do_not_change_answers(cloud):
    points, queries = cloud
    tree = splitray.KDTree(points)
    one = tree.query(queries, k=8, workers=1)
    for workers in (2, -1):
        many = tree.query(queries, k=8, workers=workers)
        np.testing.assert_array_equal(one[0], many[0])
        np.testing.assert_array_equal(one[1], many[1])


@pytest.mark.parametrize("builder", BUILDERS)
def test_query_ball_point_equals_brute_force(cloud, builder):
    points, queries = cloud
    r = 0.03 * float(np.ptp(points))
    found = splitray.KDTree(points, builder=builder).query_ball_point(queries, r, workers=-1)
    assert found.shape == (len(queries),) and found.dtype == object
    within = distances_squared(points, queries) <= np.float32(r) * np.float32(r)
    for q in range(len(queries)):
        assert found[q] == list(np.nonzero(within[q])[0]), q  # sorted by index (scipy's default)
    assert sum(map(len, found)) > len(queries)


def test_query_ball_point_agrees_with_scipy(cloud):
    points, queries = cloud
    r = 0.02 * float(np.ptp(points))
    ours = splitray.KDTree(points).query_ball_point(queries, r)
    theirs = cKDTree(points).query_ball_point(queries, r)
    differ = [q for q in range(len(queries)) if ours[q] != theirs[q]]
    assert len(differ) <= 2  # only points at distance r within float32 rounding
    counts = splitray.KDTree(points).query_ball_point(queries, r, return_length=True)
    np.testing.assert_array_equal(counts, [len(x) for x in ours])
    single = splitray.KDTree(points).query_ball_point(queries[0], r, return_sorted=True)
    assert isinstance(single, list) and single == ours[0]
    nearest_first = splitray.KDTree(points).query_ball_point(queries[0], r)
    assert sorted(nearest_first) == single
    radii = np.where(np.arange(len(queries)) % 2 == 0, r, r / 2)
    per_query = splitray.KDTree(points).query_ball_point(queries, radii)
    theirs = cKDTree(points).query_ball_point(queries, radii)
    assert sum(per_query[q] != theirs[q] for q in range(len(queries))) <= 2


def test_attributes(cloud):
    points, _ = cloud
    tree = splitray.KDTree(points, leafsize=4)
    assert tree.n == len(points) and tree.m == 3 and tree.leafsize == 4
    assert np.shares_memory(tree.data, points)  # float32 C-contiguous: used in place
    assert splitray.KDTree(points.astype(np.float64)).data.dtype == np.float32


@pytest.mark.parametrize("call,error,words", [
    (lambda p: splitray.KDTree(p[:, :2]), ValueError, "data: expected shape (N, 3), got"),
    (lambda p: splitray.KDTree(p[:0]), ValueError, "data: no points"),
    (lambda p: splitray.KDTree(np.where(p == p[5], np.inf, p)), ValueError, "not finite"),
    (lambda p: splitray.KDTree(p, builder="ball"), ValueError, "builder: unknown 'ball'"),
    (lambda p: splitray.KDTree(p, leafsize=0), ValueError, "leafsize"),
    (lambda p: splitray.KDTree(p.astype(str)), TypeError, "data: expected an array of numbers"),
    (lambda p: splitray.KDTree(p).query(p[:, :2]), ValueError, "x: expected shape (..., 3)"),
    (lambda p: splitray.KDTree(p).query(p, k=0), ValueError, "k: must be at least 1"),
    (lambda p: splitray.KDTree(p).query(p, p=1), ValueError, "p: only the Euclidean"),
    (lambda p: splitray.KDTree(p).query(p, eps=0.1), ValueError, "eps: only exact"),
    (lambda p: splitray.KDTree(p).query(p, workers=0), ValueError, "workers: 0"),
    (lambda p: splitray.KDTree(p).query(np.full((2, 3), np.nan)), ValueError, "x: coordinate 0"),
    (lambda p: splitray.KDTree(p).query_ball_point(p, -1.0), ValueError, "r: expected radii >= 0"),
    (lambda p: splitray.KDTree(p).query_ball_point(p[:4], [1.0, 2.0]), ValueError, "does not broadcast"),
])
def test_errors(cloud, call, error, words):
    with pytest.raises(error) as e:
        call(cloud[0])
    assert words in str(e.value)
