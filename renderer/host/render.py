"""The render loop: build the scene, run passes of samples, report progress, stop cleanly.

A render is a sequence of passes; pass i adds samples [s_i, s_{i+1}) of every pixel.  Because each
sample's random numbers depend only on (seed, pixel, sample index, dimension) and each pixel's samples
are added in index order, any split into passes - including an interrupted render resumed from a
checkpoint - gives a bit-identical image.  Passes grow so that each takes about `pass_seconds`
(the first is one sample per pixel: the time to the first full image).
"""
from __future__ import annotations

import time as _time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import NamedTuple

import numba
import numpy as np

from .. import description as D
from ..errors import RenderError
from ..options import RenderOptions, resolve
from .build import build, path_top
from .features import general_kernels, scene_features
from ..kernel.cameras import C_LENS, camera_table
from .film import Film
from ..kernel.filters import FILTER_NAMES
from ..kernel.integrator import (BAD_SAMPLES, N_COUNTERS, RAYS_CAMERA, RAYS_SECONDARY, RAYS_SHADOW, RAYS_SHADOW_PACKET,
                                 new_scratch, render_tiles)
from ..kernel.tiles import TILE, n_tiles
from ..kernel.records import PassParams
from ..kernel.specialize import specialize
from ..kernel.samplers import SAMPLER_NAMES
from ..kernel.path import STRATEGIES, render_tiles_path
from .light_selection import path_lights


__all__ = ['RenderError', 'RenderOptions', 'RenderResult', 'RenderStats', 'Renderer', 'render']


@dataclass
class RenderStats:
    seconds: float = 0.0
    build_seconds: float = 0.0
    first_pass_seconds: float = 0.0
    kernel_seconds: float = 0.0       # loading (or, on the first run, compiling) the numba kernel
    rays_camera: int = 0
    rays_shadow: int = 0
    rays_shadow_packet: int = 0       # of rays_shadow: first-hit shadow rays, traced in 16-ray packets
    rays_secondary: int = 0
    bad_samples: int = 0
    passes: list = field(default_factory=list)      # (spp_end, seconds)

    @property
    def rays(self) -> int:
        return self.rays_camera + self.rays_shadow + self.rays_secondary


class PassSetup(NamedTuple):
    """What the passes of one render share (`Renderer.setup`)."""
    entry: object                     # the integrator's kernel entry point, specialised for `features`
    features: object                  # kernel.features.Features, or None (the general kernel)
    ctab: np.ndarray                  # the camera table
    use_lens: bool
    use_time: bool


@dataclass
class RenderResult:
    image: np.ndarray                 # float32 (h, w, 3) linear
    film: Film
    options: RenderOptions
    stats: RenderStats
    interrupted: bool = False

    def metadata(self) -> dict:
        s = self.stats
        return {'rtc:spp': self.film.spp, 'rtc:sampler': self.options.sampler, 'rtc:filter': self.options.filter,
                'rtc:seed': self.options.seed, 'rtc:seconds': round(s.seconds, 4), 'rtc:rays': s.rays,
                'rtc:maxDepth': self.options.max_depth, 'rtc:integrator': self.options.integrator,
                'rtc:interrupted': int(self.interrupted)}


class Renderer:
    """A scene built once and rendered with given options; reusable for several renders (converge)."""

    def __init__(self, desc: D.SceneDescription, threads: int | None = None, reuse: 'Renderer | None' = None):
        """`reuse`: a Renderer of a description with the same containers (the previous frame of a
        shot), whose prototype BVHs this one takes over (`build`'s reuse); it is closed."""
        t0 = _time.perf_counter()
        self.threads = max(1, int(threads)) if threads else None
        self._pool = None
        self._scratch = {}                 # integrator -> one `Scratch` per render thread
        self.desc = desc
        with np.errstate(all='ignore'):      # values past float32 (a radius of 1e300) turn inf, as Embree's would
            self.built = build(desc, threads=threads, reuse=reuse.built if reuse is not None else None)
        if reuse is not None:
            reuse.close()
        self.build_seconds = _time.perf_counter() - t0
        self._lights = None
        self._path_top = None
        # packets of 16 rays traced 16 or 8 at a time (`embree.Device.packet_width`); the path integrator's
        # shadow rays in packets where Embree runs them with its own kernels (AVX-512, AVX2), else one by one
        # (set both before the first render to choose otherwise, as the tests do).  The cook integrator's
        # camera packets stay one 16-ray query: where Embree emulates it (AVX2) its hits are those of single
        # rays, where its 8-wide kernels' differ in the last bits (t, u, v), and cook's images are those of
        # before the path integrator (issue 13); its shadow queue only asks yes or no, in `packet_width`s.
        self.packet_width = self.built.device.packet_width
        self.shadow_packets = self.built.device.native_packets

    def path_lights(self):
        """The path integrator's light record (built on its first use: cook renders never build it), and
        its top level (`build.path_top`)."""
        if self._lights is None:
            d = self.built.data
            group = len(self.built.top.groups)
            with np.errstate(all='ignore'):  # (as in `build`: values past float32 turn inf)
                lights, shapes = path_lights(self.desc, d.li_f, self.built.top.bounds(), group, data=d,
                                             shadow_packets=self.shadow_packets)
                self._path_top, base, direct = path_top(self.built, self.desc.containers, shapes, group)
            self._lights = lights._replace(direct_base=base, direct=direct)
        return self._lights

    def path_scene(self) -> int:
        """The Embree scene path renders trace (`build.path_top`): the placements and the light shapes, or
        a scene with no instancing flat; the built top level when neither applies."""
        self.path_lights()
        return self._path_top.handle if self._path_top is not None else self.built.handle

    def setup(self, o: RenderOptions) -> PassSetup:
        """What every pass of a render with resolved options `o` shares: its kernel entry point
        (specialised for what the render needs, `kernel/specialize.py`; compiled on its first call or
        loaded from the kernel cache), the camera table and whether the lens and the shutter are
        sampled."""
        ctab, use_lens, use_time = self.camera(o)
        features = None if general_kernels() else scene_features(
            self.built.data, o, ctab, use_time, self.path_lights() if o.integrator == 'path' else None)
        entry = specialize(render_tiles_path if o.integrator == 'path' else render_tiles, features)
        return PassSetup(entry, features, ctab, use_lens, use_time)

    def run_pass(self, o: RenderOptions, setup: PassSetup, s0: int, s1: int, sums: np.ndarray, counters: np.ndarray,
                 ray_record=None, window=None) -> None:
        """Add samples [s0, s1) of every pixel of `window` (x0, y0, x1, y1; None: the whole image) to `sums`
        (window height, width, 3) float64 with the integrator of resolved options `o`, on every render
        thread; `counters` int64 (n_tiles of the whole image, N_COUNTERS); `ray_record`: None, or a
        `ray_record.RayRecord` that receives every ray (benchmarks)."""
        pp = self.pass_params(o, s0, s1, setup.ctab, setup.use_lens, setup.use_time, window)
        n = self.n_threads() if s1 > s0 else 1
        scratch = self._scratch.setdefault(o.integrator, [])
        while len(scratch) < n:
            scratch.append(new_scratch(len(self.built.data.li_type), self.packet_width,
                                       self.packet_width if o.integrator == 'path' else 16,
                                       self.path_lights().leaf_k.shape[0] if o.integrator == 'path' else 0))
        work = np.zeros(1, np.int64)             # the pass's tile counter (tiles.next_tile)
        data, handle, entry = self.built.data, self.built.handle, setup.entry
        if ray_record is not None:
            scratch = [s._replace(rec=ray_record) for s in scratch]
        if o.integrator == 'path':
            lights, handle = self.path_lights(), self.path_scene()
            self._on_threads(n, lambda t: entry(data, lights, handle, pp, scratch[t], work, sums, counters))
        else:
            self._on_threads(n, lambda t: entry(data, handle, pp, scratch[t], work, sums, counters))

    def n_threads(self) -> int:
        """Render threads: the Renderer's `threads`, else numba's thread count (NUMBA_NUM_THREADS, or
        what `numba.set_num_threads` chose)."""
        return self.threads or numba.get_num_threads()

    def _on_threads(self, n, call):
        """call(t) for t < n, on n threads at once (the kernels release the GIL); the first error raises."""
        if n == 1:
            call(0)
            return
        if self._pool is None or self._pool._max_workers < n:
            if self._pool is not None:
                self._pool.shutdown()
            self._pool = ThreadPoolExecutor(max_workers=n, thread_name_prefix='rtc-render')
        for f in [self._pool.submit(call, t) for t in range(n)]:
            f.result()

    def close(self):
        if getattr(self, '_pool', None) is not None:
            self._pool.shutdown()
            self._pool = None
        if getattr(self, '_path_top', None) is not None:
            self._path_top.close()
            self._path_top = None
        self.built.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def camera(self, o: RenderOptions):
        """(camera table, use_lens, use_time) of a render with resolved options `o`: the lens and the
        shutter are used only if the camera and the scene need them and the options allow them."""
        cam = self.desc.camera
        use_lens = o.depth_of_field and cam.lens_radius > 0 and not self.desc.settings.disable_depth_of_field
        use_time = (o.motion_blur and not self.desc.settings.disable_motion_blur
                    and (self.built.motion_steps > 1 or cam.motion is not None))
        ctab = camera_table(cam, o.width, o.height, self.built.origin, depth_of_field=use_lens,
                            motion_blur=use_time)
        return ctab, bool(ctab[C_LENS] > 0), use_time

    def pass_params(self, o: RenderOptions, s0: int, s1: int, ctab=None, use_lens=None, use_time=None, window=None):
        """The kernels' `PassParams` of samples [s0, s1) of a render with resolved options `o` (of the pixels
        of `window`, None: the whole image)."""
        if ctab is None:
            ctab, use_lens, use_time = self.camera(o)
        window = check_window(window, o.width, o.height)
        return PassParams(ctab, o.width, o.height, s0, s1, o.spp, SAMPLER_NAMES[o.sampler], FILTER_NAMES[o.filter],
                          o.seed, o.max_depth, bool(use_lens), bool(use_time), STRATEGIES[o.strategy], window)

    def render(self, options: RenderOptions | None = None, *, film: Film | None = None, should_stop=lambda: False,
               on_pass=None, ray_record=None, window=None) -> RenderResult:
        """Render with `options` resolved against the scene's render settings (None: the options the
        reader resolved) until `spp` samples per pixel (continuing `film` if given) or until
        `should_stop()` is true between passes.  `on_pass(result)` is called after every pass.
        `ray_record`: None, or `ray_record.new_ray_record(n_tiles, cap)` to store the rays traced
        (benchmarks).  `window` (x0, y0, x1, y1): render only those pixels, into a film of the window's
        size, bit for bit the same values as the whole image's render there (a shot's tile task); x0, y0
        multiples of `tiles.TILE`, x1, y1 too or the image's edges."""
        o = resolve(options if options is not None else self.desc.options, self.desc.settings)
        setup = self.setup(o)
        win = check_window(window, o.width, o.height)
        fw, fh = win[2] - win[0], win[3] - win[1]
        if film is None:
            film = Film(fw, fh)
        elif (film.width, film.height) != (fw, fh):
            raise RenderError(f'checkpoint is {film.width}x{film.height}, render is {fw}x{fh}')
        counters = np.zeros((n_tiles(o.width, o.height), N_COUNTERS), np.int64)
        stats = RenderStats(build_seconds=self.build_seconds)
        result = RenderResult(image=film.image(), film=film, options=o, stats=stats)
        s = film.spp
        # an empty pass (no samples) loads the cached kernel - or compiles it on the very first run -
        # so that the render's time and ray rate measure rendering only
        t0 = _time.perf_counter()
        self.run_pass(o, setup, s, s, film.sum, counters, ray_record, win)
        stats.kernel_seconds = _time.perf_counter() - t0
        t_start = _time.perf_counter()
        step = 1
        while s < o.spp:
            if should_stop():
                result.interrupted = True
                break
            s1 = min(o.spp, s + step)
            t0 = _time.perf_counter()
            self.run_pass(o, setup, s, s1, film.sum, counters, ray_record, win)
            dt = _time.perf_counter() - t0
            film.count += s1 - s
            stats.passes.append((s1, dt))
            if len(stats.passes) == 1:
                stats.first_pass_seconds = dt
            per_sample = dt / (s1 - s)
            s = s1
            step = max(1, min(o.spp - s, int(o.pass_seconds / max(per_sample, 1e-9))))
            tot = counters.sum(0)
            stats.rays_camera, stats.rays_shadow = int(tot[RAYS_CAMERA]), int(tot[RAYS_SHADOW])
            stats.rays_secondary, stats.bad_samples = int(tot[RAYS_SECONDARY]), int(tot[BAD_SAMPLES])
            stats.rays_shadow_packet = int(tot[RAYS_SHADOW_PACKET])
            stats.seconds = _time.perf_counter() - t_start
            if on_pass is not None:
                on_pass(result)
        stats.seconds = _time.perf_counter() - t_start
        result.image = film.image()
        return result


def check_window(window, width: int, height: int) -> tuple:
    """The pixel window (x0, y0, x1, y1) of a render of width x height pixels: None is the whole image;
    else x0, y0 multiples of TILE, x1, y1 multiples of TILE or the image's edges (RenderError if not)."""
    if window is None:
        return (0, 0, int(width), int(height))
    x0, y0, x1, y1 = (int(v) for v in window)
    ok = (0 <= x0 < x1 <= width and 0 <= y0 < y1 <= height and x0 % TILE == 0 and y0 % TILE == 0
          and (x1 % TILE == 0 or x1 == width) and (y1 % TILE == 0 or y1 == height))
    if not ok:
        raise RenderError(f'window {window} is not a window of {TILE}-pixel tiles of a {width}x{height} image')
    return (x0, y0, x1, y1)


def render(desc: D.SceneDescription, options: RenderOptions | None = None, **kw) -> RenderResult:
    """One-shot convenience: build, render, release."""
    threads = (options or desc.options or RenderOptions()).threads
    with Renderer(desc, threads=threads) as r:
        return r.render(options, **kw)
