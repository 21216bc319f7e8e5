# Renders a perifx run's point cache the way an artist would load it (README: "Blender (3.4, no
# add-on)"): the legacy OBJ importer keeping vertex order, a Mesh Cache modifier on animation.pc2,
# Cycles on the CPU. Used for assets/report/export.md:
#   blender -b --factory-startup --python assets/report/render_export.py -- RUN_DIR FRAME OUT.png [azimuth_deg elevation_deg]
import math
import os
import sys

import bpy
from mathutils import Vector

args = sys.argv[sys.argv.index("--") + 1:]
run, frame, out = args[0], int(args[1]), args[2]
azimuth = math.radians(float(args[3])) if len(args) > 3 else math.radians(-35.0)
elevation = math.radians(float(args[4])) if len(args) > 4 else math.radians(20.0)

bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
bpy.ops.import_scene.obj(filepath=os.path.join(run, "animation.obj"), split_mode="OFF", use_groups_as_vgroups=True)
obj = [o for o in scene.objects if o.type == "MESH"][0]
mod = obj.modifiers.new("perifx", "MESH_CACHE")
mod.cache_format = "PC2"
mod.filepath = os.path.join(run, "animation.pc2")
scene.frame_start, scene.frame_end = 0, frame
scene.frame_set(frame)

# Materials: the OBJ's `surface` and `crack`, given a look (pale grey-blue outside, orange inside).
for mat in obj.data.materials:
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes.get("Principled BSDF")
    if mat.name.startswith("crack"):
        bsdf.inputs["Base Color"].default_value = (0.85, 0.35, 0.08, 1.0)
        bsdf.inputs["Roughness"].default_value = 0.7
    else:
        bsdf.inputs["Base Color"].default_value = (0.62, 0.68, 0.75, 1.0)
        bsdf.inputs["Roughness"].default_value = 0.35
for poly in obj.data.polygons:
    poly.use_smooth = False

# Frame the evaluated mesh.
ev = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
pts = [obj.matrix_world @ v.co for v in ev.data.vertices]
def span(axis, q):  # the q-quantile of the vertices' coordinate (far-flung dust does not widen the shot)
    c = sorted(p[axis] for p in pts)
    return c[min(len(c) - 1, int(q * len(c)))]
lo = Vector([span(a, 0.02) for a in range(3)])
hi = Vector([span(a, 0.98) for a in range(3)])
center, diag = (lo + hi) / 2, (hi - lo).length
lo.z = min(p.z for p in pts)

# Ground plane just below, a sun and a sky.
bpy.ops.mesh.primitive_plane_add(size=diag * 20, location=(center.x, center.y, lo.z - 1e-3 * diag))
ground = bpy.context.active_object
gm = bpy.data.materials.new("ground")
gm.use_nodes = True
gm.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (0.25, 0.25, 0.27, 1.0)
ground.data.materials.append(gm)
sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
sun.data.energy = 4.0
sun.rotation_euler = (math.radians(50), math.radians(10), math.radians(-30))
scene.collection.objects.link(sun)
world = bpy.data.worlds.new("sky")
world.use_nodes = True
world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.55, 0.6, 0.7, 1.0)
world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.6
scene.world = world

cam = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
cam.data.lens = 40
direction = Vector((math.sin(azimuth) * math.cos(elevation), -math.cos(azimuth) * math.cos(elevation), math.sin(elevation)))
cam.location = center + direction * diag * 1.35
cam.rotation_euler = (-direction).to_track_quat("-Z", "Y").to_euler()
scene.collection.objects.link(cam)
scene.camera = cam

scene.render.engine = "CYCLES"
scene.cycles.device = "CPU"
scene.cycles.samples = 24
scene.cycles.use_denoising = False
scene.render.resolution_x, scene.render.resolution_y = 960, 540
scene.render.film_transparent = False
scene.render.filepath = out
bpy.ops.render.render(write_still=True)
print(f"rendered frame {frame} of {run} to {out}")
