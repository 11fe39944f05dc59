"""Writes blob.glb: a lumpy glass blob, a stand-in for a scanned organic object, for
scenes/glass-blob.json. Run: python3 make_blob.py (no dependencies)

An icosphere subdivided 4 times (2562 vertices, 5120 triangles) of radius 0.45 m, each vertex
pushed along its direction by a sum of six fixed sinusoids of position (bumps of 3-15 % of the
radius, some of them folds that make the surface concave in places), with smooth normals
averaged from the faces. The lowest point rests on y = 0 (a flat contact is not made: the blob
touches the floor at one point). One material: KHR_materials_transmission 1 with
KHR_materials_ior 1.5 (clear glass for Caustica)."""
import math

from glb import Glb

# Icosahedron.
t = (1 + 5 ** 0.5) / 2
verts = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t),
         (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
verts = [tuple(c / math.sqrt(sum(x * x for x in v)) for c in v) for v in verts]
faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
         (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
         (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
for _ in range(4):
    cache, nf = {}, []

    def mid(a, b):
        k = (min(a, b), max(a, b))
        if k not in cache:
            m = [(verts[a][i] + verts[b][i]) / 2 for i in range(3)]
            l = math.sqrt(sum(x * x for x in m))
            verts.append(tuple(x / l for x in m))
            cache[k] = len(verts) - 1
        return cache[k]

    for a, b, c in faces:
        ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
        nf += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
    faces = nf

WAVES = [((1.0, 2.0, 0.5), 3.1, 0.06), ((-1.5, 0.4, 2.2), 1.7, 0.05), ((0.3, -2.6, 1.1), 0.4, 0.04),
         ((2.8, 1.2, -0.7), 2.2, 0.03), ((-0.6, -0.9, -3.3), 5.0, 0.03), ((4.1, -3.0, 2.5), 0.9, 0.015)]


def radius(d):
    return 0.45 * (1 + sum(a * math.sin(sum(k[i] * d[i] for i in range(3)) * 1.6 + ph)
                           for k, ph, a in WAVES))


pos = [tuple(c * radius(v) for c in v) for v in verts]
lift = -min(p[1] for p in pos)
pos = [(p[0], p[1] + lift, p[2]) for p in pos]
nrm = [[0.0, 0.0, 0.0] for _ in pos]
for a, b, c in faces:
    e1 = [pos[b][i] - pos[a][i] for i in range(3)]
    e2 = [pos[c][i] - pos[a][i] for i in range(3)]
    n = (e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0])
    for v in (a, b, c):
        for i in range(3):
            nrm[v][i] += n[i]
nrm = [tuple(x / math.sqrt(sum(y * y for y in n)) for x in n) for n in nrm]

glb = Glb()
mm = ([min(p[k] for p in pos) for k in range(3)], [max(p[k] for p in pos) for k in range(3)])
pa = glb.add([c for p in pos for c in p], 'f', 34962, 5126, 'VEC3', len(pos), mm)
na = glb.add([c for n in nrm for c in n], 'f', 34962, 5126, 'VEC3', len(nrm))
ia = glb.add([i for f in faces for i in f], 'I', 34963, 5125, 'SCALAR', 3 * len(faces))
doc = {
    'asset': {'version': '2.0', 'generator': 'make_blob.py (Caustica)'},
    'extensionsUsed': ['KHR_materials_transmission', 'KHR_materials_ior'],
    'scene': 0,
    'scenes': [{'nodes': [0]}],
    'nodes': [{'mesh': 0, 'name': 'blob'}],
    'meshes': [{'name': 'blob', 'primitives': [
        {'attributes': {'POSITION': pa, 'NORMAL': na}, 'indices': ia, 'material': 0}]}],
    'materials': [{'name': 'glass',
                   'pbrMetallicRoughness': {'baseColorFactor': [1, 1, 1, 1], 'metallicFactor': 0.0,
                                            'roughnessFactor': 0.0},
                   'extensions': {'KHR_materials_transmission': {'transmissionFactor': 1.0},
                                  'KHR_materials_ior': {'ior': 1.5}}}],
}
size = glb.write(doc, 'blob.glb')
print(f'blob.glb: {size} bytes, {len(pos)} vertices, {len(faces)} triangles')
