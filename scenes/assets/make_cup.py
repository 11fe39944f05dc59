"""Writes cup.glb: a cup whose inner wall is a mirror and whose bottom and outside are white
ceramic, for the self-caustics scene (scenes/reflecting-cup.json). Run: python3 make_cup.py

Units: metres, +Y up, the cup standing on y = 0. Inner radius 0.4, outer 0.43, height 0.36,
the inner bottom at y = 0.03. Two materials: "chrome" (metallic 1, roughness 0: a mirror for
Caustica) on the inner wall, "ceramic" (metallic 0, roughness 1: diffuse) elsewhere. The inner
wall's normals point towards the axis (the reflecting side)."""
import math

from glb import Glb

SEG = 192
R_IN, R_OUT, H, FLOOR = 0.4, 0.43, 0.36, 0.03


def ring(r, y, inward):
    pos, nrm = [], []
    for i in range(SEG + 1):
        a = 2 * math.pi * i / SEG
        c, s = math.cos(a), -math.sin(a)
        pos.append((r * c, y, r * s))
        nrm.append((-c, 0.0, -s) if inward else (c, 0.0, s))
    return pos, nrm


def wall(r, y0, y1, inward):
    p0, n0 = ring(r, y0, inward)
    p1, n1 = ring(r, y1, inward)
    pos, nrm, idx = p0 + p1, n0 + n1, []
    row = SEG + 1
    for i in range(SEG):
        a, b = i, i + 1
        c, d = a + row, b + row
        # Counter-clockwise seen from the side the normals point to.
        idx += [a, c, b, b, c, d] if inward else [a, b, c, b, d, c]
    return pos, nrm, idx


def annulus(r0, r1, y, up):
    p0, _ = ring(r0, y, False)
    p1, _ = ring(r1, y, False)
    n = (0.0, 1.0 if up else -1.0, 0.0)
    pos, nrm, idx = p0 + p1, [n] * (2 * (SEG + 1)), []
    row = SEG + 1
    for i in range(SEG):
        a, b = i, i + 1
        c, d = a + row, b + row
        idx += [a, c, b, b, c, d] if up else [a, b, c, b, d, c]
    return pos, nrm, idx


def disc(r, y, up):
    pos = [(0.0, y, 0.0)] + ring(r, y, False)[0]
    n = (0.0, 1.0 if up else -1.0, 0.0)
    nrm = [n] * len(pos)
    idx = []
    for i in range(SEG):
        a, b = 1 + i, 2 + i
        idx += [0, a, b] if up else [0, b, a]
    return pos, nrm, idx


def merge(*parts):
    pos, nrm, idx = [], [], []
    for p, n, i in parts:
        base = len(pos)
        pos += p
        nrm += n
        idx += [base + k for k in i]
    return pos, nrm, idx


chrome = wall(R_IN, FLOOR, H, inward=True)
ceramic = merge(
    wall(R_OUT, 0.0, H, inward=False),
    annulus(R_IN, R_OUT, H, up=True),
    disc(R_IN, FLOOR, up=True),
    disc(R_OUT, 0.0, up=False),
)

glb, prims = Glb(), []
for mat, (pos, nrm, idx) in enumerate([chrome, ceramic]):
    flat = [c for p in pos for c in p]
    mm = ([min(p[k] for p in pos) for k in range(3)], [max(p[k] for p in pos) for k in range(3)])
    pa = glb.add(flat, 'f', 34962, 5126, 'VEC3', len(pos), mm)
    na = glb.add([c for n in nrm for c in n], 'f', 34962, 5126, 'VEC3', len(nrm))
    ia = glb.add(idx, 'I', 34963, 5125, 'SCALAR', len(idx))
    prims.append({'attributes': {'POSITION': pa, 'NORMAL': na}, 'indices': ia, 'material': mat})

doc = {
    'asset': {'version': '2.0', 'generator': 'make_cup.py (Caustica)'},
    'scene': 0,
    'scenes': [{'nodes': [0]}],
    'nodes': [{'mesh': 0, 'name': 'cup'}],
    'meshes': [{'name': 'cup', 'primitives': prims}],
    'materials': [
        {'name': 'chrome', 'pbrMetallicRoughness': {'baseColorFactor': [0.95, 0.95, 0.95, 1],
                                                    'metallicFactor': 1.0, 'roughnessFactor': 0.0}},
        {'name': 'ceramic', 'pbrMetallicRoughness': {'baseColorFactor': [0.8, 0.8, 0.8, 1],
                                                     'metallicFactor': 0.0, 'roughnessFactor': 1.0}},
    ],
}
size = glb.write(doc, 'cup.glb')
print(f'cup.glb: {size} bytes')
