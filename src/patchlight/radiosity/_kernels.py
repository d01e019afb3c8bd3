"""Numba kernels of the gather: the item buffer lookup and the rows of F it makes."""
from __future__ import annotations

import numba as nb
import numpy as np
from llvmlite import ir
from numba.core import cgutils, types
from numba.extending import intrinsic, overload

from ..atlas.raster import sub_texel_cells, texel_points
from ..imaging.halves import half_bits
from ..rays.embree import WIDTH, occlude_packet, packet_memory
from ..rays.inside import is_back_face
from ..rays.tracer import faces_ray

SKY = -1        # the ray escaped: it sees the sky
BACK_FACE = -2  # the ray hit a triangle from behind: the patch may lie inside geometry
LOST = -3       # the hit's lightmap texel is covered by no patch
NEIGHBOURS = np.array([[0, -1], [0, 1], [-1, 0], [1, 0], [-1, -1], [-1, 1], [1, -1], [1, 1]], np.int64)



@nb.njit(cache=True, nogil=True)
def wall_pairs(index, inside, texel_y, texel_x):
    """The neighbours between which each patch inside geometry (inside (N,) bool) is looked
    through: its 8-neighbours (NEIGHBOURS order) that are covered (index (H, W), -1 where not)
    and not inside, the first of them paired with each other one. Returns (P,) i64 each
    pair's patch inside, its first neighbour and the other, patch by patch in id order:
    counted, then written, with no per-neighbour arrays."""
    height, width = index.shape
    pairs = np.empty((3, 0), np.int64)
    for writing in (False, True):
        count = 0
        for p in range(inside.shape[0]):
            if not inside[p]:
                continue
            first = -1
            for k in range(NEIGHBOURS.shape[0]):
                y, x = texel_y[p] + NEIGHBOURS[k, 0], texel_x[p] + NEIGHBOURS[k, 1]
                if y < 0 or y >= height or x < 0 or x >= width:
                    continue
                s = index[y, x]
                if s < 0 or inside[s]:
                    continue
                if first < 0:
                    first = s
                elif s != first:
                    if writing:
                        pairs[0, count], pairs[1, count], pairs[2, count] = p, first, s
                    count += 1
        if not writing:
            pairs = np.empty((3, count), np.int64)
    return pairs[0], pairs[1], pairs[2]


PREFETCH_AHEAD = 32  # rays: how far ahead a sweep asks for the table entry a later ray reads


@intrinsic
def _prefetch(typingctx, array, i):
    """Ask the CPU to bring array[i] (1-d) into its caches ahead of a read: a hint
    (llvm.prefetch), never a fault, so i may lie outside the array."""
    def codegen(context, builder, signature, args):
        array_type = signature.args[0]
        ptr = cgutils.get_item_pointer(context, builder, array_type, context.make_array(array_type)(
            context, builder, args[0]), [args[1]], wraparound=False)
        byte_ptr, i32 = ir.IntType(8).as_pointer(), ir.IntType(32)
        fn = builder.module.declare_intrinsic("llvm.prefetch", [byte_ptr],
                                              ir.FunctionType(ir.VoidType(), [byte_ptr, i32, i32, i32]))
        builder.call(fn, [builder.bitcast(ptr, byte_ptr), i32(0), i32(3), i32(1)])  # a read, kept close, data
        return context.get_dummy_value()
    return types.void(array, i), codegen


@intrinsic
def _void_pointer(typingctx, address):
    """An int64 address (`address_table`) as a void pointer, for nb.carray."""
    def codegen(context, builder, signature, args):
        return builder.inttoptr(args[0], cgutils.voidptr_t)
    return types.voidptr(types.int64), codegen


def address_table(arrays: list[np.ndarray]) -> np.ndarray:
    """(2, K) int64: the address and the length of each of K 1-d C-contiguous arrays, which a
    kernel views again with nb.carray(_void_pointer(...)): how a kernel takes a list of arrays
    without numba's typed List, whose own functions numba compiles anew in every process
    (0.65 s at each start) where these kernels load from its cache. The caller keeps the
    arrays alive until the kernel returns."""
    table = np.zeros((2, len(arrays)), np.int64)
    for k, array in enumerate(arrays):
        if array.ndim != 1 or not array.flags.c_contiguous:
            raise ValueError("address_table takes 1-d C-contiguous arrays")
        table[0, k], table[1, k] = array.ctypes.data, len(array)
    return table


TEXEL_BLOCK = 32  # texels per word of a texel-rank table (coverage bits below, rank above)


def texel_ranks(index: np.ndarray) -> np.ndarray:
    """(H, ceil(W / 32)) u64 texel-rank table of a patch index (H, W) i32 whose patch ids run
    0, 1, ... over its covered texels in (y, x) order (`Patches` rows): each word holds the
    coverage of 32 texels of a row in its low 32 bits (texel x at bit x % 32) and, above, the
    id of the first patch at or after the word's first texel. 1/16 of the index's bytes, so
    the item buffer's random look-ups stay in a core's cache (a 2048 map: 1 MiB, not 16)."""
    height, width = index.shape
    covered = np.zeros((height, -(-width // TEXEL_BLOCK) * TEXEL_BLOCK), bool)
    if covered.size >= 2**31:
        raise ValueError("a lightmap of 2^31 texels or more: `resolve_hits` numbers texels in int32")
    covered[:, :width] = index >= 0
    if not np.array_equal(index[covered[:, :width]], np.arange(np.count_nonzero(covered), dtype=np.int32)):
        raise ValueError("patch ids do not follow their texels in (y, x) order")
    blocks = covered.reshape(height, -1, TEXEL_BLOCK)
    bits = np.packbits(blocks, axis=2, bitorder="little").view("<u4")[..., 0].astype(np.uint64)
    count = blocks.sum(axis=2, dtype=np.uint64).ravel()
    first = (np.cumsum(count) - count).reshape(bits.shape)
    return bits | (first << np.uint64(32))


@intrinsic
def _bit_count(typingctx, x):
    """Set bits of x (u64): one popcnt instruction (llvm.ctpop; the shift-and-mask sum it
    replaces took a dozen)."""
    if x != types.uint64:
        return None

    def codegen(context, builder, signature, args):
        i64 = ir.IntType(64)
        return builder.call(builder.module.declare_intrinsic("llvm.ctpop", [i64], ir.FunctionType(i64, [i64])), [args[0]])
    return types.uint64(x), codegen


def _texel_patch(index, y, x):
    """The patch id of texel (y, x) of `index` (H, W) i32 or its `texel_ranks`; -1 uncovered."""


@overload(_texel_patch, inline="always")
def _texel_patch_typed(index, y, x):
    if index.dtype != types.uint64:
        return lambda index, y, x: index[y, x]

    def ranked(index, y, x):
        return _ranked(index[y, x // TEXEL_BLOCK], x % TEXEL_BLOCK)
    return ranked


@nb.njit(cache=True)
def _ranked(word, bit):
    """The patch id of texel `bit` (0..31) of a `texel_ranks` word; -1 uncovered."""
    bit = np.uint64(bit)
    if (word >> bit) & np.uint64(1) == 0:
        return -1
    below = word & ((np.uint64(1) << bit) - np.uint64(1))
    return np.int64(word >> np.uint64(32)) + np.int64(_bit_count(below))


@nb.njit(cache=True, inline="always")
def _patch_at(t, u, v, tri_uv1, width, height, index):
    """The patch under point (u, v) (barycentrics of corners 1 and 2) of triangle t: the
    lightmap texel under its TEXCOORD_1 (`_texel_at`), or the nearest covered texel of its
    3 x 3 neighbourhood (`_patch_near`); LOST when none is covered.
    index: the (H, W) patch index or its `texel_ranks`."""
    y, x = _texel_at(t, u, v, tri_uv1, width, height)
    return _patch_near(index, y, x, _texel_patch(index, y, x), width, height)


@nb.njit(cache=True, inline="always")
def _texel_at(t, u, v, tri_uv1, width, height):
    """(y, x) the lightmap texel of a width x height map under point (u, v) of triangle t."""
    w0 = 1.0 - u - v
    su = w0 * tri_uv1[t, 0, 0] + u * tri_uv1[t, 1, 0] + v * tri_uv1[t, 2, 0]
    sv = w0 * tri_uv1[t, 0, 1] + u * tri_uv1[t, 1, 1] + v * tri_uv1[t, 2, 1]
    return min(max(int(sv * height), 0), height - 1), min(max(int(su * width), 0), width - 1)


@nb.njit(cache=True, inline="always")
def _patch_near(index, y, x, found, width, height):
    """`found`, the patch of texel (y, x), when it is covered (>= 0), else the patch of the
    first covered texel of its neighbourhood: the four sides, then the corners; LOST when none."""
    for k in range(8):
        if found >= 0:
            break
        yy, xx = y + NEIGHBOURS[k, 0], x + NEIGHBOURS[k, 1]
        if 0 <= yy < height and 0 <= xx < width:
            found = _texel_patch(index, yy, xx)
    return found if found >= 0 else LOST


@nb.njit(cache=True, nogil=True)
def resolve_hits(tri, normal, dirs, u, v, two_sided, tri_uv1, width, height, ranks):
    """The item buffer: the patch each ray sees, or SKY / BACK_FACE / LOST. (R,) i32.

    tri, normal, u, v: the tracer's closest hits (`Hits`) of rays along dirs (R, 3) f32;
    two_sided: (T,) bool, triangles whose back is an ordinary surface (glTF doubleSided): a
    hit on it is a hit, never BACK_FACE; tri_uv1: (T, 3, 2) lightmap UVs of each triangle's
    corners; ranks: the `texel_ranks` of the (H, W) patch index.
    """
    out = np.empty(tri.shape[0], np.int32)
    pitch = ranks.shape[1] * TEXEL_BLOCK
    for i in range(tri.shape[0]):  # first the texel each hit lies on, y * pitch + x (< 2^31)
        t = tri[i]
        if t < 0:
            out[i] = SKY
        elif is_back_face(t, faces_ray(normal, dirs, i), two_sided):
            out[i] = BACK_FACE
        else:
            y, x = _texel_at(t, u[i], v[i], tri_uv1, width, height)
            out[i] = y * pitch + x
    words = ranks.reshape(-1)
    for i in range(out.shape[0]):  # then its patch: table reads that no branch or hit waits on
        if i + PREFETCH_AHEAD < out.shape[0] and out[i + PREFETCH_AHEAD] >= 0:
            _prefetch(words, out[i + PREFETCH_AHEAD] // TEXEL_BLOCK)
        k = out[i]
        if k >= 0:
            found = _ranked(words[k // TEXEL_BLOCK], k % TEXEL_BLOCK)
            out[i] = found if found >= 0 else _patch_near(ranks, k // pitch, k % pitch, found, width, height)
    return out


@nb.njit(cache=True, inline="always")
def _hash_uniform(key, dim):
    """A uniform float in [0, 1) from two integers (splitmix64 of their mix): the same
    numbers for the same texel and sample, whichever thread or chunk draws them."""
    z = np.uint64(key) * np.uint64(0x9E3779B97F4A7C15) + np.uint64(dim) * np.uint64(0xD1B54A32D192ED03)
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    z = z ^ (z >> np.uint64(31))
    return float(z >> np.uint64(11)) * (1.0 / 9007199254740992.0)


@nb.njit(cache=True, inline="always")
def _shuffle(perms, key, draws):
    """Fill each row q of perms (Q, n) with a pseudo-random permutation of 0..n-1 (Fisher-Yates
    on _hash_uniform at dims q * n + 1 .. q * n + n - 1); draws (Q, n) i64 scratch: every swap's
    partner is drawn first, a loop of independent hashes, then the rows' swaps interleaved
    (each row's chain of swaps waits on itself alone)."""
    q_count, n = perms.shape
    for q in range(q_count):
        for i in range(1, n):
            draws[q, i] = int(_hash_uniform(key, q * n + i) * (i + 1))
        for i in range(n):
            perms[q, i] = i
    for i in range(n - 1, 0, -1):
        for q in range(q_count):
            j = draws[q, i]
            perms[q, i], perms[q, j] = perms[q, j], perms[q, i]


@nb.njit(cache=True, inline="always")
def _divided(x, count, inv_count):
    """x / count, as the product x * inv_count where inv_count = 1 / count > 0 is exact (count
    a power of two: the same number, without a division; inv_count 0 otherwise)."""
    return x * inv_count if inv_count > 0.0 else x / count


@nb.njit(cache=True, inline="always")
def power_heuristic(n_a, pdf_a, n_b, pdf_b):
    """Veach's power heuristic (beta 2): the weight of technique a, n_a samples at pdf_a,
    beside technique b; weights of a and b for the same direction sum to 1."""
    a = n_a * pdf_a
    b = n_b * pdf_b
    return a * a / (a * a + b * b) if a > 0.0 else 0.0


UV_SLACK = 1e-6  # texels: how far a sample's lightmap UV may stray off its triangle's by rounding, and more


@nb.njit(cache=True, nogil=True)
def uniform_patches(uv, width, height, index, emission):
    """(M,) i64 for each of M triangles with lightmap UVs uv (M, 3, 2) f32: a patch whose
    emission (N, 3) every point of the triangle reads through `_patch_at` (every texel of its
    UV bounding box, UV_SLACK wider, is covered and all emit the same), or -1 where they
    differ; index: the (H, W) patch index."""
    out = np.full(uv.shape[0], -1, np.int64)
    for e in range(uv.shape[0]):
        u_lo = min(uv[e, 0, 0], uv[e, 1, 0], uv[e, 2, 0]) * width - UV_SLACK
        u_hi = max(uv[e, 0, 0], uv[e, 1, 0], uv[e, 2, 0]) * width + UV_SLACK
        v_lo = min(uv[e, 0, 1], uv[e, 1, 1], uv[e, 2, 1]) * height - UV_SLACK
        v_hi = max(uv[e, 0, 1], uv[e, 1, 1], uv[e, 2, 1]) * height + UV_SLACK
        x0, x1 = min(max(int(np.floor(u_lo)), 0), width - 1), min(max(int(np.floor(u_hi)), 0), width - 1)
        y0, y1 = min(max(int(np.floor(v_lo)), 0), height - 1), min(max(int(np.floor(v_hi)), 0), height - 1)
        first = index[y0, x0]
        same = first >= 0
        for y in range(y0, y1 + 1):
            for x in range(x0, x1 + 1):
                s = index[y, x]
                if not same or s < 0 or (emission[s, 0] != emission[first, 0] or emission[s, 1] != emission[first, 1]
                                         or emission[s, 2] != emission[first, 2]):
                    same = False
                    break
        if same:
            out[e] = first
    return out


CULL_MARGIN = 1e-9  # of the coordinates' size: far above rounding (~1e-15 of it), far below any geometry


@nb.njit(cache=True)
def _faces_no_emitter(points, lx, ly, lz, nx, ny, nz, corners, em_normal, em_two_sided, reach):
    """True when every emitter (corners (M, 3, 3), em_normal (M, 3), em_two_sided (M,)) lies
    behind the plane of the texel's normal (nx, ny, nz) through its nearest ray origin (points
    (3, K) lifted by (lx, ly, lz)), or sees all those origins from behind its own plane (one-
    sided), each by CULL_MARGIN of the coordinates' size (the largest |x| of the origins and
    of the corners, `reach`) and more: then next_event_samples would find cos <= 0 at every sample,
    whatever the rounding. Stops at the first emitter in view. The points may be the corners
    of a convex set of origins: the nearest, the farthest and the bounds are those of its
    corners (all three are linear), and the margin dwarfs the rounding of the points inside."""
    k_count, m = points.shape[1], corners.shape[0]
    near = np.inf
    lo0 = lo1 = lo2 = np.inf
    hi0 = hi1 = hi2 = -np.inf
    for j in range(k_count):
        ox, oy, oz = points[0, j] + lx, points[1, j] + ly, points[2, j] + lz
        near = min(near, nx * ox + ny * oy + nz * oz)
        lo0, lo1, lo2 = min(lo0, ox), min(lo1, oy), min(lo2, oz)
        hi0, hi1, hi2 = max(hi0, ox), max(hi1, oy), max(hi2, oz)
    size = max(reach, abs(lo0), abs(lo1), abs(lo2), abs(hi0), abs(hi1), abs(hi2))
    margin = CULL_MARGIN * size
    for e in range(m):
        ex, ey, ez = em_normal[e, 0], em_normal[e, 1], em_normal[e, 2]
        far = -np.inf       # the emitter's farthest point along the texel's normal
        plane = np.inf      # the emitter's nearest corner along its own normal
        for c in range(3):
            far = max(far, nx * corners[e, c, 0] + ny * corners[e, c, 1] + nz * corners[e, c, 2])
            plane = min(plane, ex * corners[e, c, 0] + ey * corners[e, c, 1] + ez * corners[e, c, 2])
        if far < near - margin:
            continue
        ex, ey, ez = em_normal[e, 0], em_normal[e, 1], em_normal[e, 2]
        top = max(ex * lo0, ex * hi0) + max(ey * lo1, ey * hi1) + max(ez * lo2, ez * hi2)  # the origins' farthest
        if not em_two_sided[e] and top < plane - margin:
            continue
        return False
    return True


# the rows of `_emitter_table`
E_LO, E_SHARE, E_PDF, E_TWO_SIDED, E_NORMAL, E_CORNERS, E_COLUMNS = 0, 1, 2, 3, 4, 7, 16


LINEAR_PICK = 8  # emitters up to which a pick's emitter is counted, not searched for


@nb.njit(cache=True, inline="always")
def _emitters_picked(count, pick, cdf, table, t):
    """count (K,) the emitter each pick (K,) in [0, 1) chooses from cdf (M,) ascending: the
    number of cdf values <= the pick, at most M - 1; and t (E_COLUMNS, K) its column of
    table (`_emitter_table`). All K picks at once without branches: up to LINEAR_PICK
    emitters counted (cdf values but the last <= each pick) and their columns selected, so
    nothing is gathered; more by a binary search whose every step moves all K picks, then a
    gather of the columns."""
    m = cdf.shape[0]
    count[:] = 0
    if m <= LINEAR_PICK:
        for q in range(E_COLUMNS):
            t[q, :] = table[q, 0]
        for i in range(m - 1):
            for j in range(count.shape[0]):
                count[j] += cdf[i] <= pick[j]
            for q in range(E_COLUMNS):
                value = table[q, i + 1]
                for j in range(count.shape[0]):
                    t[q, j] = value if cdf[i] <= pick[j] else t[q, j]
        return
    step = 1
    while step * 2 <= m:
        step *= 2
    while step > 0:
        for j in range(count.shape[0]):
            c = count[j] + step
            count[j] += step * ((c <= m) & (cdf[min(c, m) - 1] <= pick[j]))
        step >>= 1
    for j in range(count.shape[0]):
        count[j] = min(count[j], m - 1)
    for q in range(E_COLUMNS):
        for j in range(count.shape[0]):
            t[q, j] = table[q, count[j]]


@nb.njit(cache=True, inline="always")
def _emitter_table(cdf, pdf_area, em_tri, corners, em_normal, em_two_sided):
    """(E_COLUMNS, M) f64 what a next-event sample reads of the emitter e it picks, column e:
    the cdf below it and its share, its pdf_area, 1 if two-sided (else 0), its normal (3) and
    corners (3 x 3, corner by corner)."""
    table = np.empty((E_COLUMNS, cdf.shape[0]))
    for e in range(cdf.shape[0]):
        table[E_LO, e] = cdf[e - 1] if e > 0 else 0.0
        table[E_SHARE, e] = cdf[e] - table[E_LO, e]
        table[E_PDF, e] = pdf_area[em_tri[e]]
        table[E_TWO_SIDED, e] = 1.0 if em_two_sided[e] else 0.0
        for a in range(3):
            table[E_NORMAL + a, e] = em_normal[e, a]
            for q in range(3):
                table[E_CORNERS + 3 * q + a, e] = corners[e, q, a]
    return table


@nb.njit(cache=True, nogil=True, error_model="numpy")
def next_event_samples(grid, side, normal, lift, rows, cdf, pdf_area, em_tri, corners, em_normal, em_two_sided,
                       em_patch, tri_uv1, width, height, index, emission, gather_rays, seed, occluded16, scene, out):
    """Next-event estimation towards emissive triangles: one shadow ray per sub-texel point.

    The K = side * side points of each texel of patches `rows` (R,) are made texel by texel
    (`atlas.raster.texel_points` of grid, `atlas.raster.TexelPoints.grid`); normal (N, 3)
    and lift (N,): the patches' normals and ray lifts (f32 or f64, read as f64). Emitters (M of them): cdf (M,) their
    cumulative share of emitted power; pdf_area (T,) per scene triangle, that share over its
    area (per m^2); em_tri (M,) scene triangle ids; corners (M, 3, 3); em_normal (M, 3); em_two_sided
    (M,); em_patch (M,) their `uniform_patches`. Sample j of a texel picks an emitter by
    power with its stratum of K (a per-texel permutation pairs strata with points), a point
    uniform on it, and reads the radiance of the emitter's patch there (tri_uv1, index,
    emission: what the gather sees; em_patch's, where it is not -1, is the same).
    The rays that can carry light, in sample order, each with its incident light if
    unblocked: Le cos / (pi p) / K, p the solid-angle pdf, MIS-weighted against
    `gather_rays` cosine rays (power heuristic). The other samples carry none, and a texel
    that `_faces_no_emitter` draws none at all.

    occluded16 0: returns the L rays packed (ray (L,) i64 sample ids r * K + j, origins,
    dirs (L, 3) f32, tmax (L,) f32, their light (L, 3) f32) and 0 rays traced. Else the rays go, WIDTH
    at a time as they are made, through rtcOccluded16 at that address (scene: the Embree
    scene; `embree.occlude_packet`), the same packets as `embree.occluded_rays` of the
    packed rays would trace; out (R, 3) f32 gets each texel's sum in order of its unblocked
    rays' light (a blocked ray adds its light times 0: no branch on the shadow rays' random
    outcome), and the arrays returned are empty. out is written before it is read: np.zeros'
    fresh pages, read first, map the kernel's shared zero page, and each first write then
    costs a copy-on-write fault that flushes every core's TLB (0.75 ms a page, measured).
    A texel's K samples go step by step through loops over all K (each step a loop the
    compiler turns into vector instructions, the same operations on every sample), the
    samples that carry no light then left out; their numbers may be inf or NaN meanwhile
    (IEEE division, error_model "numpy"), never read.
    """
    r_count, k_count = rows.shape[0], side * side
    tracing = occluded16 != 0
    capacity = WIDTH if tracing else r_count * k_count  # traced: one packet's rays at a time
    ray = np.empty(capacity, np.int64)
    origins = np.empty((capacity, 3), np.float32)
    dirs = np.empty((capacity, 3), np.float32)
    tmax = np.empty(capacity, np.float32)
    value = np.empty((capacity, 3), np.float32)
    packet, valid = packet_memory()
    blocked = np.empty(WIDTH, np.bool_)
    texel = np.empty(WIDTH, np.int64)  # traced: each lane's row in out, no division per ray
    if tracing:
        out[:] = 0.0
    points = np.empty((3, k_count))
    hull = np.empty((3, 4))
    grid_corners = np.array([0, side - 1, k_count - side, k_count - 1])  # the cells' corners, point ids
    cells = sub_texel_cells(side)
    perms = np.empty((2, k_count), np.int64)  # per texel: strata paired with points for the pick, the point
    perm_pick, perm_point = perms
    draws = np.empty((2, k_count), np.int64)
    picked = np.empty(k_count, np.int64)
    # per sample: its draws, origin, the picked emitter's row of the table, the ray and its light
    pick, s1, s2, dist, cos_r, cos_l, f = (np.empty(k_count), np.empty(k_count), np.empty(k_count), np.empty(k_count),
                                           np.empty(k_count), np.empty(k_count), np.empty(k_count))
    o, d, t = np.empty((3, k_count)), np.empty((3, k_count)), np.empty((E_COLUMNS, k_count))
    table = _emitter_table(cdf, pdf_area, em_tri, corners, em_normal, em_two_sided)
    inv_k = 1.0 / k_count if k_count & (k_count - 1) == 0 else 0.0  # see _divided
    m = cdf.shape[0]
    reach = np.abs(corners).max() if m > 0 else 0.0
    live = traced = 0
    for r in range(r_count):
        p = rows[r]
        nx, ny, nz = np.float64(normal[p, 0]), np.float64(normal[p, 1]), np.float64(normal[p, 2])
        lift_p = np.float64(lift[p])
        lx, ly, lz = lift_p * nx, lift_p * ny, lift_p * nz
        bounds = points
        if texel_points(points, p, grid, cells) == 0 and k_count > 4:  # an affine grid: its corners bound it
            for a in range(3):
                for q in range(4):
                    hull[a, q] = points[a, grid_corners[q]]
            bounds = hull
        if m <= k_count and _faces_no_emitter(bounds, lx, ly, lz, nx, ny, nz, corners, em_normal, em_two_sided,
                                              reach):  # tested for at most K emitters, as many as samples
            continue
        key = np.int64(p) * 1000003 + seed
        _shuffle(perms, key, draws)
        for j in range(k_count):
            pick[j] = _divided(perm_pick[j] + _hash_uniform(key, 2 * k_count + 2 * j), k_count, inv_k)
        for j in range(k_count):
            s2[j] = _divided(perm_point[j] + _hash_uniform(key, 2 * k_count + 2 * j + 1), k_count, inv_k)
        for j in range(k_count):
            o[0, j], o[1, j], o[2, j] = points[0, j] + lx, points[1, j] + ly, points[2, j] + lz
        _emitters_picked(picked, pick, cdf, table, t)
        for j in range(k_count):
            s1[j] = np.sqrt(min(max((pick[j] - t[E_LO, j]) / t[E_SHARE, j], 0.0), 1.0))
        for a in range(3):  # from the origin to the point (bw, bu, bv) on the emitter
            for j in range(k_count):
                bu, bv = s1[j] * (1.0 - s2[j]), s1[j] * s2[j]
                d[a, j] = ((1.0 - bu - bv) * t[E_CORNERS + a, j] + bu * t[E_CORNERS + 3 + a, j]
                           + bv * t[E_CORNERS + 6 + a, j] - o[a, j])
        for j in range(k_count):
            dist[j] = np.sqrt(d[0, j] * d[0, j] + d[1, j] * d[1, j] + d[2, j] * d[2, j])
        for a in range(3):
            for j in range(k_count):
                d[a, j] = d[a, j] / dist[j]
        for j in range(k_count):
            cos_r[j] = nx * d[0, j] + ny * d[1, j] + nz * d[2, j]
        for j in range(k_count):
            cos = -(t[E_NORMAL, j] * d[0, j] + t[E_NORMAL + 1, j] * d[1, j] + t[E_NORMAL + 2, j] * d[2, j])
            cos_l[j] = abs(cos) if t[E_TWO_SIDED, j] != 0.0 else cos
        for j in range(k_count):
            pdf = t[E_PDF, j] * dist[j] * dist[j] / cos_l[j]
            w = power_heuristic(k_count, pdf, gather_rays, cos_r[j] / np.pi)
            f[j] = _divided(cos_r[j] / (np.pi * pdf) * w, k_count, inv_k)
        for j in range(k_count):
            if t[E_SHARE, j] <= 0.0 or dist[j] <= 0.0 or cos_r[j] <= 0.0 or cos_l[j] <= 0.0 or f[j] != f[j]:
                continue
            e = picked[j]
            s = em_patch[e]
            if s < 0:
                s = _patch_at(em_tri[e], s1[j] * (1.0 - s2[j]), s1[j] * s2[j], tri_uv1, width, height, index)
                if s < 0:
                    continue
            if tracing:
                texel[live] = r
            else:
                ray[live] = r * k_count + j
            for a in range(3):
                origins[live, a] = o[a, j]
                dirs[live, a] = d[a, j]
                value[live, a] = f[j] * emission[s, a]
            tmax[live] = dist[j] * (1.0 - 1e-4)  # > 0: dist is at least an ulp of the coordinates
            live += 1
            if live == capacity and tracing:
                _unblocked_into(out, occluded16, scene, packet, valid, origins, dirs, tmax, value, texel, live,
                                blocked)
                traced += live
                live = 0
    if tracing and live:
        _unblocked_into(out, occluded16, scene, packet, valid, origins, dirs, tmax, value, texel, live, blocked)
        traced += live
        live = 0
    return ray[:live], origins[:live], dirs[:live], tmax[:live], value[:live], traced


@nb.njit(cache=True, inline="always")
def _unblocked_into(out, occluded16, scene, packet, valid, origins, dirs, tmax, value, texel, n, blocked):
    """Trace rays 0..n-1 (n <= WIDTH) in one packet and add the light (n, 3) of those
    unblocked into out's rows `texel` (n,), blocked ones times 0."""
    occlude_packet(occluded16, scene, packet, valid, origins, dirs, tmax, n, blocked)
    for q in range(n):
        seen = np.float32(0.0) if blocked[q] else np.float32(1.0)
        r = texel[q]
        out[r, 0] += seen * value[q, 0]
        out[r, 1] += seen * value[q, 1]
        out[r, 2] += seen * value[q, 2]


@nb.njit(cache=True, inline="always")
def _sun_deal(s_count, k):
    """The point (J,) and disc direction (J,) of each of a texel's J = max(S, K) sun rays:
    ray j leaves point j % K along direction (j + j // S) % S (a Latin square: no column of
    points shares one; a point takes several directions when J > K)."""
    j = np.arange(max(s_count, k))
    return j % k, (j + j // s_count) % s_count


@nb.njit(cache=True, nogil=True)
def sun_rays(origins, cos, dirs):
    """Shadow rays towards a sun's disc of S directions dirs (S, 3) f64 from K points per
    texel, origins (N, K, 3) f64, dealt as `_sun_deal` says; cos (N, S) f64 each texel's
    normal . direction. Returns the rays of directions in front of their texel (cos > 0), in
    (texel, j) order: ray (L,) i64 ids (texel * J + j), origins and dirs (L, 3) f32."""
    n, k, s_count = origins.shape[0], origins.shape[1], dirs.shape[0]
    point, direction = _sun_deal(s_count, k)
    j_count = point.shape[0]
    ray = np.empty(n * j_count, np.int64)
    out_origins = np.empty((n * j_count, 3), np.float32)
    out_dirs = np.empty((n * j_count, 3), np.float32)
    live = 0
    for i in range(n):
        for j in range(j_count):
            s = direction[j]
            if cos[i, s] > 0.0:
                ray[live] = i * j_count + j
                for a in range(3):
                    out_origins[live, a] = origins[i, point[j], a]
                    out_dirs[live, a] = dirs[s, a]
                live += 1
    return ray[:live], out_origins[:live], out_dirs[:live]


@nb.njit(cache=True, nogil=True)
def add_sun_light(total, cos, ray, blocked, light):
    """Add to total (N, K, 3) f64 a sun's light (3,) at each point: the mean over the point's
    sun_rays (ray (L,), their ids, ascending) of cos where the ray is not `blocked` (L,), times
    light / pi. cos (N, S)."""
    n, k = total.shape[0], total.shape[1]
    point, direction = _sun_deal(cos.shape[1], k)
    j_count = point.shape[0]
    visible = np.zeros((n, k))
    i, start = 0, 0  # the texel of ray q and its first ray id (ids ascend): no division per ray
    for q in range(ray.shape[0]):
        if not blocked[q]:
            while ray[q] >= start + j_count:
                i, start = i + 1, start + j_count
            j = ray[q] - start
            visible[i, point[j]] += cos[i, direction[j]]
    count = np.bincount(point)  # each point's rays
    for i in range(n):
        for p in range(k):
            mean = visible[i, p] / count[p]
            for c in range(3):
                total[i, p, c] += mean * light[c] / np.pi


@nb.njit(cache=True, nogil=True)
def mean_over_points(values):
    """(R, 3) f64 the mean of values (R, K, 3) over its K points, summed in order."""
    r_count, k = values.shape[0], values.shape[1]
    out = np.empty((r_count, 3))
    for r in range(r_count):
        for c in range(3):
            total = values[r, 0, c]
            for p in range(1, k):
                total += values[r, p, c]
            out[r, c] = total / k
    return out


@nb.njit(cache=True, nogil=True)
def points_disagree(values, spread):
    """(R,) bool: texels whose K points' values (R, K, 3) spread over more than `spread`
    of their largest in some channel (max - min > spread max)."""
    r_count, k = values.shape[0], values.shape[1]
    out = np.zeros(r_count, np.bool_)
    for r in range(r_count):
        for c in range(3):
            hi = lo = values[r, 0, c]
            for p in range(1, k):
                hi = max(hi, values[r, p, c])
                lo = min(lo, values[r, p, c])
            if hi - lo > spread * hi:
                out[r] = True
    return out


LINE_PATCHES = 512  # patches per bit of the second level of `emitting_patches`: one 64-byte line of the first


def emitting_patches(emission: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Which patches emit (emission (N, 3) above 0 in some channel), in two levels of bits
    (little bit order): (ceil(N / 8),) u8 one bit per patch, 1/96 of the emission's bytes,
    and (ceil(N / 4096),) u8 one bit per LINE_PATCHES patches, set where any of them emits.
    The gather tests every ray that hits a patch: the second level (700 bytes at 2048) stays
    in the nearest cache and answers alone for the patches far from any emitter."""
    bits = np.packbits((emission[:, 0] > 0) | (emission[:, 1] > 0) | (emission[:, 2] > 0), bitorder="little")
    lines = np.zeros(-(-len(bits) // (LINE_PATCHES // 8)) * (LINE_PATCHES // 8), np.uint8)
    lines[:len(bits)] = bits
    return bits, np.packbits(np.any(lines.reshape(-1, LINE_PATCHES // 8), axis=1), bitorder="little")


@nb.njit(cache=True, inline="always")
def _emits(emitting, s):
    """Patch s emits, by its bits in `emitting_patches`."""
    bits, lines = emitting
    line = s // LINE_PATCHES
    return (lines[line >> 3] >> (line & 7)) & 1 != 0 and (bits[s >> 3] >> (s & 7)) & 1 != 0


@nb.njit(cache=True, inline="always")
def _emission_share(i, tri, dist, dirs, local_dirs, pdf_area, tri_normal, nee_samples):
    """The share (f32) of its emission gather ray i, which meets an emitting patch, counts: 1,
    or where next-event estimation samples the triangle it hits (nee_samples > 0 per texel,
    pdf_area > 0), its MIS weight against those samples (power heuristic; next_event_samples is
    the other half). tri, dist: the rays' hit triangles and distances; dirs (R * D, 3);
    local_dirs (D, 3) with z along the normal; pdf_area (T,) the next-event pdf per m^2 of
    each triangle; tri_normal (T, 3)."""
    t = tri[i]
    if nee_samples > 0 and pdf_area[t] > 0.0:
        d = local_dirs.shape[0]
        cos_l = -(tri_normal[t, 0] * dirs[i, 0] + tri_normal[t, 1] * dirs[i, 1] + tri_normal[t, 2] * dirs[i, 2])
        cos_l = max(abs(cos_l), 1e-12)
        pdf = pdf_area[t] * dist[i] * dist[i] / cos_l
        return np.float32(power_heuristic(d, local_dirs[i % d, 2] / np.pi, nee_samples, pdf))
    return np.float32(1.0)


@nb.njit(cache=True, nogil=True)
def emission_shares(seen, tri, dist, dirs, local_dirs, emitting, pdf_area, tri_normal, nee_samples):
    """(R * D,) f32: the share of its emission each gather ray counts (`_emission_share`), 0
    for the rays that meet no emitting patch. seen (R * D,) as item_buffer_rows takes it;
    emitting: `emitting_patches`."""
    out = np.zeros(seen.shape[0], np.float32)
    for i in range(seen.shape[0]):
        if seen[i] >= 0 and _emits(emitting, seen[i]):
            out[i] = _emission_share(i, tri, dist, dirs, local_dirs, pdf_area, tri_normal, nee_samples)
    return out


@nb.njit(cache=True, nogil=True)
def weighted_emission(seen, tri, dist, dirs, local_dirs, weights, emitting, emission, pdf_area, tri_normal,
                      nee_samples):
    """(R, 3) f32: per patch, the emission (N, 3) of the patches its D rays see, times each
    ray's direction weight (D,) and its `emission_shares` share, summed in ray order."""
    d = weights.shape[0]
    out = np.zeros((seen.shape[0] // d, 3), np.float32)
    for i in range(seen.shape[0]):
        s = seen[i]
        if s >= 0 and _emits(emitting, s):
            share = _emission_share(i, tri, dist, dirs, local_dirs, pdf_area, tri_normal, nee_samples)
            if share != 0.0:
                w = share * weights[i % d]
                for c in range(3):
                    out[i // d, c] += w * emission[s, c]
    return out


@nb.njit(cache=True, nogil=True)
def pass_light(direct, gathered, inside, rho, emission, incident, reflected, half):
    """One pass's light from its gathered light G (n, 3) f32, into the (n, 3) outputs, all
    C-contiguous: incident I = D + G (0 at texels `inside` geometry), the reflected light
    (rho I + E) - E that the next pass gathers (the excident light less the emission, as
    `excident` rounds it), and, unless half is (0, 3), I's float16 bits (u16, `half_bits`),
    in a second loop over the flat channels, which the compiler vectorises (in the first,
    each conversion's branches took a third of the sweep)."""
    d, g, r, e = direct.reshape(-1), gathered.reshape(-1), rho.reshape(-1), emission.reshape(-1)
    light_out, reflected_out = incident.reshape(-1), reflected.reshape(-1)
    for i in range(direct.shape[0]):
        lit = not inside[i]
        for c in range(3):
            j = 3 * i + c
            light = d[j] + g[j] if lit else np.float32(0.0)
            light_out[j] = light
            reflected_out[j] = (r[j] * light + e[j]) - e[j]
    bits = half.reshape(-1)
    for j in range(bits.shape[0]):
        bits[j] = half_bits(light_out[j])


@nb.njit(cache=True, nogil=True)
def excident(incident, rho, emission, out):
    """out (n, 3) f32 = rho I + E: the excident light of incident light I (n, 3) f32."""
    for i in range(incident.shape[0]):
        for c in range(3):
            out[i, c] = rho[i, c] * incident[i, c] + emission[i, c]


@nb.njit(cache=True, nogil=True)
def largest_relative_change(current, previous, floor):
    """max |current - previous| / max(current, floor) over (n, 3) f32 arrays, in f32."""
    largest = np.float32(0.0)
    for i in range(current.shape[0]):
        for c in range(3):
            change = abs(current[i, c] - previous[i, c]) / max(current[i, c], floor)
            largest = max(largest, change)
    return largest


@nb.njit(cache=True, nogil=True)
def scatter_sum(G, ids, S, P):
    """G[ids[k]] = S[k] + P[k] for k < len(ids): gathered rows (K, 3) f32 into G (N, 3) f32."""
    for k in range(ids.shape[0]):
        for c in range(3):
            G[ids[k], c] = S[k, c] + P[k, c]


BAND_ROWS = 16  # lightmap rows of G an interpolation's wavefront advances by: with the rows behind it, they stay in cache


@nb.njit(cache=True, nogil=True)
def interpolate_rows(G, have, status, targets, neighbours, starts, nb_starts, widths, row_starts, reach, lo, hi,
                     computed, skipped):
    """Fill G (N, 3) in place at the targets of each step s of the sampler's order
    (`adaptive.Order`: targets, neighbours, starts, nb_starts, widths, row_starts and reach)
    on rows lo[s]..hi[s] - 1 (lo, hi (S,) i64), but those whose status (N,) is `computed` or
    `skipped`: each the mean of its neighbours (-1 = none) that `have` (N,) bool values,
    then marked in `have`; none -> 0. A wavefront: band after band of BAND_ROWS rows, step s
    runs reach[s] rows behind the band's end, so the rows of the earlier steps it reads are
    done (a target's neighbours belong to earlier steps, its rise rows away) and in cache."""
    n_steps = lo.shape[0]
    done = np.empty(n_steps, np.int64)
    for s in range(n_steps):
        done[s] = row_starts[s, lo[s]]
    last = hi.max() + reach.max()
    r = lo.min()
    while r < last:
        r = min(r + BAND_ROWS, last)
        for s in range(n_steps):
            end = row_starts[s, min(max(r - reach[s], lo[s]), hi[s])]
            width = widths[s]
            at = nb_starts[s] + (done[s] - starts[s]) * width
            for k in range(done[s], end):
                t = targets[k]
                if status[t] != computed and status[t] != skipped:
                    count = 0
                    acc0 = acc1 = acc2 = 0.0
                    for j in range(width):
                        n = neighbours[at + j]
                        if n >= 0 and have[n]:
                            acc0 += G[n, 0]
                            acc1 += G[n, 1]
                            acc2 += G[n, 2]
                            count += 1
                    if count > 0:
                        G[t, 0], G[t, 1], G[t, 2] = acc0 / count, acc1 / count, acc2 / count
                        have[t] = True
                    else:
                        G[t, 0] = G[t, 1] = G[t, 2] = 0.0
                at += width
            done[s] = max(done[s], end)
    return None


@nb.njit(cache=True, nogil=True)
def step_targets(index, chart, spacing, phase_y, phase_x, offsets):
    """One step of the adaptive sampler, read off the patch index (H, W) i32 (patch ids
    ascending in (y, x) order, -1 uncovered) at the texels (y, x) with y % spacing == phase_y
    and x % spacing == phase_x: their patches, the targets, ascending (K,) i32; each one's
    neighbours at `offsets` (W, 2) (dy, dx), (K, W) i32 patch ids, -1 off the map, uncovered
    or in another chart (`chart` (N,)); and row_starts (H + 1,) i64, where each lightmap row's
    targets begin."""
    height, width = index.shape
    count = 0
    for y in range(phase_y, height, spacing):
        for x in range(phase_x, width, spacing):
            count += index[y, x] >= 0
    targets = np.empty(count, np.int32)
    neighbours = np.full((count, offsets.shape[0]), -1, np.int32)
    row_starts = np.zeros(height + 1, np.int64)
    k = 0
    for y in range(height):
        row_starts[y] = k
        if y % spacing != phase_y:
            continue
        for x in range(phase_x, width, spacing):
            i = index[y, x]
            if i < 0:
                continue
            targets[k] = i
            for j in range(offsets.shape[0]):
                yy, xx = y + offsets[j, 0], x + offsets[j, 1]
                if 0 <= yy < height and 0 <= xx < width:
                    other = index[yy, xx]
                    if other >= 0 and chart[other] == chart[i]:
                        neighbours[k, j] = other
            k += 1
    row_starts[height] = k
    return targets, neighbours, row_starts


@nb.njit(cache=True, inline="always")
def _ratio(a, b):
    """The radiosity article's ratio2 of two f32 values: 1 when both are 0, 0 when one is,
    else min / max (divided in f32)."""
    if a == 0.0 and b == 0.0:
        return 1.0
    hi, lo = max(a, b), min(a, b)
    return float(np.float32(lo / hi)) if hi > 0.0 else 0.0


@nb.njit(cache=True, nogil=True)
def decide_targets(status, G, targets, neighbours, threshold, undecided, computed, interpolated):
    """Decide the undecided targets (K,) in place in status (N,) i8: interpolated when all
    their neighbours (K, 2 or 4; -1 = none) are computed or interpolated and each pair
    (0-1, 2-3) has a ratio above `threshold` in every channel of G (N, 3) f32, else
    computed. Returns the targets now computed, in order. A step's neighbours are never its
    own targets, so spans of one step may be decided in any order."""
    compute = np.empty(targets.shape[0], np.int64)
    count = 0
    m = neighbours.shape[1]
    for k in range(targets.shape[0]):
        t = targets[k]
        if status[t] != undecided:
            continue
        agree = True
        for j in range(m):
            n = neighbours[k, j]
            if n < 0 or (status[n] != computed and status[n] != interpolated):
                agree = False
        for j in range(0, m, 2):
            for c in range(3):
                if agree and not _ratio(G[neighbours[k, j], c], G[neighbours[k, j + 1], c]) > threshold:
                    agree = False
        if agree:
            status[t] = interpolated
        else:
            status[t] = computed
            compute[count] = t
            count += 1
    return compute[:count].copy()


@nb.njit(cache=True, nogil=True)
def zero_where(G, status, code):
    """G[i] = 0 (G (n, 3)) wherever status[i] == code."""
    for i in range(G.shape[0]):
        if status[i] == code:
            G[i, 0] = G[i, 1] = G[i, 2] = 0.0


@nb.njit(cache=True, nogil=True)
def ray_offsets(position, size, reach, floor):
    """(N,) f32 max(0.05 size, reach x the largest |coordinate| of position + floor) per
    patch, position (N, 3) and size (N,) f32, in float32 as NumPy's whole-array operations
    round them, without their temporaries (at 2048 x 2048, fresh pages that took 0.13 s)."""
    out = np.empty(size.shape[0], np.float32)
    for i in range(size.shape[0]):
        largest = max(max(abs(position[i, 0]), abs(position[i, 1])), abs(position[i, 2]))
        out[i] = max(np.float32(0.05) * size[i], reach * largest + floor)
    return out


@nb.njit(cache=True, nogil=True)
def sky_directions(seen, dirs):
    """(K, 3) f32 the directions (of dirs (R * D, 3)) of the K rays that see the sky, in ray
    order: `dirs[seen == SKY]` in one pass and no mask."""
    count = 0
    for i in range(seen.shape[0]):
        count += seen[i] == SKY
    out = np.empty((count, 3), np.float32)
    k = 0
    for i in range(seen.shape[0]):
        if seen[i] == SKY:
            out[k, 0], out[k, 1], out[k, 2] = dirs[i, 0], dirs[i, 1], dirs[i, 2]
            k += 1
    return out


PANEL_BITS = 16  # a panel is 2^16 columns of F: its slice of B (768 KiB) stays in a core's L2 cache


def panel_count(n_cols: int) -> int:
    """Column panels (PANEL_BITS) of a matrix of n_cols columns."""
    return (n_cols >> PANEL_BITS) + 1


@nb.njit(cache=True, inline="always")
def entry_word(row, column, weight_bits):
    """One entry of F as a u64: its f32 weight's bits (u32), the column within its panel (16
    bits) and the row (16 bits), from high to low. A row offset added to the word moves the
    row alone (rows stay below 2^16)."""
    return ((np.uint64(weight_bits) << np.uint64(32))
            | (np.uint64(column & ((1 << PANEL_BITS) - 1)) << np.uint64(16)) | np.uint64(row))


@nb.njit(cache=True, nogil=True)
def item_buffer_rows(seen, weights, sky_radiance, panels, uniform):
    """Turn the item buffer of R patches x D rays into their form-factor rows.

    seen: (R * D,) patch id or SKY / BACK_FACE / LOST per ray, patch by patch; weights: (D,)
    per-direction weights; sky_radiance: (number of SKY rays, 3) radiance seen, in ray order;
    panels: column panels of F (`panel_count`); uniform: every weight is the same (the
    stratified gather), so each ray that sees a patch is its own entry, of weight bits 0 (its
    weight is the block's unit, `PanelBlock`), duplicates not summed: no hash table, and half
    the bytes a kept entry. Returns the rows column panel by column panel (starts (panels + 1,)
    int64: panel p's entries are starts[p]..starts[p + 1], in row order, a row's in first-seen
    order; entries u64, each an `entry_word`), the sky term (R, 3), the share of each
    patch's rays that hit back faces (R,) and the number of LOST rays. Weighted (not uniform),
    duplicates are summed, meeting in a hash table of 4 D slots (a quarter full at most: few
    collisions), each holding a key, row << 32 | patch id, and beside it where its entry is;
    a key of an earlier row is a free slot, so the table is never cleared: scratch space and
    work per ray stay constant however large the lightmap. The entries, counted per panel as they
    appear, are then dealt to their panels, one word each.
    """
    d = weights.shape[0]
    rows = seen.shape[0] // d
    if rows > 1 << 16:
        raise ValueError("an item buffer holds at most 2^16 rows (u16 row ids in F's words)")
    size = 1
    while size < 4 * d:
        size *= 2
    table = np.full(size, -1, np.int64)  # keys, row << 32 | patch id; -1 and earlier rows' keys are free
    where = np.empty(size, np.int64)  # where each key's entry is in indices / data
    indptr = np.zeros(rows + 1, np.int64)
    indices = np.empty(seen.shape[0], np.int32)
    data = np.empty(0 if uniform else seen.shape[0], np.float32)
    starts = np.zeros(panels + 1, np.int64)
    sky = np.empty((rows, 3), np.float32)
    back = np.empty(rows, np.float32)
    nnz = 0
    k_sky = 0
    lost = 0
    for r in range(rows):
        row_key = np.int64(r) << 32
        red, green, blue, back_rays = np.float32(0.0), np.float32(0.0), np.float32(0.0), 0
        for j in range(d):
            s = seen[r * d + j]
            if s >= 0 and uniform:
                indices[nnz] = s
                starts[(s >> PANEL_BITS) + 1] += 1
                nnz += 1
            elif s >= 0:
                key = row_key | s
                h = (s * 2654435761) & (size - 1)  # Knuth's multiplicative hash
                while True:
                    slot = table[h]
                    if slot == key:
                        data[where[h]] += weights[j]
                        break
                    if slot < row_key:
                        table[h], where[h] = key, nnz
                        indices[nnz] = s
                        data[nnz] = weights[j]
                        starts[(s >> PANEL_BITS) + 1] += 1
                        nnz += 1
                        break
                    h = (h + 1) & (size - 1)
            elif s == SKY:  # summed in registers: in the array, each add waited on the one before
                red += weights[j] * sky_radiance[k_sky, 0]
                green += weights[j] * sky_radiance[k_sky, 1]
                blue += weights[j] * sky_radiance[k_sky, 2]
                k_sky += 1
            elif s == BACK_FACE:
                back_rays += 1
            else:
                lost += 1
        indptr[r + 1] = nnz
        sky[r, 0], sky[r, 1], sky[r, 2] = red, green, blue
        back[r] = np.float32(back_rays) / d
    for p in range(panels):
        starts[p + 1] += starts[p]
    at = starts[:-1].copy()
    entries = np.empty(nnz, np.uint64)
    weight_bits = data.view(np.uint32)
    for r in range(rows):
        for k in range(np.uint64(indptr[r]), np.uint64(indptr[r + 1])):
            c = np.uint32(indices[k])
            i = np.uint64(at[c >> np.uint32(PANEL_BITS)])
            at[c >> np.uint32(PANEL_BITS)] = i + 1
            entries[i] = entry_word(r, c, 0 if uniform else weight_bits[k])
    return starts, entries, sky, back, lost


@intrinsic
def _add_scaled_rgb(typingctx, out, r, w, b, c):
    """out[4 r: 4 r + 4] += w * (b[3 c], b[3 c + 1], b[3 c + 2], 0) as one 4-lane multiply
    and add (out: flat f32, four floats a row; b: flat f32, three a row; r,
    c: uint64): each lane rounds as the scalar w * b then + does, in half the instructions."""
    def codegen(context, builder, signature, args):
        out_data = context.make_array(signature.args[0])(context, builder, args[0]).data
        b_data = context.make_array(signature.args[3])(context, builder, args[3]).data
        f32, i32, i64 = ir.FloatType(), ir.IntType(32), ir.IntType(64)
        lane4, lane3 = ir.VectorType(f32, 4), ir.VectorType(f32, 3)
        to_out = builder.bitcast(builder.gep(out_data, [builder.mul(args[1], ir.Constant(i64, 4))]), lane4.as_pointer())
        to_b = builder.bitcast(builder.gep(b_data, [builder.mul(args[4], ir.Constant(i64, 3))]), lane3.as_pointer())
        rgb0 = builder.shuffle_vector(builder.load(to_b, align=4), ir.Constant(lane3, [0.0] * 3),
                                      ir.Constant(ir.VectorType(i32, 4), [0, 1, 2, 3]))
        w4 = builder.shuffle_vector(builder.insert_element(ir.Constant(lane4, ir.Undefined), args[2], ir.Constant(i32, 0)),
                                    ir.Constant(lane4, ir.Undefined), ir.Constant(ir.VectorType(i32, 4), [0] * 4))
        builder.store(builder.fadd(builder.load(to_out, align=4), builder.fmul(w4, rgb0)), to_out, align=4)
        return context.get_dummy_value()

    flat_f32 = all(isinstance(a, types.Array) and a.ndim == 1 and a.layout == "C" and a.dtype == types.float32
                   for a in (out, b))
    if not (flat_f32 and r == types.uint64 and c == types.uint64 and w == types.float32):
        return None
    return types.void(out, r, w, b, c), codegen


@nb.njit(cache=True, nogil=True)
def item_buffer_times(seen, weights, B):
    """(R, 3) f32: each of R patches' weighted sum of the excident light B (N, 3) f32 of the
    patches its D rays see (seen: (R * D,) as item_buffer_rows takes it), the row of F B
    straight from the item buffer, without storing F."""
    d = weights.shape[0]
    rows = seen.shape[0] // d
    out = np.zeros((rows, 4), np.float32)
    sums, b = out.reshape(-1), B.reshape(-1)
    for r in range(rows):
        for j in range(d):
            s = seen[r * d + j]
            if s >= 0:
                _add_scaled_rgb(sums, np.uint64(r), weights[j], b, np.uint64(s))
    return out[:, :3]


@nb.njit(cache=True, nogil=True)
def panel_in_column_order(p, piece_starts, first_rows, pieces, entries, weights):
    """Write column panel p of a block from its pieces (`item_buffer_rows`' rows, one piece
    after the other: piece_starts (K, panels + 1) int64, first_rows (K,) int64 the block's
    row of each piece's first, pieces the `address_table` of their K u64 entry words) in column order,
    rows ascending within a column, into entries (u32: column within the panel << 16 | row)
    and, unless it is empty (a uniform block), weights (f32): the block's panel p. A stable
    counting sort by column of the pieces' panel-p words, taken piece by piece in row order,
    through a histogram the size of the panel. The words are sorted whole (one scattered
    write each, not two), then split in order."""
    at = np.zeros((1 << PANEL_BITS) + 1, np.uint32)  # unsigned indices spare numba's negative-index checks
    for k in range(pieces.shape[1]):
        words = nb.carray(_void_pointer(pieces[0, k]), pieces[1, k], np.uint64)
        for i in range(np.uint64(piece_starts[k, p]), np.uint64(piece_starts[k, p + 1])):
            at[((words[i] >> np.uint64(16)) & np.uint64(0xFFFF)) + np.uint64(1)] += 1
    for c in range(1 << PANEL_BITS):
        at[c + 1] += at[c]
    sorted_words = np.empty(entries.shape[0] if weights.shape[0] else 0, np.uint64)
    for k in range(pieces.shape[1]):
        words = nb.carray(_void_pointer(pieces[0, k]), pieces[1, k], np.uint64)
        first_row = np.uint64(first_rows[k])
        for i in range(np.uint64(piece_starts[k, p]), np.uint64(piece_starts[k, p + 1])):
            c = (words[i] >> np.uint64(16)) & np.uint64(0xFFFF)
            j = at[c]
            at[c] = j + np.uint32(1)
            if weights.shape[0]:
                sorted_words[j] = words[i] + first_row
            else:  # weight bits 0: the word's low half is the whole entry
                entries[j] = np.uint32(words[i] + first_row)
    weight_bits = weights.view(np.uint32)
    for j in range(sorted_words.shape[0]):
        word = sorted_words[j]
        entries[j], weight_bits[j] = word & np.uint64(0xFFFFFFFF), word >> np.uint64(32)


@nb.njit(cache=True, nogil=True)
def blocks_times_rgb(starts, entries, weights, units, row_counts, B):
    """(sum of row_counts, 3) f32: consecutive panel-major blocks of F (`address_table`s of G
    arrays, one a block: starts int64, entries u32 column << 16 | row, weights f32 or,
    uniform, none: each entry weighs units[g]; row_counts (G,) int64) times B (N, 3) f32 C-contiguous, their rows
    one after the other, on the calling thread. Panel by panel across the blocks, so each
    panel's 2^16-row slice of B comes from memory once for all of them and from the caches for
    the rest (block by block, each block read all of B: a fifth more CPU time); a block's sums
    (n_rows x 4) stay cache-resident while its entries of the panel stream by (row by row over
    a CSR matrix whose B is larger than the caches, every read missed: 3x slower). In column
    order, consecutive entries add into different rows, so the adds do not wait on one another
    (in row order each waited on the one before: 2x slower), and most read the same B as the
    entry before. Each add is one 4-lane `_add_scaled_rgb` (three scalar ones took 1.4x as
    long); a uniform block adds B alone and scales each row's sum by its unit at the end.
    Unsigned indices spare numba's negative-index checks."""
    first_rows = np.zeros(row_counts.shape[0] + 1, np.int64)
    for g in range(row_counts.shape[0]):
        first_rows[g + 1] = first_rows[g] + row_counts[g]
    out = np.zeros((first_rows[-1], 4), np.float32)
    sums, b = out.reshape(-1), B.reshape(-1)
    for p in range(starts[1, 0] - 1):
        base = np.uint64(p << PANEL_BITS)
        for g in range(starts.shape[1]):
            at = nb.carray(_void_pointer(starts[0, g]), starts[1, g], np.int64)
            block = nb.carray(_void_pointer(entries[0, g]), entries[1, g], np.uint32)
            w = nb.carray(_void_pointer(weights[0, g]), weights[1, g], np.float32)
            row0 = np.uint64(first_rows[g])
            if w.shape[0]:
                for k in range(np.uint64(at[p]), np.uint64(at[p + 1])):
                    _add_scaled_rgb(sums, row0 + np.uint64(block[k] & np.uint32(0xFFFF)), w[k], b,
                                    base + np.uint64(block[k] >> np.uint32(16)))
            else:
                for k in range(np.uint64(at[p]), np.uint64(at[p + 1])):
                    _add_scaled_rgb(sums, row0 + np.uint64(block[k] & np.uint32(0xFFFF)), np.float32(1.0), b,
                                    base + np.uint64(block[k] >> np.uint32(16)))
    for g in range(starts.shape[1]):
        if weights[1, g] == 0:
            for r in range(first_rows[g], first_rows[g + 1]):
                for c in range(3):
                    out[r, c] *= units[g]
    return out[:, :3]


@nb.njit(cache=True, nogil=True)
def directional_sums(part, seen, dirs, B, sky, weights, cos, solid_angle, moments, normal, sh_basis, luminance,
                     sh, dominant):
    """Write the directional sums of patches part (C,) from what their rays see: seen
    (C * D,) as `resolve_hits` (patch id, SKY, else nothing), dirs (C * D, 3) f32 the rays'
    world directions, B (N, 3) f64 the light of the patches hit, sky (S, 3) f64 the radiance
    of the SKY rays in ray order; per pattern ray (D,) f64 its weight, cosine and solid angle;
    moments (2, 2) the inverse of the pattern's moments of 1 and cos; normal (N, 3); sh_basis
    (Y00, Y1). Per patch: the fit a + b cos of its radiance (least squares over the weights)
    projected exactly on the hemisphere about its normal (whose integrals of 1, cos, the
    direction and the direction x cos are 2 pi, pi, pi n and 2 pi n / 3), the rest ray by ray
    as radiance x solid angle into sh (N, 4, 3); the rays' incident light L w by luminance
    into dominant (N, 4) (direction sum, luminance). Two sweeps of each patch's rays, no
    arrays but one patch's radiance (D, 3). The rows are written, not added to: a row first
    read of a fresh array maps the shared zero page, and the write after it then takes a
    copy-on-write fault that flushes both cores' TLBs (the Cornell box at 1024: 2.8 -> 0.4
    system CPU s)."""
    d = weights.shape[0]
    y00, y1 = sh_basis[0], sh_basis[1]
    radiance = np.empty((d, 3))
    s = 0
    for r in range(part.shape[0]):
        p = part[r]
        m0r = m0g = m0b = m1r = m1g = m1b = 0.0  # the moments of 1 and cos
        for k in range(d):
            q = seen[r * d + k]
            if q >= 0:
                lr, lg, lb = B[q, 0], B[q, 1], B[q, 2]
            elif q == SKY:
                lr, lg, lb = sky[s, 0], sky[s, 1], sky[s, 2]
                s += 1
            else:
                lr = lg = lb = 0.0
            radiance[k, 0], radiance[k, 1], radiance[k, 2] = lr, lg, lb
            w, wc = weights[k], weights[k] * cos[k]
            m0r += lr * w
            m0g += lg * w
            m0b += lb * w
            m1r += lr * wc
            m1g += lg * wc
            m1b += lb * wc
        ar, ag, ab = (moments[0, 0] * m0r + moments[0, 1] * m1r, moments[0, 0] * m0g + moments[0, 1] * m1g,
                      moments[0, 0] * m0b + moments[0, 1] * m1b)
        br, bg, bb = (moments[1, 0] * m0r + moments[1, 1] * m1r, moments[1, 0] * m0g + moments[1, 1] * m1g,
                      moments[1, 0] * m0b + moments[1, 1] * m1b)
        # per channel, L0 and the sum of direction x piece (y1 applied at the end)
        l0r = l0g = l0b = 0.0
        xr = xg = xb = yr = yg = yb = zr = zg = zb = 0.0
        tx = ty = tz = tl = 0.0
        for k in range(d):
            i = r * d + k
            dx, dy, dz = np.float64(dirs[i, 0]), np.float64(dirs[i, 1]), np.float64(dirs[i, 2])
            lr, lg, lb = radiance[k, 0], radiance[k, 1], radiance[k, 2]
            pr = (lr - ar - br * cos[k]) * solid_angle[k]
            pg = (lg - ag - bg * cos[k]) * solid_angle[k]
            pb = (lb - ab - bb * cos[k]) * solid_angle[k]
            l0r += y00 * pr
            l0g += y00 * pg
            l0b += y00 * pb
            xr += y1 * dx * pr
            xg += y1 * dx * pg
            xb += y1 * dx * pb
            yr += y1 * dy * pr
            yg += y1 * dy * pg
            yb += y1 * dy * pb
            zr += y1 * dz * pr
            zg += y1 * dz * pg
            zb += y1 * dz * pb
            lum = lr * weights[k] * luminance[0] + lg * weights[k] * luminance[1] + lb * weights[k] * luminance[2]
            tx += lum * dx
            ty += lum * dy
            tz += lum * dz
            tl += lum
        nx, ny, nz = np.float64(normal[p, 0]), np.float64(normal[p, 1]), np.float64(normal[p, 2])
        hr, hg, hb = (np.pi * ar + 2.0 * np.pi / 3.0 * br, np.pi * ag + 2.0 * np.pi / 3.0 * bg,
                      np.pi * ab + 2.0 * np.pi / 3.0 * bb)
        sh[p, 0, 0] = y00 * (2.0 * np.pi * ar + np.pi * br) + l0r
        sh[p, 0, 1] = y00 * (2.0 * np.pi * ag + np.pi * bg) + l0g
        sh[p, 0, 2] = y00 * (2.0 * np.pi * ab + np.pi * bb) + l0b
        sh[p, 1, 0] = y1 * nx * hr + xr
        sh[p, 1, 1] = y1 * nx * hg + xg
        sh[p, 1, 2] = y1 * nx * hb + xb
        sh[p, 2, 0] = y1 * ny * hr + yr
        sh[p, 2, 1] = y1 * ny * hg + yg
        sh[p, 2, 2] = y1 * ny * hb + yb
        sh[p, 3, 0] = y1 * nz * hr + zr
        sh[p, 3, 1] = y1 * nz * hg + zg
        sh[p, 3, 2] = y1 * nz * hb + zb
        dominant[p, 0] = tx
        dominant[p, 1] = ty
        dominant[p, 2] = tz
        dominant[p, 3] = tl
