"""Light volumes of ambient cubes, and baking incident light to vertex colours."""
from .grid import MAX_PROBES, ProbeGrid, grid_over
from .io import read_volume, write_volume
from .probes import VolumeSettings, bake_volume
from .volume import AXES, AXIS_VECTORS, LightVolume, compact, expand, sky_volume

__all__ = ["AXES", "AXIS_VECTORS", "MAX_PROBES", "LightVolume", "ProbeGrid", "VolumeSettings", "bake_volume",
           "compact", "expand", "grid_over", "read_volume", "sky_volume", "write_volume"]
