"""Ground truth for scenes of meshes over a floor (tests/data/mitsuba/lowpoly-glass.json and
other glass or mirror objects), rendered by Mitsuba 3's particle tracer (`ptracer`).

Set-up (once):  python3 -m venv venv && venv/bin/pip install mitsuba numpy
                (llvm_ad_rgb also needs libllvm, e.g. apt-get install -y libllvm19)
Run from the repository root:
    venv/bin/python tests/data/mitsuba/mesh_ptracer.py --scene tests/data/mitsuba/lowpoly-glass.json \
        --variant llvm_ad_rgb --spp 65536 --out tests/data/mitsuba/lowpoly-glass-ptracer-65536spp.exr

The scene is read from our JSON so that both renderers see the same numbers:
  camera   perspective, eye/target/up, vertical field of view and size of the scene, box filter
  floor    an object whose shape is our `plane` without a transform (size w x d in y = 0,
           centred at the origin): Mitsuba's rectangle rotated into y = 0
  objects  every other object as our loader resolves it (world space, smooth vertex normals),
           exported with `cargo run --release --example export_ply -- SCENE NAME OUT.ply`
           and given to Mitsuba with `face_normals: false`, so that both shade with the same
           interpolated normals
  materials  `diffuse` -> diffuse; `dielectric` without absorption -> dielectric (int_ior the
           ior, ext_ior 1); `mirror` -> conductor with material none and the reflectance
  lights   directional, point and spot (Mitsuba's spot has the same smooth falloff between
           beam width and cutoff)
Output: linear radiance (W/(m2 sr)) per pixel, row 0 at the top. The particle tracer renders
smooth glass and mirrors black: compare receiver pixels only.
"""
import argparse, json, os, subprocess, tempfile, time
import mitsuba as mi

p = argparse.ArgumentParser()
p.add_argument('--scene', required=True)
p.add_argument('--spp', type=int, default=1024)
p.add_argument('--variant', default='scalar_rgb')
p.add_argument('--seed', type=int, default=0)
p.add_argument('--out', required=True)
p.add_argument('--exporter', default='cargo run --quiet --release --example export_ply --',
               help='the command that writes one object to a PLY (SCENE NAME OUT.ply follow)')
a = p.parse_args()

mi.set_variant(a.variant)
T = mi.ScalarTransform4f
desc = json.load(open(a.scene))
cam = desc['camera']
mats = desc['materials']


def rgb(v):
    return {'type': 'rgb', 'value': v if isinstance(v, list) else [v] * 3}


def bsdf(name):
    m = mats[name]
    if m['type'] == 'diffuse':
        return {'type': 'diffuse', 'reflectance': rgb(m['albedo'])}
    if m['type'] == 'dielectric':
        assert not any(m.get('absorption', [0]) if isinstance(m.get('absorption', 0), list)
                       else [m.get('absorption', 0)]), 'absorbing glass needs a Mitsuba medium'
        return {'type': 'dielectric', 'int_ior': m['ior'], 'ext_ior': 1.0}
    if m['type'] == 'mirror':
        return {'type': 'conductor', 'material': 'none',
                'specular_reflectance': rgb(m.get('reflectance', 1.0))}
    raise SystemExit(f'material type {m["type"]} is not exported')


def light(l):
    if l['type'] == 'directional':
        assert l.get('angular_radius', 0) == 0
        return {'type': 'directional', 'direction': l['direction'], 'irradiance': rgb(l['irradiance'])}
    if l['type'] == 'point':
        return {'type': 'point', 'position': l['position'], 'intensity': rgb(l['intensity'])}
    if l['type'] == 'spot':
        return {'type': 'spot', 'to_world': T().look_at(origin=l['position'], target=l['target'], up=[0, 1, 0]),
                'cutoff_angle': l['cutoff_angle'], 'beam_width': l['beam_width'], 'intensity': rgb(l['intensity'])}
    raise SystemExit(f'light type {l["type"]} is not exported')


scene = {
    'type': 'scene',
    'integrator': {'type': 'ptracer', 'max_depth': 16},
    'sensor': {'type': 'perspective', 'fov': cam['fov_y'], 'fov_axis': 'y',
               'to_world': T().look_at(origin=cam['eye'], target=cam['target'], up=cam.get('up', [0, 1, 0])),
               'sampler': {'type': 'independent', 'sample_count': a.spp, 'seed': a.seed},
               'film': {'type': 'hdrfilm', 'width': cam['width'], 'height': cam['height'],
                        'rfilter': {'type': 'box'}}},
}
tmp = tempfile.mkdtemp()
for o in desc['objects']:
    if o['shape']['type'] == 'plane' and 'transform' not in o:
        fw, fd = o['shape']['size']
        # The rectangle spans [-1,1]^2 in its local xy plane (normal +z): scale, then turn into y = 0.
        scene[o['name']] = {'type': 'rectangle', 'to_world': T().rotate([1, 0, 0], -90).scale([fw / 2, fd / 2, 1]),
                            'bsdf': bsdf(o['material'])}
        continue
    ply = os.path.join(tmp, o['name'] + '.ply')
    subprocess.run(a.exporter.split() + [a.scene, o['name'], ply], check=True)
    scene[o['name']] = {'type': 'ply', 'filename': ply, 'face_normals': False, 'bsdf': bsdf(o['material'])}
for i, l in enumerate(desc['lights']):
    scene[f'light{i}'] = light(l)

t0 = time.time()
img = mi.render(mi.load_dict(scene), spp=a.spp)
mi.Bitmap(img).write(a.out)
print(f'{a.variant} ptracer {a.scene} {a.spp} spp: {time.time() - t0:.1f} s -> {a.out}')
