"""The primvars a UsdGeom.PointInstancer gives each of its instances, as Storm binds them: a primvar authored on
the instancer with one value per instance (interpolation ``vertex``, ``varying`` or ``uniform``), or one value
for all (``constant``), reads on every gprim of that instance's prototype as if authored above it (the
prototype's own primvars are closer, and win: `materials.MaterialTable._primvar_value`).

Only the primvars a material can read are taken: ``displayColor`` (the fallback material's colour) and the
names the stage's UsdPrimvarReaders read (`reader_varnames`: one walk of the stage, made only when an instancer
authors another primvar), so that an instancer's unrelated per-instance data (ids, velocities) costs nothing.
"""
from __future__ import annotations

from typing import Callable, Optional

import numpy as np
from pxr import Usd, UsdGeom, UsdShade

from .primvar_values import flattened

PER_INSTANCE = (UsdGeom.Tokens.vertex, UsdGeom.Tokens.varying, UsdGeom.Tokens.uniform)
# Instances given the same values share a material set; each distinct set of values is resolved on its own (a
# binding query and a material): past this many in one instancer, its primvars are not given (warned)
MAX_DISTINCT = 10_000


def reader_varnames(stage: Usd.Stage) -> frozenset:
    """The primvar names (without the ``primvars:`` namespace) that the stage's UsdPrimvarReader shaders read
    (their inputs:varname, following connections to material interfaces)."""
    names = set()
    for prim in stage.Traverse():
        if prim.GetTypeName() != 'Shader':
            continue
        shader = UsdShade.Shader(prim)
        if not str(shader.GetShaderId() or '').startswith('UsdPrimvarReader'):
            continue
        inp = shader.GetInput('varname')
        for attr in (inp.GetValueProducingAttributes() if inp else []):
            value = attr.Get()
            if isinstance(value, str) and value:
                names.add(value[len('primvars:'):] if value.startswith('primvars:') else value)
    return frozenset(names)


def instance_primvars(pi: Usd.Prim, n: int, time, warn: Callable[[str], None],
                      wanted: Callable[[], frozenset]) -> Optional[list]:
    """Per instance of PointInstancer `pi` (n = its protoIndices' count), a hashable tuple of (name, values)
    of the primvars it gives that instance (values: a tuple of floats), or None when it gives none.  `wanted()`:
    the names materials read besides displayColor (asked only when the instancer authors another primvar).
    A per-instance primvar whose count is not n is left out, warned; so are all of them where they take more
    than MAX_DISTINCT distinct values."""
    found = [pv for pv in UsdGeom.PrimvarsAPI(pi).GetPrimvarsWithAuthoredValues()]
    if not found:
        return None
    names = None
    columns = []
    for pv in found:
        name = pv.GetPrimvarName()
        if name != 'displayColor':
            names = wanted() if names is None else names
            if name not in names:
                continue
        interpolation = pv.GetInterpolation()
        if pv.GetTypeName().isArray:
            values = flattened(pv, time, warn, 'not given to its instances')
        else:
            values = [pv.Get(time)]
        if values is None or len(values) == 0:
            continue
        try:
            v = np.asarray(values, np.float64).reshape(len(values), -1)
        except (TypeError, ValueError):
            continue
        if interpolation in PER_INSTANCE and len(v) != 1:
            if len(v) != n:
                warn(f'{pv.GetAttr().GetPath()}: {len(v)} values for {n} instances; not given to its instances')
                continue
        else:                                            # one value for every instance
            v = v[:1].repeat(n, axis=0)
        columns.append((name, v))
    if not columns:
        return None
    given = [tuple((name, tuple(v[j].tolist())) for name, v in columns) for j in range(n)]
    distinct = len(set(given))
    if distinct > MAX_DISTINCT:
        warn(f'{pi.GetPath()}: primvars {", ".join(name for name, _ in columns)} take {distinct} distinct values over '
             f'its instances, more than {MAX_DISTINCT:,} (a material each); not given to its instances')
        return None
    return given
