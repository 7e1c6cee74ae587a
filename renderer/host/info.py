"""`rtc info SCENE.usd`: what the renderer would see, without rendering.

`describe` summarises a SceneDescription (prototypes and how often each is placed, unique vs
instanced triangles, lights, camera, materials, textures, warnings, skipped prims); the `rtc info`
command (rtc/cli.py) prints it for a USD file or a course XML file compiled in memory.
"""
from __future__ import annotations

from collections import Counter

import numpy as np

from ..description import MODEL_NAMES, BytePixels, SceneDescription
from ..options import resolve

LIGHT_NAMES = ('point', 'sphere', 'rect', 'disk', 'distant', 'dome', 'cylinder')
MODEL_LABELS = {v: k for k, v in MODEL_NAMES.items()}
MAX_LISTED = 20


def describe(desc: SceneDescription) -> str:
    inst = desc.instances
    per_container = np.bincount(inst.container, minlength=len(desc.containers)) if inst.count else \
        np.zeros(len(desc.containers), np.int64)
    unique, instanced = desc.triangle_counts()
    balls = [sum(len(s.balls()) for s in c.spheres) for c in desc.containers]      # (a point cloud: its spheres)
    spheres = sum(balls)
    placed_spheres = sum(b * int(n) for b, n in zip(balls, per_container))
    segs = [sum(len(x.segments) for x in c.curves) for c in desc.containers]
    placed_segs = sum(s * int(n) for s, n in zip(segs, per_container))
    lines = [f'{desc.source}',
             f'  up axis {desc.up_axis} (description is Y-up), metersPerUnit {desc.meters_per_unit:g}',
             f'  prototypes (containers): {len(desc.containers)}, placements: {inst.count}, '
             f'motion samples: {inst.motion_steps} at t = {", ".join(f"{t:g}" for t in desc.shutter_times)}',
             f'  triangles: {unique} unique, {instanced} instanced; '
             f'spheres: {spheres} unique, {placed_spheres} instanced'
             + (f'; curve segments: {sum(segs)} unique, {placed_segs} instanced' if sum(segs) else '')]
    order = np.argsort(-per_container, kind='stable')
    for c in order[:MAX_LISTED]:
        container = desc.containers[c]
        tris = sum(len(m.triangles) for m in container.meshes)
        lines.append(f'    {container.key}: {len(container.meshes)} meshes ({tris} triangles), '
                     f'{balls[c]} spheres, '
                     + (f'{len(container.curves)} curves ({segs[c]} segments), ' if segs[c] else '')
                     + f'placed {int(per_container[c])}x')
    if len(order) > MAX_LISTED:
        lines.append(f'    ... {len(order) - MAX_LISTED} more')
    kinds = Counter(LIGHT_NAMES[light.type] for light in desc.lights)
    shaped = sum(light.shaping is not None or light.ies is not None for light in desc.lights)
    profiled = sum(light.ies is not None for light in desc.lights)
    imaged = sum(light.texture >= 0 for light in desc.lights)
    gained = sum(tuple(light.gains) != (1.0, 1.0) for light in desc.lights)
    lines.append(f'  lights: {len(desc.lights)} (' + ', '.join(f'{k} {n}' for k, n in sorted(kinds.items())) + ')'
                 + (f'; shaped {shaped}' + (f' ({profiled} by an IES profile)' if profiled else '') if shaped else '')
                 + (f'; {imaged} with an image' if imaged else '')
                 + (f'; {gained} with diffuse / specular gains' if gained else ''))
    cam, s = desc.camera, desc.settings
    lines.append(f'  camera: {cam.path} {cam.projection}, focal length {cam.focal_length:g}, aperture '
                 f'{cam.horizontal_aperture:g} x {cam.vertical_aperture:g}, lens radius {cam.lens_radius:g}, '
                 f'focus {cam.focus_distance:g}, shutter [{cam.shutter_open:g}, {cam.shutter_close:g}]'
                 + (f', {len(cam.motion)} motion samples' if cam.motion is not None else ''))
    o = resolve(desc.options, s)
    lines.append(f'  image {o.width} x {o.height}, spp {o.spp} '
                 f'({"render settings " + s.path if s.path else "defaults: no render settings"}), '
                 f'background {tuple(round(x, 4) for x in desc.background)}')
    models = Counter(MODEL_LABELS.get(m.model, str(m.model)) for m in desc.materials)
    lines.append(f'  materials: {len(desc.materials)} (' + ', '.join(f'{k} {n}' for k, n in sorted(models.items()))
                 + f'), material sets: {len(inst.material_sets)}')
    lines.append(f'  textures: {len(desc.textures)}')
    for t in desc.textures[:MAX_LISTED]:
        h, w = t.pixels.shape[:2]
        found = sum(p is not None for p in t.tiles)
        bits = ', 8-bit, kept as bytes' if isinstance(t.pixels, BytePixels) else ''
        lines.append(f'    {t.path} ({found} UDIM tiles of {len(t.tiles)})' if t.tiles else
                     f'    {t.path} ({w} x {h}, {t.pixels.shape[2]} channels{bits})')
    for title, items in (('warnings', desc.warnings), ('skipped', desc.skipped)):
        lines.append(f'  {title}: {len(items)}')
        lines += [f'    {x}' for x in items[:MAX_LISTED]]
        if len(items) > MAX_LISTED:
            lines.append(f'    ... {len(items) - MAX_LISTED} more')
    return '\n'.join(lines)

