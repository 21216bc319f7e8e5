#!/usr/bin/env python3
"""Close-up of one piece's crack face from a perifx surface OBJ, rendered with POV-Ray.

usage: render_crack.py SURFACE.obj OUT.png [--side above|below] [--axis y] [--title TEXT]

Takes the piece (OBJ `o piece_<id>` group) with the largest crack area whose crack faces lie on the
given side of the crack (centroid coordinate along --axis above / below the crack faces' mean), and
draws its crack faces (orange, flat shaded so every facet shows) and the rest of it (grey), seen from
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
    ap.add_argument('--title', default='')
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

    stats = {name: area_centroid(f) for name, f in pieces.items()}
    mean = sum(s[0] * s[1][ax] for s in stats.values()) / max(1e-300, sum(s[0] for s in stats.values()))
    cands = [(s[0], name) for name, s in stats.items() if s[0] > 0 and ((s[1][ax] > mean) == (a.side == 'above'))]
    if not cands:
        sys.exit('no piece with crack faces on that side')
    name = max(cands)[1]
    faces = pieces[name]
    used = sorted({v for _, idx in faces for v in idx})
    lo = [min(verts[v][d] for v in used) for d in range(3)]
    hi = [max(verts[v][d] for v in used) for d in range(3)]
    c = [(lo[d] + hi[d]) / 2 for d in range(3)]
    ext = max(hi[d] - lo[d] for d in range(3))
    # Camera on the crack side, looking at the crack face obliquely.
    sgn = -1.0 if a.side == 'above' else 1.0
    cam = list(c)
    cam[ax] += sgn * 0.55 * ext
    other = [d for d in range(3) if d != ax]
    cam[other[1]] += 0.35 * ext
    cam[other[0]] += 0.15 * ext
    light = list(c)
    light[ax] += sgn * 0.25 * ext
    light[other[0]] -= 1.0 * ext
    light[other[1]] += 0.3 * ext

    def vec(p):
        return '<%.9g,%.9g,%.9g>' % (p[0], p[1], p[2])

    out = []
    out.append('#version 3.7;\nglobal_settings { assumed_gamma 1.0 }\nbackground { color rgb <1,1,1> }')
    out.append('camera { perspective location %s look_at %s angle 40 right x*%d/%d }' % (vec(cam), vec(c), a.width, a.height))
    out.append('light_source { %s color rgb 1.3 }' % vec(light))
    out.append('light_source { %s color rgb 0.35 shadowless }' % vec(cam))
    for crack in (True, False):
        tris = [idx for cr, idx in faces if cr == crack]
        if not tris:
            continue
        out.append('mesh {')
        for i, j, k in tris:
            out.append('triangle { %s, %s, %s }' % (vec(verts[i]), vec(verts[j]), vec(verts[k])))
        col = '<1.0,0.55,0.15>' if crack else '<0.7,0.7,0.72>'
        out.append('texture { pigment { color rgb %s } finish { ambient 0.08 diffuse 0.85 specular 0.15 } } }' % col)
    if a.title:
        pass
    with tempfile.TemporaryDirectory() as d:
        pov = os.path.join(d, 'scene.pov')
        open(pov, 'w').write('\n'.join(out) + '\n')
        subprocess.run(['povray', '-D', '+A0.2', '+W%d' % a.width, '+H%d' % a.height, '+I' + pov, '+O' + a.png],
                       check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    print('%s: piece %s, %d crack triangles' % (a.png, name, sum(1 for cr, _ in faces if cr)))


if __name__ == '__main__':
    main()
