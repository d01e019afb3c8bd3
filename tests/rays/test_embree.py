"""The packet tracer (rays/embree.py) against embreex's own one-ray-a-call `run`, an
independent path into the same library: the same hits to the bit, for full and partial
packets, rays aimed at shared edges and corners, rays leaving surfaces, and occlusion just
short of and just past a blocker."""
import numpy as np
import pytest
from embreex import rtcore_scene
from embreex.mesh_construction import TriangleMesh

from patchlight.errors import PatchlightError
from patchlight.rays import embree
from patchlight.rays.embree import TriangleBvh
from patchlight.rays.tracer import Tracer


def _box() -> tuple[np.ndarray, np.ndarray]:
    """A closed unit cube of 12 triangles and a floor quad below it: shared edges and corners."""
    corners = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], np.float32)
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    tris = [t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))]
    floor = np.array([[-3, -1, -3], [3, -1, -3], [3, -1, 3], [-3, -1, 3]], np.float32)
    positions = np.concatenate([corners, floor])
    tris += [(8, 10, 9), (8, 11, 10)]
    return positions, np.array(tris, np.int32)


def _rays(positions: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray]:
    """Random rays from outside and inside the cube, and rays aimed exactly at its
    vertices and edge midpoints (where two or more triangles meet)."""
    rng = np.random.default_rng(7)
    origins = rng.uniform(-2, 3, (count, 3)).astype(np.float32)
    targets = rng.uniform(-0.2, 1.2, (count, 3)).astype(np.float32)
    sharp = np.concatenate([positions[:8], 0.5 * (positions[[0, 0, 0, 7, 7, 7]] + positions[[1, 2, 4, 3, 5, 6]])])
    aimed = np.repeat(sharp, 8, axis=0)[:count]
    targets[: len(aimed)] = aimed
    directions = targets - origins
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    return origins, directions.astype(np.float32)


@pytest.fixture(scope="module")
def scenes():
    positions, indices = _box()
    reference = rtcore_scene.EmbreeScene()
    TriangleMesh(reference, positions, indices)
    return positions, indices, reference, TriangleBvh(positions, indices)


@pytest.mark.parametrize("count", [0, 1, 15, 16, 17, 4099])
def test_closest_hits_equal_embreex_ray_by_ray(scenes, count):
    positions, _, reference, bvh = scenes
    origins, directions = _rays(positions, count)
    tri, u, v, t, normal = bvh.closest(origins, directions)
    if count == 0:
        assert tri.shape == (0,) and normal.shape == (0, 3)
        return
    expected = reference.run(origins, directions, output=1)
    hit = expected["primID"] >= 0
    assert 0 < hit.sum() < count or count < 1000  # large batches both hit and miss
    np.testing.assert_array_equal(tri, expected["primID"])
    np.testing.assert_array_equal(t, expected["tfar"])
    for ours, theirs in ((u, expected["u"]), (v, expected["v"]), (normal, expected["Ng"])):
        np.testing.assert_array_equal(ours[hit], theirs[hit])
        assert not ours[~hit].any()  # escaped rays: zeros, not a packet's leftovers


def test_rays_aimed_at_shared_edges_and_corners_hit(scenes):
    """The robust build is watertight: no ray slips between two triangles of the cube."""
    positions, _, _, bvh = scenes
    origins = np.full((14, 3), [0.5, 0.5, 5.0], np.float32)
    targets = np.concatenate([positions[[1, 3, 5, 7]], 0.5 * (positions[[1, 1, 3, 5]] + positions[[3, 5, 7, 7]]),
                              np.float32([[0.5, 0.5, 1.0]] * 6)])
    directions = targets - origins
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    tri, *_ = bvh.closest(origins, directions.astype(np.float32))
    assert (tri >= 0).all()


def test_occlusion_equals_embreex_short_of_and_past_the_blocker(scenes):
    positions, _, reference, bvh = scenes
    origins, directions = _rays(positions, 999)
    tri, _, _, t, _ = bvh.closest(origins, directions)
    hit = tri >= 0
    tmax = np.where(hit, t, 10.0).astype(np.float32)
    for far in (tmax * np.float32(0.999), tmax * np.float32(1.001), np.full(999, 1e-3, np.float32)):
        expected = reference.run(origins, directions, dists=far.copy(), query="OCCLUDED") >= 0
        np.testing.assert_array_equal(bvh.occluded(origins, directions, far), expected)
    assert bvh.occluded(origins, directions, tmax * np.float32(1.001))[hit].all()
    assert not bvh.occluded(origins, directions, tmax * np.float32(0.999)).any()


def test_the_tracer_traces_through_the_packets_in_chunks_on_both_cores(scenes, monkeypatch):
    monkeypatch.setattr("patchlight.rays.tracer.CHUNK", 64)
    positions, indices, reference, _ = scenes
    origins, directions = _rays(positions, 1000)
    hits = Tracer(positions, indices).intersect(origins, directions)
    np.testing.assert_array_equal(hits.tri, reference.run(origins, directions, output=1)["primID"])


def test_a_missing_library_is_one_clear_error(tmp_path, monkeypatch):
    package = tmp_path / "embreex"
    package.mkdir()
    (package / "__init__.py").write_text("")

    class Spec:
        origin = str(package / "__init__.py")

    monkeypatch.setattr(embree.importlib.util, "find_spec", lambda name: Spec())
    with pytest.raises(PatchlightError, match="carries no Embree 4 library"):
        embree._library_file()


def test_a_library_that_will_not_load_is_one_clear_error(tmp_path, monkeypatch):
    broken = tmp_path / "libembree4.so.4"
    broken.write_text("not a shared library")
    monkeypatch.setattr(embree, "_library_file", lambda: broken)
    monkeypatch.setattr(embree._Api, "_loaded", None)
    with pytest.raises(PatchlightError, match="libembree4.so.4 could not be loaded"):
        TriangleBvh(*_box())


def test_rays_the_kernels_cannot_read_are_refused(scenes):
    *_, bvh = scenes
    origins, directions = _rays(scenes[0], 20)
    for bad in (origins[:, :2], origins.astype(np.float64), np.asfortranarray(origins), origins[:10]):
        with pytest.raises(ValueError, match="contiguous f32"):
            bvh.closest(bad, directions)
    with pytest.raises(ValueError, match="contiguous f32"):
        bvh.occluded(origins, directions, np.ones(1, np.float32))  # one tmax for 20 rays


def test_a_negative_tmax_counts_as_occluded_as_in_embreex(scenes):
    _, _, reference, bvh = scenes
    origins = np.array([[5, 5, 5], [5, 5, 5]], np.float32)
    directions = np.array([[1, 0, 0], [1, 0, 0]], np.float32)  # away from everything
    tmax = np.array([-1, 1], np.float32)
    np.testing.assert_array_equal(bvh.occluded(origins, directions, tmax), [True, False])
    np.testing.assert_array_equal(reference.run(origins, directions, dists=tmax.copy(), query="OCCLUDED") >= 0,
                                  [True, False])


def test_an_error_embree_reports_while_tracing_is_raised(scenes, monkeypatch):
    """What the device reports after a call is raised (the library shipped reports no error a
    test can provoke: its checks of packets are in debug builds alone)."""
    positions, _, _, _ = scenes
    bvh = TriangleBvh(*_box())
    origins, directions = _rays(positions, 20)
    monkeypatch.setattr(bvh._api, "device_error", lambda device: 3)  # RTC_ERROR_INVALID_OPERATION
    with pytest.raises(PatchlightError, match=r"Embree failed to trace rays \(error 3\)"):
        bvh.closest(origins, directions)
    with pytest.raises(PatchlightError, match="error 3"):
        bvh.occluded(origins, directions, np.ones(20, np.float32))


EXIT_HANDLERS_WHILE_TRACING = """
import atexit, os, threading, time
import numpy as np
from patchlight.rays.embree import TriangleBvh
bvh = TriangleBvh(np.array([[0, 0, 1], [1, 0, 1], [0, 1, 1]], np.float32), np.array([[0, 1, 2]], np.int32))
n = 1 << 16
o = np.zeros((n, 3), np.float32) + np.float32([0.2, 0.2, 0])
d = np.zeros((n, 3), np.float32) + np.float32([0, 0, 1])
hits, stop = [], time.monotonic() + 1.0
def trace():
    while time.monotonic() < stop:
        hits.append(int((bvh.closest(o, d)[0] == 0).sum()))
worker = threading.Thread(target=trace)
worker.start()
time.sleep(0.2)
atexit._run_exitfuncs()
worker.join()
print("hits", min(hits), flush=True)
os._exit(0)
"""


def test_the_exit_handlers_leave_a_scene_that_a_thread_still_traces():
    """A stopped command runs the exit handlers, then os._exit (cli.main._end_process), while a
    pool thread may still be tracing: the scene is not released there (it was, and the
    thread crashed the process with SIGSEGV after "interrupted")."""
    import subprocess
    import sys

    run = subprocess.run([sys.executable, "-c", EXIT_HANDLERS_WHILE_TRACING], capture_output=True, text=True,
                         timeout=120)
    assert run.returncode == 0 and run.stdout.split() == ["hits", str(1 << 16)], (run.returncode, run.stderr)
