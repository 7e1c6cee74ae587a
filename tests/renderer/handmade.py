"""Small SceneDescriptions built by hand (no USD), for tests with closed-form answers."""
import numpy as np

from rtc.renderer import description as D


def look_at(eye, at, up=(0.0, 1.0, 0.0)) -> np.ndarray:
    """Camera-to-world matrix (column vectors) looking from eye to at, +Y up."""
    eye, at, up = (np.asarray(v, np.float64) for v in (eye, at, up))
    w = eye - at
    w /= np.linalg.norm(w)
    u = np.cross(up, w)
    u /= np.linalg.norm(u)
    v = np.cross(w, u)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = u, v, w, eye
    return m


def translate(x, y, z) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = (x, y, z)
    return m


def quad(size=10.0, y=0.0, material=0, path='/quad', center=(0.0, 0.0)) -> D.Mesh:
    """A square in the plane y = const, facing +Y."""
    h = size / 2
    cx, cz = center
    pts = np.array([[cx - h, y, cz - h], [cx + h, y, cz - h], [cx + h, y, cz + h], [cx - h, y, cz + h]], np.float64)
    return D.Mesh(path=path, points=pts, triangles=np.array([[0, 2, 1], [0, 3, 2]], np.int32), material=material)


def static_instances(n_containers=1, matrices=None) -> D.Instances:
    """One identity placement per container (or the given (N, 4, 4) matrices of container 0)."""
    if matrices is None:
        mats = np.repeat(np.eye(4)[None, None], n_containers, axis=0)
        cont = np.arange(n_containers, dtype=np.int32)
    else:
        mats = np.asarray(matrices, np.float64)[:, None]
        cont = np.zeros(len(mats), np.int32)
    return D.Instances(container=cont, matrices=mats, material_set=np.zeros(len(cont), np.int32),
                       material_sets=[()])


def ortho_down(height=10.0, width=2.0, y=5.0) -> D.Camera:
    """Orthographic camera above the origin looking down -Y, image up = -Z, film `width` wide."""
    m = np.eye(4)
    m[:3, 0] = (1, 0, 0)       # screen right = +X
    m[:3, 1] = (0, 0, -1)      # screen up = -Z
    m[:3, 2] = (0, 1, 0)       # camera looks down -local Z = -Y
    m[:3, 3] = (0, y, 0)
    return D.Camera(path='/cam', matrix=m, projection='orthographic', horizontal_aperture=width,
                    vertical_aperture=width)


def scene(containers, materials, lights, camera, instances=None, width=32, height=32, background=(0, 0, 0),
          textures=()) -> D.SceneDescription:
    return D.SceneDescription(
        source='<test>', containers=containers,
        instances=instances if instances is not None else static_instances(len(containers)),
        materials=materials, textures=list(textures), lights=lights, camera=camera,
        settings=D.RenderSettings(width=width, height=height), background=background)


def point_light(pos, intensity) -> D.Light:
    return D.Light(path='/light', type=D.POINT, matrix=translate(*pos), radiance=tuple(intensity))


def rect_light(center, width, height, radiance, facing_down=True) -> D.Light:
    """RectLight centred at `center`, emitting along -Y (its local -Z mapped to -Y)."""
    m = np.eye(4)
    m[:3, 0] = (1, 0, 0)
    m[:3, 1] = (0, 0, -1)
    m[:3, 2] = (0, 1, 0)       # local +Z = +Y, so it emits along -Y
    m[:3, 3] = center
    return D.Light(path='/rect', type=D.RECT, matrix=m, radiance=tuple(radiance), width=width, height=height)


def exr_file(path, pixels) -> str:
    """Writes pixels (rows x columns x channels) to an OpenEXR file of floats at path; returns the path."""
    import OpenImageIO as oiio
    pixels = np.ascontiguousarray(pixels, np.float32)
    out = oiio.ImageOutput.create(str(path))
    out.open(str(path), oiio.ImageSpec(pixels.shape[1], pixels.shape[0], pixels.shape[2], 'float'))
    out.write_image(pixels)
    out.close()
    return str(path)


def estimator_means(desc, nee_spp=128, bsdf_spp=1024, mis_spp=128, seeds=2):
    """(light sampling, BSDF sampling, MIS) estimates of the image mean of `desc`: path, direct light only (max depth
    1), independent samples, the mean of `seeds` seeds each; they must agree when each has converged."""
    from rtc.renderer.host.render import Renderer
    from rtc.renderer.options import RenderOptions
    with Renderer(desc, threads=2) as r:
        def mean(strategy, spp):
            return np.mean([r.render(RenderOptions(spp=spp, seed=s, integrator='path', max_depth=1, strategy=strategy,
                                                   sampler='independent')).image.astype(np.float64)
                            for s in range(seeds)])
        return mean('nee', nee_spp), mean('bsdf', bsdf_spp), mean('mis', mis_spp)
