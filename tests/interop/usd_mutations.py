"""Semantic mutations of a USD stage for fuzzing the stage reader: the file stays valid USD, its values turn odd.

Each mutation is authored on the stage's root layer (an opinion over whatever the stage composes), chosen by a
`random.Random` (the tests seed one per case):

* a value: an attribute of a prim set to an odd value of its own type (NaN, Inf, 1e38, 1e300, -1, 0 in a component;
  for arrays: empty, one element, doubled, truncated, one element poisoned), at the default time or as a time
  sample, or blocked;
* a prim's type changed to another schema's (a Mesh becomes a Sphere, a light a PointInstancer ...);
* a prim deactivated, or its instanceable flag flipped;
* a relationship retargeted (material bindings, skeletons, prototypes) to a missing prim, the prim itself or any
  other; a shader input connected to another prim's output, missing or not;
* an xformOpOrder naming an op that does not exist;
* a schema attribute re-declared with the wrong type (radius as a string, points as a bool ...).

`mutate` returns the mutations it made, as lines for the failure message.
"""
from __future__ import annotations

import random

from pxr import Gf, Sdf, Usd, Vt

ODD_FLOATS = [float('nan'), float('inf'), -float('inf'), 1e38, -1e38, 0.0, -0.0, -1.0, 1e-38, 3e9, 1e300, -1e300]
ODD_INTS = [-1, 0, 7, 1_000_000, 2 ** 31 - 1, -2 ** 31]
TOKENS = ['bogus', '', 'none', 'catmullClark', 'cubic', 'linear', 'bspline', 'catmullRom', 'bezier', 'vertex',
          'varying', 'uniform', 'faceVarying', 'constant', 'periodic', 'nonperiodic', 'pinned', 'rightHanded',
          'leftHanded', 'X', 'Y', 'Z', 'invisible', 'inherited', 'orthographic', 'perspective', 'sRGB', 'raw',
          'repeat', 'clamp', 'mirror', 'black', 'latlong', 'angular', 'guide', 'proxy', 'render', 'tube', 'ribbon']
STRINGS = ['', 'x', '../../etc/passwd', 'a' * 300]
ASSETS = ['', 'nonexistent.png', 'missing.usda', '/dev/null', 'x.exr', '.']
TYPES = ['Mesh', 'Sphere', 'Cube', 'Cylinder', 'Cone', 'Capsule', 'Plane', 'Points', 'BasisCurves', 'NurbsCurves',
         'PointInstancer', 'Xform', 'Scope', 'RectLight', 'DiskLight', 'SphereLight', 'CylinderLight', 'DistantLight',
         'DomeLight', 'Camera', 'Material', 'Shader', 'TetMesh', 'NurbsPatch', 'SkelRoot', 'Skeleton', 'GeomSubset',
         'Volume', 'PortalLight', 'GeometryLight', 'Cylinder_1', 'Capsule_1', '', 'Bogus']
RELATIONSHIPS = ['material:binding', 'skel:skeleton', 'skel:animationSource', 'prototypes', 'proxyPrim',
                 'light:filters']
OUTPUTS = ['outputs:rgb', 'outputs:surface', 'outputs:r', 'outputs:result', 'inputs:file', 'outputs:nope']
OPS = ['xformOp:translate:missing', '!resetXformStack!', 'xformOp:bogus', 'xformOp:scale']
RETYPED = ['radius', 'points', 'intensity', 'inputs:intensity', 'height', 'size', 'widths', 'faceVertexIndices',
           'xformOp:translate', 'primvars:displayColor', 'inputs:radius', 'inputs:width', 'inputs:diffuseColor',
           'inputs:roughness', 'protoIndices', 'curveVertexCounts', 'inputs:texture:file', 'inputs:color',
           'inputs:diffuse', 'inputs:specular']
WRONG_VALUES = [(Sdf.ValueTypeNames.String, 'x'), (Sdf.ValueTypeNames.Int, 3),
                (Sdf.ValueTypeNames.Float3, Gf.Vec3f(1, 2, 3)), (Sdf.ValueTypeNames.FloatArray, Vt.FloatArray([1, 2])),
                (Sdf.ValueTypeNames.Bool, True), (Sdf.ValueTypeNames.Token, 'bogus')]
SCALARS = {'float', 'double', 'half', 'int', 'uint', 'int64', 'uint64', 'uchar', 'bool', 'token', 'string', 'asset'}


def _odd_scalar(rng: random.Random, kind: str):
    if kind in ('float', 'double', 'half'):
        return rng.choice(ODD_FLOATS)
    if kind in ('int', 'int64'):
        return rng.choice(ODD_INTS)
    if kind in ('uint', 'uint64', 'uchar'):
        return min(abs(rng.choice(ODD_INTS)), 255 if kind == 'uchar' else 2 ** 31 - 1)
    if kind == 'bool':
        return rng.choice([True, False])
    if kind == 'token':
        return rng.choice(TOKENS)
    if kind == 'string':
        return rng.choice(STRINGS)
    return Sdf.AssetPath(rng.choice(ASSETS))


def _poisoned(rng: random.Random, kind: str, value):
    """`value` (of scalar type `kind`) with an odd component, or None where it cannot be poisoned."""
    if kind in SCALARS:
        return _odd_scalar(rng, kind)
    if value is None:
        return None
    if kind.startswith('matrix'):
        rows = [list(value.GetRow(i)) for i in range(4)]
        rows[rng.randrange(4)][rng.randrange(4)] = rng.choice(ODD_FLOATS)
        return type(value)(*[x for row in rows for x in row])
    try:
        comps = list(value)
    except TypeError:
        return None
    if not comps:
        return None
    k = rng.randrange(len(comps))
    comps[k] = rng.choice(ODD_INTS) if isinstance(comps[0], int) else rng.choice(ODD_FLOATS)
    try:
        return type(value)(*comps)
    except (TypeError, ValueError, OverflowError):
        return None


def odd_value(rng: random.Random, attr: Usd.Attribute):
    """An odd value of `attr`'s own type, from its current value; None where none can be made."""
    type_name = attr.GetTypeName()
    kind = str(type_name.scalarType)
    current = attr.Get()
    if not type_name.isArray:
        return _poisoned(rng, kind, current)
    items = list(current) if current is not None else []
    op = rng.choice(['empty', 'one', 'double', 'truncate', 'poison', 'poison', 'extra']) if items else 'empty'
    if op == 'empty':
        items = []
    elif op == 'one':
        items = items[:1]
    elif op == 'double':
        items = items + items
    elif op == 'truncate':
        items = items[:rng.randrange(len(items))]
    elif op == 'extra':
        items = items + items[:1]
    else:
        k = rng.randrange(len(items))
        items[k] = _poisoned(rng, kind, items[k])
        if items[k] is None:
            return None
    try:
        return type_name.type.pythonClass(items)
    except (TypeError, ValueError, OverflowError):
        return None


def _editable_prims(stage: Usd.Stage) -> list[Usd.Prim]:
    """The prims an opinion on the root layer can change: every prim but those inside instances."""
    return [p for p in stage.Traverse(Usd.PrimAllPrimsPredicate) if not p.IsInstanceProxy()]


def _value(rng, stage, prim, log):
    attrs = prim.GetAttributes()
    if not attrs:
        return
    attr = rng.choice(attrs)
    how = rng.choice(['default'] * 4 + ['sample', 'block'])
    if how == 'block':
        attr.Block()
        log.append(f'blocked {attr.GetPath()}')
        return
    value = odd_value(rng, attr)
    if value is None:
        return
    time = Usd.TimeCode.Default() if how == 'default' else Usd.TimeCode(rng.choice([0, 1, 24, -5, 1e9]))
    attr.Set(value, time)
    log.append(f'{attr.GetPath()} = {str(value)[:80]} at {time}')


def _retype(rng, stage, prim, log):
    name = rng.choice(TYPES)
    prim.SetTypeName(name)
    log.append(f'{prim.GetPath()} retyped {name!r}')


def _deactivate(rng, stage, prim, log):
    prim.SetActive(False)
    log.append(f'{prim.GetPath()} deactivated')


def _instanceable(rng, stage, prim, log):
    prim.SetInstanceable(not prim.IsInstanceable())
    log.append(f'{prim.GetPath()} instanceable = {prim.IsInstanceable()}')


def _relationship(rng, stage, prim, log):
    target = rng.choice([Sdf.Path('/Nope'), rng.choice(_editable_prims(stage)).GetPath(), prim.GetPath()])
    rels = prim.GetRelationships()
    rel = rng.choice(rels) if rels and rng.random() < 0.7 else prim.CreateRelationship(rng.choice(RELATIONSHIPS))
    rel.SetTargets([target])
    log.append(f'{rel.GetPath()} -> {target}')


def _connection(rng, stage, prim, log):
    ports = [a for a in prim.GetAttributes() if a.GetName().startswith(('inputs:', 'outputs:'))]
    if not ports:
        return
    port = rng.choice(ports)
    source = rng.choice(_editable_prims(stage)).GetPath().AppendProperty(rng.choice(OUTPUTS))
    port.SetConnections([source])
    log.append(f'{port.GetPath()} <- {source}')


def _op_order(rng, stage, prim, log):
    current = prim.GetAttribute('xformOpOrder')
    order = list(current.Get() or []) if current else []
    order.insert(rng.randrange(len(order) + 1), rng.choice(OPS))
    prim.CreateAttribute('xformOpOrder', Sdf.ValueTypeNames.TokenArray, True).Set(order)
    log.append(f'{prim.GetPath()}.xformOpOrder = {order}')


def _wrong_type(rng, stage, prim, log):
    name = rng.choice(RETYPED)
    type_name, value = rng.choice(WRONG_VALUES)
    spec = stage.GetRootLayer().GetPrimAtPath(prim.GetPath()) or Sdf.CreatePrimInLayer(stage.GetRootLayer(),
                                                                                        prim.GetPath())
    if name in spec.properties:
        del spec.properties[name]
    Sdf.AttributeSpec(spec, name, type_name)
    prim.GetAttribute(name).Set(value)
    log.append(f'{prim.GetPath()}.{name} declared {type_name} = {value}')


MUTATIONS = [_value] * 6 + [_retype, _deactivate, _instanceable, _relationship, _connection, _op_order,
                            _wrong_type]


def mutate(rng: random.Random, stage: Usd.Stage, count: int) -> list[str]:
    """`count` mutations of `stage`'s root layer; the lines describing those made."""
    log: list[str] = []
    prims = _editable_prims(stage)
    if not prims:
        return log
    read = [p for p in prims if p.GetTypeName() not in ('', 'Xform', 'Scope')]    # gprims, lights, shaders ...
    for _ in range(count):
        prim = rng.choice(read if read and rng.random() < 0.75 else prims)
        mutation = rng.choice(MUTATIONS)
        try:
            mutation(rng, stage, prim, log)
        except Exception as exc:                        # usd-core refused the edit itself: no mutant
            log.append(f'({mutation.__name__} on {prim.GetPath()} refused by usd-core: {type(exc).__name__})')
    return log
