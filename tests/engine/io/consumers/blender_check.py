# The real consumer of perifx's exports: Blender, headless. Run as
#   blender -b --factory-startup --python blender_check.py -- RUN_DIR
# on a run written with output.formats including surface_ply, cache and gltf. Checks:
#  1. animation.obj + animation.pc2: imported the way the README tells an artist (legacy OBJ importer,
#     one object, vertex order kept, groups as vertex groups) with a Mesh Cache modifier; at several
#     frames every evaluated vertex whose embedded-mesh vertex is on that frame's surface.NNNN.ply
#     sits where perifx put it, within 1e-5 of the body size (bounding-box diagonal at frame 0).
#  2. animation.glb: one mesh object per final piece (pieces.csv), each animated over frames
#     0..last at the run's frame rate, and at the last frame placed where pieces.csv says.
# Prints a summary (worst deviation) and exits 1 on failure.
import bpy
import csv
import math
import os
import struct
import sys

TOLERANCE = 1e-5
run = sys.argv[sys.argv.index("--") + 1]
failures = []


def fail(msg):
    failures.append(msg)
    print("FAIL:", msg)


def read_surface_ply(path):
    """Positions (float32 tuples) and `source` per vertex of a perifx surface PLY (binary)."""
    with open(path, "rb") as f:
        data = f.read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode().splitlines()
    sizes = {"float": "f", "uint": "I", "int": "i", "uchar": "B", "double": "d"}
    props, count, element = [], 0, None
    for line in header:
        tok = line.split()
        if tok[:1] == ["element"]:
            element = tok[1]
            if element == "vertex":
                count = int(tok[2])
        elif tok[:1] == ["property"] and element == "vertex":
            props.append((tok[2], sizes[tok[1]]))
    fmt = "<" + "".join(p[1] for p in props)
    record = struct.calcsize(fmt)
    names = [p[0] for p in props]
    ix, iy, iz, isrc = (names.index(n) for n in ("x", "y", "z", "source"))
    pos, src = [], []
    for k in range(count):
        r = struct.unpack_from(fmt, data, end + k * record)
        pos.append((r[ix], r[iy], r[iz]))
        src.append(r[isrc])
    return pos, src


rows = list(csv.DictReader(open(os.path.join(run, "pieces.csv"))))
last = max(int(r["frame"]) for r in rows)
with open(os.path.join(run, "animation.pc2"), "rb") as f:
    _, _, cache_vertices, _, _, cache_frames = struct.unpack("<12siiffi", f.read(32))
if cache_frames != last + 1:
    fail(f"animation.pc2 has {cache_frames} frames, pieces.csv {last + 1}")

# ---- 1. OBJ + point cache through the Mesh Cache modifier ----
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
bpy.ops.import_scene.obj(filepath=os.path.join(run, "animation.obj"), split_mode="OFF", use_groups_as_vgroups=True)
meshes = [o for o in scene.objects if o.type == "MESH"]
if len(meshes) != 1:
    fail(f"the OBJ imported as {len(meshes)} objects, expected 1")
obj = meshes[0]
if len(obj.data.vertices) != cache_vertices:
    fail(f"the OBJ has {len(obj.data.vertices)} vertices, the cache {cache_vertices}")
mod = obj.modifiers.new("perifx", "MESH_CACHE")
mod.cache_format = "PC2"
mod.filepath = os.path.join(run, "animation.pc2")
scene.frame_start, scene.frame_end = 0, last


def evaluated(frame):
    scene.frame_set(frame)
    ev = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    return [tuple(v.co) for v in ev.data.vertices]


# Which embedded-mesh vertex each cache vertex is: at the last frame every cache vertex is on the
# surface, at exactly the float position surface.<last>.ply holds.
final_pos, final_src = read_surface_ply(os.path.join(run, f"surface.{last:04d}.ply"))
by_position = {}
for p, s in zip(final_pos, final_src):
    by_position.setdefault(p, set()).add(s)
# Two embedded-mesh vertices can sit at the same float position (copies on either side of a crack
# of zero width, e.g. a face torn to repair a pinched edge, while both sides still move alike): such
# a cache vertex is at a surface vertex, but which one is ambiguous, so it is not compared later.
source, unmatched, ambiguous = [], 0, 0
for p in evaluated(last):
    key = tuple(float(struct.unpack("<f", struct.pack("<f", c))[0]) for c in p)
    s = by_position.get(key)
    unmatched += not s
    ambiguous += bool(s) and len(s) > 1
    source.append(next(iter(s)) if s and len(s) == 1 else None)
if unmatched:
    fail(f"{unmatched} cache vertices are not at a vertex of surface.{last:04d}.ply at the last frame")
if ambiguous:
    print(f"{ambiguous} cache vertices sit where two surface vertices coincide (not compared)")

first_pos, _ = read_surface_ply(os.path.join(run, "surface.0000.ply"))
lo = [min(p[d] for p in first_pos) for d in range(3)]
hi = [max(p[d] for p in first_pos) for d in range(3)]
size = math.dist(lo, hi)
worst, worst_frame, compared_total, sitting = 0.0, 0, 0, 0
check_frames = sorted({0, 1, last // 3, (2 * last) // 3, last - 1, last} - {-1})
for k in check_frames:
    pos, src = read_surface_ply(os.path.join(run, f"surface.{k:04d}.ply"))
    at = {}
    for p, s in zip(pos, src):
        at[s] = p
    co = evaluated(k)
    compared = 0
    for i, s in enumerate(source):
        if s is None:
            continue
        if s in at:
            d = math.dist(co[i], at[s]) / size
            compared += 1
            if d > worst:
                worst, worst_frame = d, k
        else:
            sitting += 1  # not on this frame's surface (an inside copy before its split)
    compared_total += compared
    print(f"frame {k}: {compared} of {len(co)} cache vertices compared with surface.{k:04d}.ply")
    if compared == 0:
        fail(f"frame {k}: no cache vertex to compare")
print(f"cache: {len(source)} vertices, {cache_frames} frames, body size {size:.6g} m; worst deviation "
      f"{worst:.3e} of the body size (frame {worst_frame}) over {compared_total} vertex-frames; "
      f"{sitting} vertex-frames not on that frame's surface (inside copies) not compared")
if worst > TOLERANCE:
    fail(f"worst deviation {worst:.3e} of the body size exceeds {TOLERANCE}")

# ---- 2. glTF: one object per piece, frame range, last pose ----
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
times = sorted({(int(r["frame"]), float(r["time"])) for r in rows})
# The frame rate: frame k is at k / frame_rate in the glb.
fps = round(last / max(t for _, t in times)) if last else 24
scene.render.fps, scene.render.fps_base = int(fps), 1.0
# Debian's Blender 3.4 glTF importer uses numpy.bool, which Debian 12's numpy 1.24 no longer has (the
# import fails for any file); the README gives artists the same one-line fix.
import numpy
if not hasattr(numpy, "bool"):
    numpy.bool = bool
bpy.ops.import_scene.gltf(filepath=os.path.join(run, "animation.glb"))
pieces = {int(r["piece"]): r for r in rows if int(r["frame"]) == last}
objects = {o.name: o for o in scene.objects if o.type == "MESH"}
if sorted(objects) != sorted(f"piece_{p}" for p in pieces):
    fail(f"glb objects {sorted(objects)[:5]}... ({len(objects)}) are not the {len(pieces)} pieces of the last frame")
ranges = set()
for o in objects.values():
    ad = o.animation_data
    if not ad or not ad.action:
        fail(f"{o.name} has no animation")
        continue
    ranges.add(tuple(round(x, 3) for x in ad.action.frame_range))
if last > 0 and ranges != {(0.0, float(last))}:
    fail(f"glb animation frame ranges {ranges}, expected {{(0.0, {float(last)})}}")
scene.frame_set(last)
pose_worst = 0.0
for pid, r in pieces.items():
    o = objects.get(f"piece_{pid}")
    if o is None:
        continue
    t = (float(r["tx"]), float(r["ty"]), float(r["tz"]))
    expected = (t[0], -t[2], t[1])  # glTF Y up -> Blender Z up
    pose_worst = max(pose_worst, math.dist(tuple(o.matrix_world.translation), expected) / size)
print(f"glb: {len(objects)} objects for {len(pieces)} pieces, frame ranges {sorted(ranges)}, "
      f"worst translation at frame {last} {pose_worst:.3e} of the body size")
if pose_worst > TOLERANCE:
    fail(f"glb translation at the last frame off by {pose_worst:.3e} of the body size")

print("blender check:", "FAILED" if failures else "passed")
sys.exit(1 if failures else 0)
