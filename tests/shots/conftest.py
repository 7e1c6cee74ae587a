"""A tiny animated, instanced, motion-blurred shot (benchmarks/gen_shot.py) and its frames rendered
the plain way: one process, `render(read_stage(path, time=frame))`."""
import numpy as np
import pytest

from rtc.renderer.host.film import read_image
from rtc.renderer.host.render import RenderOptions, render
from rtc.renderer.usd.stage import read_stage

from benchmarks.gen_shot import write_shot

W, H, SPP, FRAMES = 32, 24, 4, 4


@pytest.fixture(scope='session')
def shot_path(tmp_path_factory):
    path = tmp_path_factory.mktemp('shot') / 'shot.usda'
    write_shot(str(path), frames=FRAMES, instances=8, tris=200, width=W, height=H, spp=SPP)
    return str(path)


@pytest.fixture(scope='session')
def reference(shot_path):
    """frame -> float32 image of a one-process render (seed 3)."""
    cache = {}

    def get(frame):
        if frame not in cache:
            desc = read_stage(shot_path, time=frame)
            cache[frame] = render(desc, RenderOptions(seed=3)).image
        return cache[frame]
    return get


def same_bits(path, image) -> bool:
    got = read_image(path)
    return got.dtype == image.dtype and got.shape == image.shape and got.tobytes() == image.tobytes()
