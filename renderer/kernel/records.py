"""The named records the kernels pass around (numba compiles namedtuples to plain structs: inlined,
they cost nothing; passed to a compiled function, a record crosses the call as its fields).

Per render pass
    PassParams      what a pass computes: camera table, image size, sample range, sampler, filter, seed,
                    depth, whether the lens and the shutter are sampled, the path integrator's strategy, the
                    window of the image it renders (x0, y0, x1, y1: the whole image, or a shot's tile)
    Tile            the pixels [x0, x1) x [y0, y1) of tile `index`
Per thread (allocated once per tile by `render_pass`; the shading code allocates nothing)
    Packet          16 rays for Embree's packet queries: valid mask, float32 and uint32 views of their fields,
                    and log2 of how many Embree traces at a time (16: one RTCRayHit16; 8: two RTCRayHit8)
    ShadowQueue     shadow rays waiting to be traced as one rtcOccluded16 packet, and the light of the
                    unoccluded ones per lane (cook: first-hit shadow rays; path: every shadow ray where no
                    surface is see-through)
    Lanes           the camera stage's per-lane state (structure of arrays, so that loops vectorise)
    Scratch         one render thread's arrays, allocated by the host (`integrator.new_scratch`): the camera
                    packet, the single-ray buffer, matrix scratch, a tile's counters, the shadow queue, the lanes,
                    the ray record of the pass (None: every render; a `ray_record.RayRecord`: benchmarks) and the
                    tile's light choice
    TileLights      the light choice of a tile's first path vertices (path, `tile_lights.py`): a light's
                    importances, the choice's pmf and cdf over the lights (columns of `PathLights.leaf_f`), and
                    its head (the light sampled at every first vertex, the others' share: where one outshines them)
    Tracer          what tracing a path needs besides the scene tables: the Embree scene, the single-ray
                    buffer, matrix scratch, ray counters, the shadow queue, the tile index, the ray record and the
                    tile's light choice
Per path and bounce
    SampleKey       (sampler, seed, pixel, index, spp): which sample's random numbers a path draws
    Path            a path's sample key, its lane in the camera packet and its shutter time
    Ray             origin and unit direction (float64 triples)
    Hit             what Embree reports of a hit: placement (instance id, row), geometry, primitive,
                    barycentrics and distance
    ShadingPoint    a surface point ready to shade: position, geometric and shading normals (facing the
                    viewer), texture coordinates, material and model, which side was hit, the direction
                    to the viewer and the material's (textured) colours
    PathState       radiance gathered so far, throughput, and the Beer attenuation of the current medium
    Vertex          a path vertex as next-event estimation needs it (path): position, normals, shading frame,
                    direction to the viewer in that frame, shadow-ray origin, time, the path's throughput,
                    its lane in the camera packet (whose light a queued shadow ray adds to) and its glossy
                    lobe (`lobe_sampling.glossy_lobe`, which rect and disk light samples follow)
    PrevVertex      the vertex a BSDF-sampled ray left (path): position, normal, the BSDF's pdf of the ray,
                    how the light it finds is weighted (power heuristic, 1, or 0), its glossy lobe
                    (`lobe_sampling.glossy_lobe`: the lights' light samples drew towards it), the diffuse
                    share of its BSDF value along the ray (rgb, `bsdf.diffuse_share`; -1 for a camera ray) and
                    whether its light samples were chosen by the tile's `TileLights` (a first vertex)
    Continuation    the specular bounce a shading point chose: alive, the new ray, throughput, attenuation
"""
from collections import namedtuple

PassParams = namedtuple('PassParams', ['cam', 'width', 'height', 's0', 's1', 'spp', 'sampler', 'filt', 'seed',
                                       'max_depth', 'use_lens', 'use_time', 'strategy', 'window'])
Tile = namedtuple('Tile', ['index', 'x0', 'y0', 'x1', 'y1'])
Packet = namedtuple('Packet', ['valid', 'f', 'u', 'shift'])
ShadowQueue = namedtuple('ShadowQueue', ['packet', 'lane', 'contrib', 'count', 'direct', 'light_u'])
Lanes = namedtuple('Lanes', ['o', 'd', 'time', 'ids', 'L', 'u', 'film', 'key32', 'work'])
Scratch = namedtuple('Scratch', ['packet', 'f', 'u', 'm', 'm32', 'counts', 'queue', 'lanes', 'rec', 'tl'])
TileLights = namedtuple('TileLights', ['w', 'pmf', 'cdf', 'head'])
Tracer = namedtuple('Tracer', ['scene', 'f', 'u', 'm', 'm32', 'counts', 'queue', 'tile', 'rec', 'tl'])
SampleKey = namedtuple('SampleKey', ['sampler', 'seed', 'pixel', 'index', 'spp'])
Path = namedtuple('Path', ['key', 'lane', 'time'])
Ray = namedtuple('Ray', ['o', 'd'])
Hit = namedtuple('Hit', ['inst_id', 'inst_prim', 'geom_id', 'prim_id', 'u', 'v', 't'])
ShadingPoint = namedtuple('ShadingPoint', ['p', 'ng', 'ns', 'st', 'mat', 'model', 'front', 'wo', 'kd', 'ks', 'rmo'])
PathState = namedtuple('PathState', ['L', 'T', 'A'])
Vertex = namedtuple('Vertex', ['p', 'ng', 'ns', 'tt', 'bb', 'wo', 'po', 'time', 'T', 'lane', 'lobe'])
PrevVertex = namedtuple('PrevVertex', ['p', 'n', 'pdf', 'mode', 'lobe', 'share', 'tiled'])
Continuation = namedtuple('Continuation', ['alive', 'o', 'd', 'T', 'A'])
