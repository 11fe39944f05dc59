"""The binary glTF (GLB) writing that make_cup.py, make_blob.py and make_lumps.py share:
accessors packed into one buffer (each view 4-byte aligned), and the container with its JSON and
BIN chunks; the icosphere, smooth normals and clear-glass GLB the glass lumps are made of."""
import json, math, os, struct


class Glb:
    def __init__(self):
        self.bin = bytearray()
        self.views, self.accessors = [], []

    def add(self, data, fmt, target, comp, typ, count, minmax=None):
        """Packs `data` (struct format `fmt` per element) as a new view and accessor; returns
        the accessor's index."""
        while len(self.bin) % 4:
            self.bin.append(0)
        off = len(self.bin)
        self.bin.extend(struct.pack('<' + fmt * len(data), *data))
        self.views.append({'buffer': 0, 'byteOffset': off, 'byteLength': len(self.bin) - off,
                           'target': target})
        acc = {'bufferView': len(self.views) - 1, 'componentType': comp, 'count': count,
               'type': typ}
        if minmax:
            acc['min'], acc['max'] = minmax
        self.accessors.append(acc)
        return len(self.accessors) - 1

    def write(self, doc, name):
        """Writes `doc` (the glTF JSON without buffers, bufferViews and accessors, which this
        adds) with the packed buffer as `name` beside this file; returns its size in bytes."""
        doc = dict(doc, buffers=[{'byteLength': len(self.bin)}], bufferViews=self.views,
                   accessors=self.accessors)
        js = json.dumps(doc, separators=(',', ':')).encode()
        js += b' ' * (-len(js) % 4)
        bin_ = bytearray(self.bin)
        while len(bin_) % 4:
            bin_.append(0)
        out = bytearray(b'glTF' + struct.pack('<II', 2, 12 + 8 + len(js) + 8 + len(bin_)))
        out += struct.pack('<I', len(js)) + b'JSON' + js
        out += struct.pack('<I', len(bin_)) + b'BIN\x00' + bin_
        open(os.path.join(os.path.dirname(os.path.abspath(__file__)), name), 'wb').write(out)
        return len(out)


def icosphere(subdivisions):
    """Unit icosphere: (vertices, faces), each subdivision splitting a face into four."""
    t = (1 + 5 ** 0.5) / 2
    verts = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t),
             (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    verts = [tuple(c / math.sqrt(sum(x * x for x in v)) for c in v) for v in verts]
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
             (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
             (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(subdivisions):
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
    return verts, faces


def smooth_normals(pos, faces):
    """Vertex normals: the area-weighted mean of the adjacent faces' normals."""
    nrm = [[0.0, 0.0, 0.0] for _ in pos]
    for a, b, c in faces:
        e1 = [pos[b][i] - pos[a][i] for i in range(3)]
        e2 = [pos[c][i] - pos[a][i] for i in range(3)]
        n = (e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
             e1[0] * e2[1] - e1[1] * e2[0])
        for v in (a, b, c):
            for i in range(3):
                nrm[v][i] += n[i]
    return [tuple(x / math.sqrt(sum(y * y for y in n)) for x in n) for n in nrm]


def write_glass(pos, faces, name, generator):
    """Writes the mesh (smooth normals) as one clear-glass primitive (KHR_materials_transmission
    1, KHR_materials_ior 1.5) to `name` beside this file; returns its size in bytes."""
    nrm = smooth_normals(pos, faces)
    glb = Glb()
    mm = ([min(p[k] for p in pos) for k in range(3)], [max(p[k] for p in pos) for k in range(3)])
    pa = glb.add([c for p in pos for c in p], 'f', 34962, 5126, 'VEC3', len(pos), mm)
    na = glb.add([c for n in nrm for c in n], 'f', 34962, 5126, 'VEC3', len(nrm))
    ia = glb.add([i for f in faces for i in f], 'I', 34963, 5125, 'SCALAR', 3 * len(faces))
    stem = name.rsplit('.', 1)[0]
    doc = {
        'asset': {'version': '2.0', 'generator': generator},
        'extensionsUsed': ['KHR_materials_transmission', 'KHR_materials_ior'],
        'scene': 0,
        'scenes': [{'nodes': [0]}],
        'nodes': [{'mesh': 0, 'name': stem}],
        'meshes': [{'name': stem, 'primitives': [
            {'attributes': {'POSITION': pa, 'NORMAL': na}, 'indices': ia, 'material': 0}]}],
        'materials': [{'name': 'glass',
                       'pbrMetallicRoughness': {'baseColorFactor': [1, 1, 1, 1],
                                                'metallicFactor': 0.0, 'roughnessFactor': 0.0},
                       'extensions': {'KHR_materials_transmission': {'transmissionFactor': 1.0},
                                      'KHR_materials_ior': {'ior': 1.5}}}],
    }
    return glb.write(doc, name)
