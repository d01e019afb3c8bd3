"""The gather on a (local) Ray cluster gives the same lightmap as the gather in process."""
import numpy as np
import pytest

from patchlight.bake import bake
from patchlight.config import BakeSettings
from patchlight.scene import load_scene

ray = pytest.importorskip("ray")


@pytest.fixture(scope="module")
def local_ray():
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False, configure_logging=False)
    yield
    ray.shutdown()


def test_ray_gather_equals_the_local_gather(local_ray):
    scene = load_scene("cornell")
    here = bake(scene, BakeSettings(resolution=48))
    there = bake(scene, BakeSettings(resolution=48, ray="local"))
    assert there.stats["rays_gather"] == here.stats["rays_gather"]
    np.testing.assert_array_equal(there.status, here.status)
    np.testing.assert_allclose(there.lightmap, here.lightmap, rtol=1e-5, atol=1e-7)
