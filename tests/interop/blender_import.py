"""Run under Blender's Python module (`bpy`): import a USD file with Blender's USD importer and
print what it made as one JSON line (prefix ``JSON``).  Used by test_interop_blender.py in a child
process (bpy bundles its own USD libraries, which must not meet usd-core's in one process).

    python blender_import.py scene.usda 1|0      # 1 = support_scene_instancing (Blender's default)
"""
import json
import sys

import bpy

path, instancing = sys.argv[1], sys.argv[2] == '1'
bpy.ops.wm.read_factory_settings(use_empty=True)
result = bpy.ops.wm.usd_import(filepath=path, support_scene_instancing=instancing)
objects = []
for o in bpy.data.objects:
    objects.append(dict(name=o.name, type=o.type, parent=o.parent.name if o.parent else None,
                        instance_type=o.instance_type,
                        instance_collection=o.instance_collection.name if o.instance_collection else None,
                        collections=[c.name for c in o.users_collection],
                        matrix=[list(row) for row in o.matrix_world],
                        materials=[s.material.name if s.material else None for s in o.material_slots]))
print('JSON' + json.dumps(dict(result=sorted(result), version=bpy.app.version_string, objects=objects)))
