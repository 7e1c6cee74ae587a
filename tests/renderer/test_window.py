"""A render of a window of the image (a shot's tile task: `Renderer.render(window=...)`) gives the whole
image's values there bit for bit, with both integrators, for windows inside the image and at its edges;
windows that do not fall on tile boundaries are refused."""
import numpy as np
import pytest

from rtc.renderer.errors import RenderError
from rtc.renderer.host.render import RenderOptions, Renderer
from tests.renderer.test_specialize import _rich_path_scene

WINDOWS = [(0, 0, 8, 8), (8, 0, 24, 16), (16, 8, 37, 21), (0, 16, 37, 21)]      # image 37 x 21


@pytest.mark.parametrize('integrator', ['cook', 'path'])
def test_a_window_is_the_whole_images_crop(integrator):
    opts = RenderOptions(width=37, height=21, spp=6, integrator=integrator, max_depth=3, pass_seconds=1e-9)
    with Renderer(_rich_path_scene()) as r:
        whole = r.render(opts).image
        assert whole.max() > 0.05
        for x0, y0, x1, y1 in WINDOWS:
            part = r.render(opts, window=(x0, y0, x1, y1))
            assert part.image.shape == (y1 - y0, x1 - x0, 3)
            assert np.array_equal(part.image, whole[y0:y1, x0:x1]), (x0, y0, x1, y1)
            assert part.stats.rays_camera == (y1 - y0) * (x1 - x0) * 6


@pytest.mark.parametrize('window', [(4, 0, 16, 8), (0, 0, 12, 8), (0, 0, 40, 8), (8, 8, 8, 16)])
def test_a_window_off_the_tile_grid_is_refused(window):
    with Renderer(_rich_path_scene()) as r:
        with pytest.raises(RenderError, match='window'):
            r.render(RenderOptions(width=37, height=21, spp=1), window=window)
