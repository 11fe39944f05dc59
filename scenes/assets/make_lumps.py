"""Writes the two glass test objects of the glass-accuracy issue, for scenes/glass-dense.json
and scenes/glass-spiky.json. Run: python3 make_lumps.py (no dependencies)

dense.glb: a dense smooth mesh in the manner of a scanned object. An icosphere subdivided 6
times (40,962 vertices, 81,920 triangles) shaped as make_blob.py's blob (radius 0.45 m, the
same six sinusoids), each vertex then moved along its direction by a fixed pseudo-random grain
of up to ±0.1 % of the radius (a scanner's noise: the smooth normals averaged from the faces
wobble by a few degrees from one vertex to the next).

spiky.glb: a strongly non-convex glass lump. An icosphere subdivided 4 times (2562 vertices,
5120 triangles) of radius 0.28 m, pushed out into nine rounded spikes (a star, each spike up
to 0.75 of the radius long) with concave valleys between them, and smooth normals.

Both rest their lowest point on y = 0 and have one material: KHR_materials_transmission 1 with
KHR_materials_ior 1.5 (clear glass for Caustica)."""
import math

from glb import icosphere, write_glass
from make_blob import radius as blob_radius


def rest_on_floor(pos):
    lift = -min(p[1] for p in pos)
    return [(p[0], p[1] + lift, p[2]) for p in pos]


def grain(i):
    """A fixed pseudo-random number in [-1, 1] for vertex i (an LCG step of its index)."""
    x = (i * 2654435761 + 12345) % 4294967296
    x = (x * 1103515245 + 12345) % 4294967296
    return x / 2147483648.0 - 1.0


verts, faces = icosphere(6)
pos = [tuple(c * blob_radius(v) * (1 + 0.001 * grain(i)) for c in v) for i, v in enumerate(verts)]
size = write_glass(rest_on_floor(pos), faces, 'dense.glb', 'make_lumps.py (Caustica)')
print(f'dense.glb: {size} bytes, {len(pos)} vertices, {len(faces)} triangles')

SPIKES = [(0.0, 1.0, 0.0), (0.9, 0.3, 0.2), (-0.5, 0.4, 0.8), (-0.6, 0.2, -0.7), (0.3, -0.2, -0.9),
          (0.4, -0.4, 0.8), (-0.9, -0.3, 0.0), (0.7, -0.6, -0.3), (0.0, -1.0, 0.1)]
SPIKES = [tuple(c / math.sqrt(sum(x * x for x in s)) for c in s) for s in SPIKES]


def spiky_radius(d):
    return 0.28 * (1 + 0.75 * sum(max(0.0, sum(d[i] * s[i] for i in range(3))) ** 12
                                  for s in SPIKES))


verts, faces = icosphere(4)
pos = [tuple(c * spiky_radius(v) for c in v) for v in verts]
size = write_glass(rest_on_floor(pos), faces, 'spiky.glb', 'make_lumps.py (Caustica)')
print(f'spiky.glb: {size} bytes, {len(pos)} vertices, {len(faces)} triangles')
