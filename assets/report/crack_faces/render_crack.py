#!/usr/bin/env python3
"""Close-up of one piece's crack face from a perifx surface OBJ, rendered with Blender (Cycles, `blender -b`).

usage: render_crack.py SURFACE.obj OUT.png [--side above|below] [--axis y] [--title TEXT]

Takes the crack faces of one side (outward normal towards -axis for the side above) and the rest of the
surface on that side of the crack faces' mean, and
draws the crack faces alone (orange, flat shaded so every facet shows), seen from
the crack's side at a grazing light, so stair-steps show as stripes of light and shadow.
"""
import argparse
import subprocess
import sys
import tempfile
import os


def read_obj(path):
    verts, pieces, piece, mat = [], {}, None, None
    with open(path) as f:
        for line in f:
            t = line.split()
            if not t:
                continue
            if t[0] == 'v':
                verts.append(tuple(float(x) for x in t[1:4]))
            elif t[0] == 'o':
                piece = t[1]
            elif t[0] == 'usemtl':
                mat = t[1]
            elif t[0] == 'f':
                idx = [int(x.split('/')[0]) - 1 for x in t[1:4]]
                pieces.setdefault(piece, []).append((mat == 'crack', idx))
    return verts, pieces


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('obj')
    ap.add_argument('png')
    ap.add_argument('--side', default='above')
    ap.add_argument('--axis', default='y')
    ap.add_argument('--focus', default='', help='A,B: only faces whose centroid lies in [A, B] along the first other axis')
    ap.add_argument('--width', type=int, default=960)
    ap.add_argument('--height', type=int, default=540)
    a = ap.parse_args()
    ax = 'xyz'.index(a.axis)
    verts, pieces = read_obj(a.obj)

    def area_centroid(faces):
        A, C = 0.0, [0.0, 0.0, 0.0]
        for crack, (i, j, k) in faces:
            if not crack:
                continue
            p, q, r = verts[i], verts[j], verts[k]
            u = [q[d] - p[d] for d in range(3)]
            w = [r[d] - p[d] for d in range(3)]
            n = [u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]]
            s = 0.5 * sum(x * x for x in n) ** 0.5
            A += s
            for d in range(3):
                C[d] += s * (p[d] + q[d] + r[d]) / 3
        return A, [c / A for c in C] if A > 0 else C

    # The crack side: crack triangles whose outward normal points across the crack (towards -axis for
    # the side above), and the non-crack triangles on that side of the crack faces' mean.
    allf = [(name, cr, idx) for name, fs in pieces.items() for cr, idx in fs]

    def normal(idx):
        p, q, r = (verts[i] for i in idx)
        u = [q[d] - p[d] for d in range(3)]
        w = [r[d] - p[d] for d in range(3)]
        return [u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]]

    def centroid(idx):
        return [sum(verts[i][d] for i in idx) / 3 for d in range(3)]

    crack_c = [centroid(idx)[ax] for _, cr, idx in allf if cr]
    if not crack_c:
        sys.exit('no crack faces')
    mean = sum(crack_c) / len(crack_c)
    above = a.side == 'above'
    faces = []
    for name, cr, idx in allf:
        if cr:
            if (normal(idx)[ax] < 0) == above:
                faces.append((True, idx))
        elif (centroid(idx)[ax] > mean) == above:
            faces.append((False, idx))
    name = 'side ' + a.side
    other = [d for d in range(3) if d != ax]
    if a.focus:
        f0, f1 = (float(x) for x in a.focus.split(','))
        faces = [(cr, idx) for cr, idx in faces if f0 <= centroid(idx)[other[0]] <= f1]
    used = sorted({v for cr, idx in faces if cr for v in idx})
    lo = [min(verts[v][d] for v in used) for d in range(3)]
    hi = [max(verts[v][d] for v in used) for d in range(3)]
    c = [(lo[d] + hi[d]) / 2 for d in range(3)]
    ext = hi[other[0]] - lo[other[0]]
    # Camera on the crack side looking at the crack face, tilted a little; light grazing along it.
    sgn = -1.0 if a.side == 'above' else 1.0
    cam = list(c)
    cam[ax] += sgn * 1.05 * ext
    cam[other[1]] += 0.45 * ext
    light = list(c)
    light[other[0]] -= 1.0 * ext
    light[ax] += sgn * 0.35 * ext
    light[other[1]] += 0.25 * ext
    crack_tris = [idx for cr, idx in faces if cr]
    rest_tris = []  # the crack faces alone: the rest of the piece hides them at this angle
    script = """
import bpy, math
from mathutils import Vector
bpy.ops.wm.read_factory_settings(use_empty=True)
sc = bpy.context.scene
verts = %r
def add(name, tris, color):
    used = sorted({v for t in tris for v in t})
    remap = {v: i for i, v in enumerate(used)}
    me = bpy.data.meshes.new(name)
    me.from_pydata([verts[v] for v in used], [], [[remap[v] for v in t] for t in tris])
    me.update()
    ob = bpy.data.objects.new(name, me)
    sc.collection.objects.link(ob)
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes['Principled BSDF']
    bsdf.inputs['Base Color'].default_value = color
    bsdf.inputs['Roughness'].default_value = 0.45
    me.materials.append(mat)
add('crack', %r, (1.0, 0.45, 0.1, 1))
if %r: add('rest', %r, (0.6, 0.6, 0.62, 1))
cam = bpy.data.objects.new('cam', bpy.data.cameras.new('cam'))
sc.collection.objects.link(cam)
cam.location = Vector(%r)
d = Vector(%r) - cam.location
cam.rotation_euler = d.to_track_quat('-Z', 'Y').to_euler()
cam.data.angle = math.radians(40); cam.data.clip_start = 1e-5; cam.data.clip_end = 100
sc.camera = cam
sun = bpy.data.objects.new('sun', bpy.data.lights.new('sun', 'SUN'))
sc.collection.objects.link(sun)
sun.data.energy = 4.0
sun.rotation_euler = (Vector(%r) - Vector(%r)).to_track_quat('-Z', 'Y').to_euler()
world = bpy.data.worlds.new('w'); sc.world = world; world.use_nodes = True
world.node_tree.nodes['Background'].inputs['Color'].default_value = (0.9, 0.9, 0.92, 1)
world.node_tree.nodes['Background'].inputs['Strength'].default_value = 0.4
sc.render.engine = 'CYCLES'; sc.cycles.samples = 48; sc.cycles.device = 'CPU'; sc.cycles.use_denoising = False
sc.render.resolution_x = %d; sc.render.resolution_y = %d
sc.render.filepath = %r
bpy.ops.render.render(write_still=True)
""" % ([tuple(v) for v in verts], crack_tris, rest_tris, rest_tris, tuple(cam), tuple(c), tuple(c), tuple(light),
       a.width, a.height, os.path.abspath(a.png))
    with tempfile.TemporaryDirectory() as d:
        py = os.path.join(d, 'scene.py')
        open(py, 'w').write(script)
        r = subprocess.run(['blender', '-b', '--factory-startup', '-P', py], capture_output=True, text=True)
        if r.returncode != 0 or not os.path.exists(a.png):
            sys.exit(r.stdout[-3000:] + r.stderr[-3000:])
    print('%s: %s, %d crack triangles' % (a.png, name, len(crack_tris)))


if __name__ == '__main__':
    main()
