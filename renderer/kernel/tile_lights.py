"""The light choice of a tile's first path vertices (path integrator, scenes of many lights): a distribution
over the lights built once per image tile, instead of a walk down the light tree at each of its first
vertices.

The first vertices of a tile's paths lie where its pixels look: close together, with a light distribution
that changes little between them (unlike the later vertices, which lie anywhere).  So before its first
camera packet a tile traces PILOTS x PILOTS pilot rays, through the centres of a grid over its pixels (the
lens centre, the shutter's middle: the same rays whatever the pass, the sample range or the thread count),
weighs every light at each pilot's hit with the light tree's own importance (`light_tree.importances` over
the lights' own bounds, `PathLights.leaf_f`: power over distance squared, bounds of the cosines at the light
and at the receiver), normalises those weights at each pilot and averages them (a mixture: where the
pilots see different surfaces, each keeps its share), then mixes in a uniform share FLOOR, so that a
light no pilot sees - a first vertex may lie beside the pilots, on another surface - still has a
probability (every light that can light a vertex can be sampled: unbiased).  Where one light takes
at least 1 - SPLIT_BELOW of the choice it is sampled at every first vertex, and one of the others with
the probability q of their share (as the tree's split nodes: the dominant light keeps its stratification).
Its choices draw the same 1D sample as the tree's, through the cdf (monotone: stratified samples stay
stratified), and `tile_pmf` is the expected number of samples of a light, as `light_tree.light_pmf`.

The walk down the tree costs a few hundred ns a vertex with a thousand lights (`benchmarks/RESULTS.md`,
"Many lights"); a choice from the table a binary search.  The table costs PILOTS^2 rays and importance
loops over every light a tile, so it is built where the scene has TILE_LIGHTS_MIN to TILE_LIGHTS_MAX lights
with a position (`host/light_selection._leaf_fields`); elsewhere `PathLights.leaf_k` is empty and the tree
chooses at every vertex.  The later vertices always use the tree.
"""
import numba as nb

from .cameras import generate_ray
from .features import F_TILE_LIGHTS
from .integrator import RAYS_CAMERA, _shading_point
from .jit import SHADING_INLINE_JIT, STAGE_JIT
from .light_tree import NO_SAMPLE, ONE_MINUS, SPLIT_BELOW, _p_unbounded, importances, light_pmf
from .ray_record import record_if
from .records import Ray
from .tables import C_FAR, C_NEAR
from .trace import intersect1_surfaces, placed_hit

PILOTS = 4                         # a tile's pilot rays: a PILOTS x PILOTS grid over its pixels
FLOOR = 0.05                       # the uniform share of the choice
# lights with a position where the table is built: it reached equal error sooner on 16 to 2,000 lights (diffuse and
# glossy stages, gallery stages of emissive surfaces), later on 4,000 (`benchmarks/RESULTS.md`, "Many lights: a
# tile's first vertices")
TILE_LIGHTS_MIN, TILE_LIGHTS_MAX = 16, 2048
TOP, REST = 0, 1                   # TileLights.head: the light sampled at every first vertex (a column) and the
                                   # others' share, where one outshines the rest (else 0)


@nb.njit(**STAGE_JIT)
def _pilots(S, L, tr, pp, tile):
    """The number of the tile's pilot rays that hit a surface; the mean of their normalised light weights
    into tr.tl.pmf."""
    tl = tr.tl
    w, pmf = tl.w, tl.pmf
    n = pmf.shape[0]
    for c in range(n):
        pmf[c] = 0.0
    cam = pp.cam
    time = 0.5 if pp.use_time else 0.0
    hits = 0
    for j in range(PILOTS):
        for i in range(PILOTS):
            fx = (tile.x0 + (tile.x1 - tile.x0) * (i + 0.5) / PILOTS) / pp.width
            fy = (tile.y0 + (tile.y1 - tile.y0) * (j + 0.5) / PILOTS) / pp.height
            o, d = generate_ray(cam, fx, fy, 0.5, 0.5, time)
            record_if(tr.rec, tr.tile, RAYS_CAMERA, o, d, cam[C_NEAR], cam[C_FAR], time)
            tr.counts[RAYS_CAMERA] += 1
            if not intersect1_surfaces(tr.scene, tr.f, tr.u, o, d, cam[C_NEAR], cam[C_FAR], time):
                continue
            placed_hit(L, tr.u)
            sp = _shading_point(S, tr, Ray(o, d), time)
            importances(L.leaf_f, 0, sp.p, sp.ns, w)
            total = 0.0
            for c in range(n):
                total += w[c]
            if total > 0.0:
                inv = 1.0 / total
                for c in range(n):
                    pmf[c] += w[c] * inv
                hits += 1
    return hits


@nb.njit(**STAGE_JIT)
def build_tile_lights(S, L, tr, pp, tile):
    """The light choice of the tile's first vertices, into tr.tl (`TileLights`)."""
    tabulate(tr.tl, _pilots(S, L, tr, pp, tile))


@nb.njit(**STAGE_JIT)
def tabulate(tl, hits):
    """The choice of `TileLights` tl from the sum of `hits` pilots' normalised weights in tl.pmf: their
    mean mixed with the uniform FLOOR (uniform where no pilot met a surface), its cdf, and its split."""
    pmf, cdf, head = tl.pmf, tl.cdf, tl.head
    n = pmf.shape[0]
    a = (1.0 - FLOOR) / hits if hits > 0 else 0.0
    b = FLOOR / n if hits > 0 else 1.0 / n
    top = 0
    for c in range(n):
        pmf[c] = a * pmf[c] + b
        if pmf[c] > pmf[top]:
            top = c
    rest = 0.0
    for c in range(n):
        if c != top:
            rest += pmf[c]
    split = rest <= SPLIT_BELOW
    cdf[0] = 0.0
    for c in range(n):
        cdf[c + 1] = cdf[c] + (0.0 if split and c == top else pmf[c])
    head[TOP] = top
    head[REST] = cdf[n] if split else 0.0


@nb.njit(**SHADING_INLINE_JIT)
def _find(cdf, x):
    """The column c with cdf[c] <= x < cdf[c + 1] (x in [0, cdf[-1])): a binary search; a column of no
    probability is never returned."""
    lo, hi = 0, cdf.shape[0] - 1
    while hi - lo > 1:
        mid = (lo + hi) >> 1
        if cdf[mid] <= x:
            lo = mid
        else:
            hi = mid
    while lo > 0 and cdf[lo + 1] == cdf[lo]:          # (x rounded onto the end of the table)
        lo -= 1
    return lo


@nb.njit(**SHADING_INLINE_JIT)
def tiled(L, v):
    """Whether path vertex v chooses its lights from its tile's table: a first vertex (v = 0) in a scene
    that has one."""
    return F_TILE_LIGHTS != 0 and v == 0 and L.leaf_k.shape[0] > 0


@nb.njit(**SHADING_INLINE_JIT)
def choose_tile_lights(L, tl, u):
    """As `light_tree.choose_lights`, for a first vertex of the tile whose choice tl holds: ((light, its
    expected number of samples) of the main sample and of up to two side samples; -1 where none)."""
    pu = _p_unbounded(L)
    if u < pu:
        nu = L.unbounded.shape[0]
        return (L.unbounded[min(int(u / pu * nu), nu - 1)], pu / nu), NO_SAMPLE, NO_SAMPLE
    u = min((u - pu) / (1.0 - pu), ONE_MINUS)
    cdf, pmf, head = tl.cdf, tl.pmf, tl.head
    total = cdf[cdf.shape[0] - 1]
    q = head[REST]
    if q > 0.0:                                         # the top light at every vertex, another with chance q
        main = (L.leaf_k[int(head[TOP])], 1.0 - pu)
        if u < q:
            c = _find(cdf, min(u / q, ONE_MINUS) * total)
            return main, (L.leaf_k[c], (1.0 - pu) * pmf[c]), NO_SAMPLE
        return main, NO_SAMPLE, NO_SAMPLE
    c = _find(cdf, u * total)
    return (L.leaf_k[c], (1.0 - pu) * pmf[c]), NO_SAMPLE, NO_SAMPLE


@nb.njit(**SHADING_INLINE_JIT)
def tile_pmf(L, tl, k):
    """The expected number of samples `choose_tile_lights` takes of light k (as `light_tree.light_pmf`)."""
    c = L.leaf_col[k]
    if c < 0:                                           # a light without a position
        pu = _p_unbounded(L)
        return pu / L.unbounded.shape[0] if pu > 0.0 else 0.0
    pu = _p_unbounded(L)
    if tl.head[REST] > 0.0 and c == int(tl.head[TOP]):
        return 1.0 - pu
    return (1.0 - pu) * tl.pmf[c]


@nb.njit(**SHADING_INLINE_JIT)
def vertex_pmf(L, tl, prev, k):
    """The expected number of samples of light k the light samples of the vertex `prev` (a `PrevVertex`)
    took: by the tile's choice where it was a first vertex that used it, else by the tree's."""
    if prev[6]:
        return tile_pmf(L, tl, k)
    return light_pmf(L, prev[0], prev[1], k)

