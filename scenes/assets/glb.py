"""The binary glTF (GLB) writing that make_cup.py and make_blob.py share: accessors packed
into one buffer (each view 4-byte aligned), and the container with its JSON and BIN chunks."""
import json, os, struct


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
