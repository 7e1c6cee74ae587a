"""Run under Blender's Python module (`bpy`): import a USD file with Blender's USD importer and
print what it made as one JSON line (prefix ``JSON``).  Used by test_interop_blender.py in a child
process (bpy bundles its own USD libraries, which must not meet usd-core's in one process).

    python blender_import.py scene.usda 1|0      # 1 = support_scene_instancing (Blender's default)

Per object: its type, world matrix, collections, the instanced collection, the materials of its
slots and, per material, the base colour Blender shows (the Principled BSDF's "Base Color" input,
or its default when nothing is linked there; None when a texture drives it).  The world colour is
the Background node's colour of the scene's world (None when there is no world node tree).
"""
import json
import sys

import bpy

path, instancing = sys.argv[1], sys.argv[2] == '1'
bpy.ops.wm.read_factory_settings(use_empty=True)
# Blender's default scene has a world, which its importer fills from a DomeLight; the empty one has
# none (and the importer then makes none), so give it one
bpy.context.scene.world = bpy.data.worlds.new('World')
result = bpy.ops.wm.usd_import(filepath=path, support_scene_instancing=instancing)


def base_colour(material):
    if material is None or material.node_tree is None:
        return None
    for node in material.node_tree.nodes:
        if node.type == 'BSDF_PRINCIPLED':
            socket = node.inputs['Base Color']
            return None if socket.is_linked else list(socket.default_value)[:3]
    return None


def world_colour(world):
    if world is None or world.node_tree is None:
        return None
    for node in world.node_tree.nodes:
        if node.type == 'BACKGROUND':
            socket = node.inputs['Color']
            if socket.is_linked:
                source = socket.links[0].from_node
                if source.type == 'RGB':
                    return list(source.outputs[0].default_value)[:3]
                return None
            return list(socket.default_value)[:3]
    return None


objects = []
for o in bpy.data.objects:
    objects.append(dict(name=o.name, type=o.type, parent=o.parent.name if o.parent else None,
                        instance_type=o.instance_type,
                        instance_collection=o.instance_collection.name if o.instance_collection else None,
                        collections=[c.name for c in o.users_collection],
                        matrix=[list(row) for row in o.matrix_world],
                        materials=[s.material.name if s.material else None for s in o.material_slots]))
materials = {m.name: base_colour(m) for m in bpy.data.materials}
world = world_colour(bpy.context.scene.world)
print('JSON' + json.dumps(dict(result=sorted(result), version=bpy.app.version_string, objects=objects,
                               materials=materials, world=world)))
