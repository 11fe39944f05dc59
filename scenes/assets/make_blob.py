"""Writes blob.glb: a lumpy glass blob, a stand-in for a scanned organic object, for
scenes/glass-blob.json. Run: python3 make_blob.py (no dependencies)

An icosphere subdivided 4 times (2562 vertices, 5120 triangles) of radius 0.45 m, each vertex
pushed along its direction by a sum of six fixed sinusoids of position (bumps of 3-15 % of the
radius, some of them folds that make the surface concave in places), with smooth normals
averaged from the faces. The lowest point rests on y = 0 (a flat contact is not made: the blob
touches the floor at one point). One material: KHR_materials_transmission 1 with
KHR_materials_ior 1.5 (clear glass for Caustica)."""
import math

from glb import icosphere, write_glass

WAVES = [((1.0, 2.0, 0.5), 3.1, 0.06), ((-1.5, 0.4, 2.2), 1.7, 0.05), ((0.3, -2.6, 1.1), 0.4, 0.04),
         ((2.8, 1.2, -0.7), 2.2, 0.03), ((-0.6, -0.9, -3.3), 5.0, 0.03), ((4.1, -3.0, 2.5), 0.9, 0.015)]


def radius(d):
    return 0.45 * (1 + sum(a * math.sin(sum(k[i] * d[i] for i in range(3)) * 1.6 + ph)
                           for k, ph, a in WAVES))


if __name__ == '__main__':
    verts, faces = icosphere(4)
    pos = [tuple(c * radius(v) for c in v) for v in verts]
    lift = -min(p[1] for p in pos)
    pos = [(p[0], p[1] + lift, p[2]) for p in pos]
    size = write_glass(pos, faces, 'blob.glb', 'make_blob.py (Caustica)')
    print(f'blob.glb: {size} bytes, {len(pos)} vertices, {len(faces)} triangles')
