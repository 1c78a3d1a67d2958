"""splitray.Scene against brute force, the command-line program and Open3D's conventions."""

import subprocess

import numpy as np
import pytest

import splitray
from conftest import rays_at, shared_file

MISS = np.uint32(2**32 - 1)
STRUCTURES = [(a, b) for a in ("bih", "bvh", "kd") for b in splitray.builder_names(a)]


@pytest.fixture(scope="module")
def reference(horse):
    vertices, triangles = horse
    rays = rays_at(vertices, 3000, seed=1)
    return rays, splitray.Scene(vertices, triangles, accel="brute").cast_rays(rays)


def test_load_mesh(horse):
    vertices, triangles = horse
    assert vertices.dtype == np.float32 and vertices.shape == (8431, 3)
    assert triangles.dtype == np.uint32 and triangles.shape == (16843, 3)
    assert triangles.max() < len(vertices)


@pytest.mark.parametrize("accel,builder", STRUCTURES)
def test_every_structure_equals_brute_force(horse, reference, accel, builder):
    rays, brute = reference
    hits = splitray.Scene(*horse, accel=accel, builder=builder).cast_rays(rays)
    assert (brute["primitive_ids"] != MISS).sum() > 1000  # the rays do hit the horse
    for key in ("t_hit", "primitive_ids", "geometry_ids", "primitive_uvs", "primitive_normals"):
        np.testing.assert_array_equal(hits[key], brute[key], err_msg=f"{accel}/{builder} {key}")


@pytest.mark.parametrize("builder", ["medium", "medium-robust"])
def test_embree_finds_the_same_triangles(horse, reference, builder):
    rays, brute = reference
    scene = splitray.Scene(*horse, accel="embree", builder=builder)
    assert scene.stats["builder"] == builder
    hits = scene.cast_rays(rays)
    same = hits["primitive_ids"] == brute["primitive_ids"]
    assert same.mean() > 0.999  # Embree's own triangle test may differ on shared edges
    np.testing.assert_allclose(hits["t_hit"][same], brute["t_hit"][same], rtol=1e-5)


def test_hits_equal_the_command_line_program(horse, reference, cli, tmp_path):
    rays, _ = reference
    np.save(tmp_path / "rays.npy", rays)
    subprocess.run([cli, "trace", splitray_horse_path(), "--accel", "bvh", "--rays-in",
                    tmp_path / "rays.npy", "--hits-out", tmp_path / "hits.npz"], check=True,
                   capture_output=True)
    expected = np.load(tmp_path / "hits.npz")
    hits = splitray.Scene(*horse, accel="bvh").cast_rays(rays)
    for key in expected.files:
        np.testing.assert_array_equal(hits[key], expected[key], err_msg=key)


def splitray_horse_path():
    from conftest import SOURCE
    return str(SOURCE / "data" / "horse" / "horse.obj.gz")


def test_open3d_conventions(horse, reference):
    vertices, triangles = horse
    rays, brute = reference
    hit = brute["primitive_ids"] != MISS
    assert np.all(np.isinf(brute["t_hit"][~hit]))
    assert np.all(brute["geometry_ids"][hit] == 0) and np.all(brute["geometry_ids"][~hit] == MISS)
    assert np.all(brute["primitive_uvs"][~hit] == 0) and np.all(brute["primitive_normals"][~hit] == 0)
    # The hit point from t equals the one from the barycentrics; the normal is the unit normal.
    tri = vertices[triangles[brute["primitive_ids"][hit]]]
    u, v = brute["primitive_uvs"][hit].T
    from_uv = tri[:, 0] * (1 - u - v)[:, None] + tri[:, 1] * u[:, None] + tri[:, 2] * v[:, None]
    from_t = rays[hit, :3] + brute["t_hit"][hit, None] * rays[hit, 3:]
    np.testing.assert_allclose(from_uv, from_t, atol=1e-3 * np.ptp(vertices))
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    np.testing.assert_allclose(brute["primitive_normals"][hit], n, atol=1e-5)


def test_any_leading_shape_and_threads(horse, reference):
    rays, brute = reference
    scene = splitray.Scene(*horse, accel="kd")
    grid = scene.cast_rays(rays[:3000].reshape(30, 100, 6), nthreads=1)
    assert grid["t_hit"].shape == (30, 100) and grid["primitive_normals"].shape == (30, 100, 3)
    np.testing.assert_array_equal(grid["primitive_ids"].reshape(-1), brute["primitive_ids"])
    one = scene.cast_rays(rays[5])
    assert one["t_hit"].shape == () and one["primitive_uvs"].shape == (2,)
    for workers in (1, 2, -1):
        np.testing.assert_array_equal(scene.cast_rays(rays, nthreads=workers)["t_hit"], brute["t_hit"])


def test_vertices_used_in_place(horse, reference):
    vertices, triangles = horse
    rays, brute = reference
    wide = np.hstack([vertices, np.zeros_like(vertices)])  # rows of 24 bytes
    scene = splitray.Scene(wide[:, :3], triangles, accel="bvh")
    assert np.shares_memory(scene.vertices, wide) and np.shares_memory(scene.triangles, triangles)
    np.testing.assert_array_equal(scene.cast_rays(rays)["primitive_normals"], brute["primitive_normals"])
    converted = splitray.Scene(vertices.astype(np.float64), triangles.astype(np.int64))
    assert converted.vertices.dtype == np.float32 and converted.triangles.dtype == np.uint32
    np.testing.assert_array_equal(converted.cast_rays(rays)["t_hit"], brute["t_hit"])


def test_non_finite_and_zero_rays_miss(horse, reference):
    rays, brute = reference
    bad = rays.copy()  # every third ray broken, in batches large enough for packet paths
    broken = np.arange(len(rays)) % 3 == 0
    kinds = np.arange(len(rays)) % 4
    bad[broken & (kinds == 0), 0] = np.nan
    bad[broken & (kinds == 1), 3] = np.inf
    bad[broken & (kinds == 2), 4] = -np.inf
    bad[broken & (kinds == 3), 3:] = 0
    for accel in splitray.accel_names():
        scene = splitray.Scene(*horse, accel=accel)
        hits = scene.cast_rays(bad)
        assert np.all(hits["primitive_ids"][broken] == MISS) and np.all(np.isinf(hits["t_hit"][broken]))
        assert not scene.test_occlusions(bad)[broken].any()
        same = hits["primitive_ids"][~broken] == brute["primitive_ids"][~broken]
        assert same.all() if accel != "embree" else same.mean() > 0.999, accel


def test_occlusions(horse, reference):
    rays, brute = reference
    scene = splitray.Scene(*horse, accel="bvh")
    hit = brute["primitive_ids"] != MISS
    np.testing.assert_array_equal(scene.test_occlusions(rays), hit)
    assert not scene.test_occlusions(rays, tfar=0.0).any()
    # With the closest hit scaled to t = 0.999 it occludes within tfar = 1; at 1.001 nothing does.
    t = np.where(hit, brute["t_hit"], 1.0).astype(np.float64)
    for factor, expected in ((0.999, True), (1.001, False)):
        scaled = rays.copy()
        scaled[:, 3:] *= (t / factor)[:, None]  # the hit moves to t = factor
        assert (scene.test_occlusions(scaled, tfar=1.0)[hit] == expected).all(), factor


def frames(count):
    folder = shared_file("anim_horse_collapse/frames")
    return [splitray.load_mesh(p) for p in sorted(folder.glob("*.obj.gz"))[:count]]


@pytest.mark.parametrize("accel,how", [("bvh", "refit"), ("kd", "predicted_rebuild"),
                                       ("bih", "rebuild")])
def test_update_follows_an_animation(accel, how):
    sequence = frames(4)
    vertices, triangles = sequence[0]
    scene = splitray.Scene(vertices, triangles, accel=accel)
    for moved, same_triangles in sequence[1:]:
        np.testing.assert_array_equal(same_triangles, triangles)
        assert scene.update(moved) == how
        rays = rays_at(moved, 1500, seed=len(moved))
        brute = splitray.Scene(moved, triangles, accel="brute").cast_rays(rays)
        hits = scene.cast_rays(rays)
        for key in ("t_hit", "primitive_ids", "primitive_normals"):
            np.testing.assert_array_equal(hits[key], brute[key], err_msg=f"{accel} {key}")
    assert scene.stats["prims"] == len(triangles)


def test_stats(horse):
    stats = splitray.Scene(*horse, accel="kd", builder="binned").stats
    assert stats["accel"] == "kd" and stats["builder"] == "binned" and stats["prims"] == 16843
    assert stats["nodes"] > stats["leaves"] > 0 and stats["sah_cost"] > 0
    # Every SAH cost names its constants: the kd-tree's measured defaults, the BVH's 15 / 20.
    assert (stats["sah_kt"], stats["sah_ki"]) == (70.0, 20.0)
    bvh = splitray.Scene(*horse, accel="bvh").stats
    assert (bvh["sah_kt"], bvh["sah_ki"]) == (15.0, 20.0)


@pytest.mark.parametrize("kwargs,error,words", [
    (dict(rays=np.zeros((4, 5), np.float32)), ValueError, "rays: expected shape (..., 6), got (4, 5)"),
    (dict(rays=np.array([["a"] * 6])), TypeError, "rays: expected an array of numbers"),
    (dict(rays=np.zeros((4, 6)), nthreads=-2), ValueError, "nthreads: -2"),
])
def test_bad_rays(horse, kwargs, error, words):
    scene = splitray.Scene(*horse)
    with pytest.raises(error) as e:
        scene.cast_rays(**kwargs)
    assert words in str(e.value)


def test_bad_occlusion_interval(horse):
    with pytest.raises(ValueError, match="tnear, tfar"):
        splitray.Scene(*horse).test_occlusions(np.zeros((1, 6), np.float32), tnear=2, tfar=1)


@pytest.mark.parametrize("make,error,words", [
    (lambda v, f: (v[:, :2], f), ValueError, "vertices: expected shape (N, 3)"),
    (lambda v, f: (v, f[:, :2]), ValueError, "triangles: expected shape (N, 3)"),
    (lambda v, f: (v, f.astype(np.float32)), TypeError, "triangles: expected an array of integers"),
    (lambda v, f: (v, f.astype(np.int64) - 1), ValueError, "triangles: negative index -1"),
    (lambda v, f: (v, f + 10**6), ValueError, "out of range (8431 vertices)"),
    (lambda v, f: (np.where(np.arange(len(v))[:, None] == 7, np.nan, v), f), ValueError, "non-finite"),
    (lambda v, f: (v, f[:0]), ValueError, "no triangles"),
    (lambda v, f: (v, f.astype(np.int64) + 2**33), ValueError, "does not fit 32 bits"),
])
def test_bad_meshes(horse, make, error, words):
    with pytest.raises(error) as e:
        splitray.Scene(*make(*horse))
    assert words in str(e.value)


def test_bad_options(horse):
    with pytest.raises(ValueError, match="accel: unknown structure 'octree'"):
        splitray.Scene(*horse, accel="octree")
    with pytest.raises(ValueError, match="builder: 'fast' is not a builder of accel 'kd'"):
        splitray.Scene(*horse, accel="kd", builder="fast")
    scene = splitray.Scene(*horse)
    with pytest.raises(ValueError, match="an update keeps the mesh's 8431 vertices"):
        scene.update(horse[0][:100])


def test_bad_files(tmp_path):
    with pytest.raises(FileNotFoundError):
        splitray.load_mesh(tmp_path / "missing.obj")
    bad = tmp_path / "bad.obj"
    bad.write_text("v 0 0 0\nv 1 0 0\nf 1 2 9\n")
    with pytest.raises(ValueError, match="bad.obj"):
        splitray.load_mesh(bad)
    with pytest.raises(TypeError):
        splitray.load_mesh(42)
