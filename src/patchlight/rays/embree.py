"""Intel Embree's C API, called from numba kernels in packets of 16 rays.

The library is the one the `embreex` package installs beside itself; its functions are
called through ctypes to build a scene and from nopython kernels to trace. Packets of 16
rays (rtcIntersect16, rtcOccluded16) took 0.6-0.7 of the CPU time of one rtcIntersect1
call a ray (embreex's `run`) on the bakes' closest-hit rays and 0.3 on their shadow rays.
The scene is built as embreex builds it (robust flag, medium quality), and the hits came
out the same to the bit on every ray compared (tests/rays/test_embree.py, and every ray of
the room's and the Cornell box's bakes at 512).

A kernel gets each function as an int64 address and calls it through `_call4`, so numba
can cache the kernels (an address baked into the code would change from process to
process).
"""
from __future__ import annotations

import ctypes
import importlib.util
import weakref
from pathlib import Path

import numba as nb
import numpy as np
from llvmlite import ir
from numba.core import types
from numba.extending import intrinsic

from ..errors import PatchlightError

WIDTH = 16  # rays a packet
INVALID_ID = np.uint32(0xFFFFFFFF)  # RTC_INVALID_GEOMETRY_ID
EVERY_MASK = np.uint32(0xFFFFFFFF)  # a ray's mask: it meets every geometry
NO_HIT_T = np.float32(1e37)  # tfar of a closest-hit ray that escapes
SCENE_FLAG_ROBUST = 1 << 2
BUILD_QUALITY_MEDIUM = 1
GEOMETRY_TRIANGLE = 0
BUFFER_INDEX, BUFFER_VERTEX = 0, 1
FORMAT_UINT3, FORMAT_FLOAT3 = 0x5003, 0x9003
# A RTCRayHit16 as float32 lanes of WIDTH: the ray's fields, then the hit's.
ORG_X, ORG_Y, ORG_Z, TNEAR, DIR_X, DIR_Y, DIR_Z, TIME, TFAR, MASK, RAY_ID, FLAGS = range(12)
NG_X, NG_Y, NG_Z, HIT_U, HIT_V, PRIM_ID, GEOM_ID, INST_ID = range(12, 20)
# The hit ends with a row of instance ids (and one of instance primitive ids) per instance
# level, which Embree writes too: room for 14 levels (Embree's default build has 1).
PACKET_FLOATS = 48 * WIDTH
ALIGN = 64  # bytes: Embree's packets are 64-byte aligned


def _library_file() -> Path:
    """The Embree 4 shared library the embreex wheel carries (embreex.libs on Linux and
    Windows, .dylibs on macOS)."""
    spec = importlib.util.find_spec("embreex")
    if spec is None or spec.origin is None:
        raise PatchlightError("Embree is missing: `pip install embreex` installs it")
    package = Path(spec.origin).parent
    for folder in (package.parent / "embreex.libs", package / ".dylibs", package):
        found = sorted(folder.glob("*embree4*")) if folder.is_dir() else []
        if found:
            return found[0]
    raise PatchlightError(f"embreex at {package} carries no Embree 4 library (embreex.libs/*embree4*)")


class _Api:
    """The C functions, declared once per process on first use (every pointer an int64)."""

    _loaded = None

    def __init__(self):
        path = _library_file()
        try:
            lib = ctypes.CDLL(str(path))
        except OSError as exc:
            raise PatchlightError(f"Embree's library {path} could not be loaded ({exc})") from None
        p, i, u, s = ctypes.c_uint64, ctypes.c_int, ctypes.c_uint, ctypes.c_size_t

        def fn(name, restype, *argtypes):
            f = getattr(lib, name)
            f.restype, f.argtypes = restype, list(argtypes)
            return f

        self.new_device = fn("rtcNewDevice", p, ctypes.c_char_p)
        self.device_error = fn("rtcGetDeviceError", i, p)
        self.release_device = fn("rtcReleaseDevice", None, p)
        self.new_scene = fn("rtcNewScene", p, p)
        self.scene_flags = fn("rtcSetSceneFlags", None, p, i)
        self.scene_quality = fn("rtcSetSceneBuildQuality", None, p, i)
        self.commit_scene = fn("rtcCommitScene", None, p)
        self.release_scene = fn("rtcReleaseScene", None, p)
        self.new_geometry = fn("rtcNewGeometry", p, p, i)
        self.geometry_quality = fn("rtcSetGeometryBuildQuality", None, p, i)
        self.new_buffer = fn("rtcSetNewGeometryBuffer", p, p, i, u, i, s, s)
        self.commit_geometry = fn("rtcCommitGeometry", None, p)
        self.attach_geometry = fn("rtcAttachGeometry", u, p, p)
        self.release_geometry = fn("rtcReleaseGeometry", None, p)
        address = lambda name: ctypes.cast(getattr(lib, name), ctypes.c_void_p).value  # noqa: E731
        self.intersect16 = address("rtcIntersect16")
        self.occluded16 = address("rtcOccluded16")
        self.lib = lib

    @classmethod
    def get(cls) -> _Api:
        if cls._loaded is None:
            cls._loaded = _Api()
        return cls._loaded


class TriangleBvh:
    """One Embree scene of a triangle soup, built at construction: positions (V, 3) f32,
    indices (T, 3) i32 (ids of the hits index `indices`). Released when garbage-collected, not
    at exit."""

    def __init__(self, positions: np.ndarray, indices: np.ndarray):
        api = _Api.get()
        self._api = api
        device = api.new_device(None)
        if not device:
            raise PatchlightError("Embree could not start (rtcNewDevice failed)")
        scene = api.new_scene(device)
        self._release = weakref.finalize(self, _release, api, device, scene)
        self._release.atexit = False  # run by the exit handlers, it crashed a pool thread still tracing in it
        geometry = scene and api.new_geometry(device, GEOMETRY_TRIANGLE)
        if not geometry:
            raise PatchlightError(f"Embree could not make a scene (error {api.device_error(device)})")
        api.scene_flags(scene, SCENE_FLAG_ROBUST)
        api.scene_quality(scene, BUILD_QUALITY_MEDIUM)
        api.geometry_quality(geometry, BUILD_QUALITY_MEDIUM)
        for kind, form, array in ((BUFFER_VERTEX, FORMAT_FLOAT3, np.ascontiguousarray(positions, np.float32)),
                                  (BUFFER_INDEX, FORMAT_UINT3, np.ascontiguousarray(indices, np.uint32))):
            target = api.new_buffer(geometry, kind, 0, form, 12, len(array))
            if not target:
                api.release_geometry(geometry)
                raise PatchlightError(f"Embree could not hold {len(array):,} {'vertices' if kind else 'triangles'} "
                                      f"(error {api.device_error(device)})")
            ctypes.memmove(target, array.ctypes.data, array.nbytes)
        api.commit_geometry(geometry)
        api.attach_geometry(scene, geometry)
        api.release_geometry(geometry)  # the scene holds it
        api.commit_scene(scene)
        error = api.device_error(device)
        if error:
            raise PatchlightError(f"Embree could not build the scene of {len(indices):,} triangles (error {error})")
        self.scene, self._device = scene, device

    def closest(self, origins: np.ndarray, directions: np.ndarray):
        """Closest hits of contiguous (N, 3) f32 rays from t = 0: tri (N,) i32 (-1: escaped),
        u, v, t (N,) f32, normal (N, 3) f32 (the triangle's geometric normal, its winding's,
        unnormalised); where a ray escaped, t = 1e37 and u, v, normal are 0."""
        _check_rays(origins, directions)
        return self._checked(closest_hits(self._api.intersect16, self.scene, origins, directions))

    def occluded(self, origins: np.ndarray, directions: np.ndarray, tmax: np.ndarray) -> np.ndarray:
        """(N,) bool: something lies on each contiguous (N, 3) f32 ray in (0, tmax (N,) f32);
        a ray of tmax < 0 counts as occluded (Embree leaves it untraced), as in embreex."""
        _check_rays(origins, directions, tmax)
        return self._checked(occluded_rays(self._api.occluded16, self.scene, origins, directions, tmax))

    def occluding(self, kernel, *args):
        """kernel(occluded16, scene, *args): a function whose nopython kernel makes shadow
        rays and traces them itself in packets (`occlude_packet`) through rtcOccluded16 at
        address occluded16; its result, Embree's errors raised as for `occluded`."""
        return self._checked(kernel(self._api.occluded16, self.scene, *args))

    def _checked(self, result):
        """result, unless Embree refused a call on this thread (a library built without ray
        packets would leave every ray unanswered rather than fail)."""
        error = self._api.device_error(self._device)
        if error:
            raise PatchlightError(f"Embree failed to trace rays (error {error})")
        return result


def _check_rays(origins, directions, tmax=None) -> None:
    """ValueError unless the rays are what the kernels read without bounds checks: origins
    and directions (N, 3) and tmax (N,), all f32 and contiguous."""
    arrays = (origins, directions) if tmax is None else (origins, directions, tmax)
    shapes = [(len(origins), 3), (len(origins), 3), (len(origins),)][:len(arrays)]
    if any(not isinstance(a, np.ndarray) or a.shape != shape or a.dtype != np.float32 or not a.flags.c_contiguous
           for a, shape in zip(arrays, shapes)):
        raise ValueError("rays must be contiguous f32 arrays: origins and directions (N, 3), tmax (N,)")


def _release(api: _Api, device: int, scene: int) -> None:
    if scene:
        api.release_scene(scene)
    api.release_device(device)


@intrinsic
def _call4(typingctx, function, a, b, c):
    """Call the C function at int64 address `function` with four int64 arguments (pointers
    in the first place: valid mask, scene, packet, arguments; the last is NULL)."""
    sig = types.void(types.int64, types.int64, types.int64, types.int64)

    def codegen(context, builder, signature, args):
        i64 = ir.IntType(64)
        fnty = ir.FunctionType(ir.VoidType(), [i64, i64, i64, i64])
        target = builder.inttoptr(args[0], fnty.as_pointer())
        builder.call(target, [args[1], args[2], args[3], ir.Constant(i64, 0)])
        return context.get_dummy_value()

    return sig, codegen


@nb.njit(cache=True, nogil=True, inline="always")
def _aligned_words(count):
    """(count,) f32 zeros whose data starts on an ALIGN-byte boundary."""
    raw = np.zeros(count + ALIGN // 4, np.float32)
    skip = ((-raw.ctypes.data) % ALIGN) // 4
    return raw[skip:skip + count]


@nb.njit(cache=True, nogil=True, inline="always")
def _load_packet(packet, bits, valid, origins, directions, far, start, n):
    """Rays start..start+n-1 into the packet's lanes (the rest switched off)."""
    for k in range(WIDTH):
        if k < n:
            i = start + k
            valid[k] = -1
            packet[ORG_X * WIDTH + k] = origins[i, 0]
            packet[ORG_Y * WIDTH + k] = origins[i, 1]
            packet[ORG_Z * WIDTH + k] = origins[i, 2]
            packet[TNEAR * WIDTH + k] = 0.0
            packet[DIR_X * WIDTH + k] = directions[i, 0]
            packet[DIR_Y * WIDTH + k] = directions[i, 1]
            packet[DIR_Z * WIDTH + k] = directions[i, 2]
            packet[TIME * WIDTH + k] = 0.0
            packet[TFAR * WIDTH + k] = far[i] if far.shape[0] else NO_HIT_T
            bits[MASK * WIDTH + k] = EVERY_MASK
            bits[RAY_ID * WIDTH + k] = 0
            bits[FLAGS * WIDTH + k] = 0
            bits[PRIM_ID * WIDTH + k] = INVALID_ID
            bits[GEOM_ID * WIDTH + k] = INVALID_ID
            bits[INST_ID * WIDTH + k] = INVALID_ID
        else:
            valid[k] = 0


@nb.njit(cache=True, nogil=True)
def closest_hits(intersect16, scene, origins, directions):
    """`TriangleBvh.closest` through rtcIntersect16 at address intersect16."""
    n = origins.shape[0]
    tri = np.empty(n, np.int32)
    u = np.empty(n, np.float32)
    v = np.empty(n, np.float32)
    t = np.empty(n, np.float32)
    normal = np.empty((n, 3), np.float32)
    packet = _aligned_words(PACKET_FLOATS)
    bits = packet.view(np.uint32)
    valid = _aligned_words(WIDTH).view(np.int32)
    no_far = np.zeros(0, np.float32)
    for start in range(0, n, WIDTH):
        m = min(WIDTH, n - start)
        _load_packet(packet, bits, valid, origins, directions, no_far, start, m)
        _call4(intersect16, valid.ctypes.data, scene, packet.ctypes.data)
        for k in range(m):
            i = start + k
            prim = bits[PRIM_ID * WIDTH + k]
            hit = prim != INVALID_ID
            tri[i] = np.int32(prim) if hit else -1
            t[i] = packet[TFAR * WIDTH + k]
            u[i] = packet[HIT_U * WIDTH + k] if hit else 0.0
            v[i] = packet[HIT_V * WIDTH + k] if hit else 0.0
            normal[i, 0] = packet[NG_X * WIDTH + k] if hit else 0.0
            normal[i, 1] = packet[NG_Y * WIDTH + k] if hit else 0.0
            normal[i, 2] = packet[NG_Z * WIDTH + k] if hit else 0.0
    return tri, u, v, t, normal


@nb.njit(cache=True, nogil=True, inline="always")
def packet_memory():
    """(packet, valid): the aligned lanes of one packet, for `occlude_packet`; made once per
    kernel call and reused for every packet."""
    return _aligned_words(PACKET_FLOATS), _aligned_words(WIDTH).view(np.int32)


@nb.njit(cache=True, nogil=True, inline="always")
def occlude_packet(occluded16, scene, packet, valid, origins, directions, tmax, n, blocked):
    """Rays 0..n-1 (n <= WIDTH) of origins, directions (>= n, 3) f32 and tmax (>= n,) f32
    through rtcOccluded16 at address occluded16 in one packet (`packet_memory`): blocked[k]
    True where something lies on ray k (Embree sets an occluded ray's tfar to -inf). For
    kernels that make their shadow rays themselves and trace them as they go."""
    _load_packet(packet, packet.view(np.uint32), valid, origins, directions, tmax, 0, n)
    _call4(occluded16, valid.ctypes.data, scene, packet.ctypes.data)
    for k in range(n):
        blocked[k] = packet[TFAR * WIDTH + k] < 0.0


@nb.njit(cache=True, nogil=True)
def occluded_rays(occluded16, scene, origins, directions, tmax):
    """`TriangleBvh.occluded` through rtcOccluded16 at address occluded16 (`occlude_packet`)."""
    n = origins.shape[0]
    out = np.empty(n, np.bool_)
    packet, valid = packet_memory()
    for start in range(0, n, WIDTH):
        occlude_packet(occluded16, scene, packet, valid, origins[start:], directions[start:], tmax[start:],
                       min(WIDTH, n - start), out[start:])
    return out
