"""The camera stage of a packet, shared by both integrators: which (pixel, sample) pairs its 16 lanes
trace, their pixel, lens and time samples, the film positions and the camera rays, written into the
packet (an RTCRayHit16) for one rtcIntersect16.  Each step is a loop over the lanes (structure of
arrays in `records.Lanes`), which LLVM vectorises: the Sobol' sampler draws the whole packet's numbers
at once (`samplers.sobol_packet`), `cameras.camera_rays` turns them into rays branch-free.
"""
import numba as nb
import numpy as np

from .cameras import camera_rays
from .dimensions import pixel_dim, time_dim
from .features import B_SOBOL, F_LENS, F_SAMPLERS, F_TIME
from .filters import filter_offset
from .jit import STAGE_JIT
from .samplers import SOBOL, sample_1d, sample_2d, sample_pixel_lens, sobol_packet
from .tables import C_FAR, C_NEAR
from .trace import PACKET, set_packet_ray


@nb.njit(**STAGE_JIT)
def next_samples(pp, tile, lanes, first, cursor):
    """Fill the lane ids of the packet's samples [first, first + n) of the tile, pixel-major, from
    the cursor (sample index, x, y) of the next one (counters, not three integer divisions per
    sample); returns (n, the new cursor)."""
    total = (tile.x1 - tile.x0) * (tile.y1 - tile.y0) * (pp.s1 - pp.s0)
    n = min(PACKET, total - first)
    nidx, nx, ny = cursor
    for j in range(n):
        pixel = ny * pp.width + nx
        lanes.ids[0, j] = pixel
        lanes.ids[1, j] = nidx
        lanes.ids[2, j] = nx
        lanes.ids[3, j] = ny
        lanes.key32[0, j] = pixel
        lanes.key32[1, j] = nidx
        nidx += 1
        if nidx == pp.s1:
            nidx = pp.s0
            nx += 1
            if nx == tile.x1:
                nx = tile.x0
                ny += 1
    return n, (nidx, nx, ny)


@nb.njit(**STAGE_JIT)
def camera_samples(pp, lanes, n):
    """The pixel, lens and time samples of the packet's lanes, then their film positions."""
    ids = lanes.ids
    lane_t = lanes.time[0]
    if F_SAMPLERS & B_SOBOL and (F_SAMPLERS == B_SOBOL or pp.sampler == SOBOL):      # a packet at a time
        sobol_packet(pp.seed, pixel_dim(), lanes.key32[0], lanes.key32[1], n, 4 if pp.use_lens else 2, lanes.work,
                     lanes.u)
        if F_TIME and pp.use_time:
            sobol_packet(pp.seed, time_dim(), lanes.key32[0], lanes.key32[1], n, np.int64(1), lanes.work, lanes.time)
        else:
            for j in range(n):
                lane_t[j] = 0.0
    else:
        for j in range(n):
            if F_LENS and pp.use_lens:
                a, b, lu, lv = sample_pixel_lens(pp.sampler, pp.seed, ids[0, j], ids[1, j], pp.spp)
                lanes.u[2, j] = lu
                lanes.u[3, j] = lv
            else:
                a, b = sample_2d(pp.sampler, pp.seed, ids[0, j], ids[1, j], pp.spp, pixel_dim())
            lanes.u[0, j] = a
            lanes.u[1, j] = b
            if F_TIME and pp.use_time:
                lane_t[j] = sample_1d(pp.sampler, pp.seed, ids[0, j], ids[1, j], pp.spp, time_dim())
            else:
                lane_t[j] = 0.0
    film = lanes.film
    for j in range(n):
        film[0, j], film[1, j] = filter_offset(pp.filt, lanes.u[0, j], lanes.u[1, j])
    for j in range(n):                  # vectorised: film positions
        film[0, j] = (ids[2, j] + 0.5 + film[0, j]) / pp.width
        film[1, j] = (ids[3, j] + 0.5 + film[1, j]) / pp.height


@nb.njit(**STAGE_JIT)
def camera_rays_into(pp, lanes, packet, n):
    """The lanes' camera rays (`lanes.o`, `lanes.d`) and the packet's first n lanes set to them (the
    others invalid)."""
    cam = pp.cam
    camera_rays(cam, n, lanes.film[0], lanes.film[1], (lanes.u[2], lanes.u[3]), lanes.time[0], lanes.o, lanes.d)
    for j in range(PACKET):
        packet.valid[j] = 0
    lo = lanes.o
    ld = lanes.d
    for j in range(n):
        set_packet_ray(packet, j, (lo[0, j], lo[1, j], lo[2, j]), (ld[0, j], ld[1, j], ld[2, j]), cam[C_NEAR], cam[C_FAR],
                  lanes.time[0, j])
