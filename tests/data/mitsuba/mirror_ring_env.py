"""Ground truth for scenes/mirror-ring-env.json (and -sky): the mirror ring on its table under
the procedural sky, rendered by Mitsuba 3's particle tracer (`ptracer`).

Set-up (once):  python3 -m venv venv && venv/bin/pip install mitsuba numpy
                (llvm_ad_rgb also needs libllvm, e.g. apt-get install -y libllvm19)
Run from the repository root:
    venv/bin/python tests/data/mitsuba/mirror_ring_env.py --scene scenes/mirror-ring-env.json \
        --spp 4096 --size 128 --out tests/data/mitsuba/ring-env-ptracer-4096spp.exr

The scene is read from our JSON so that both renderers see the same numbers:
  camera  perspective, eye/target/up and vertical field of view of the scene, box filter
  floor   our `plane` (size w x d in the y = 0 plane, centred at the origin): Mitsuba's
          rectangle rotated into y = 0, diffuse albedo of the scene
  ring    our exact mesh, world space with smooth vertex normals, exported by our loader
          (`cargo run --example export_ply -- SCENE ring ring.ply`); our `mirror` (reflectance
          R, no Fresnel) is Mitsuba's `conductor` with `material: none` (a perfect conductor,
          Fresnel reflectance 1 at every angle) and `specular_reflectance` R
  light   `envmap` reading our HDR file, identity `to_world`, scale of the scene (our u, v
          conventions are Mitsuba's, design.md section 2)
Output: linear radiance (W/(m2 sr)) per pixel, row 0 at the top. The particle tracer renders the
mirror black: compare floor pixels only.
"""
import argparse, json, os, subprocess, tempfile, time
import mitsuba as mi

p = argparse.ArgumentParser()
p.add_argument('--scene', default='scenes/mirror-ring-env.json')
p.add_argument('--spp', type=int, default=1024)
p.add_argument('--size', type=int, default=128)
p.add_argument('--variant', default='scalar_rgb')
p.add_argument('--integrator', default='ptracer')
p.add_argument('--seed', type=int, default=0)
p.add_argument('--ply', default=None, help='the ring mesh; exported with cargo when omitted')
p.add_argument('--out', default='ring-env.exr')
a = p.parse_args()

mi.set_variant(a.variant)
T = mi.ScalarTransform4f
desc = json.load(open(a.scene))
scene_dir = os.path.dirname(os.path.abspath(a.scene))
cam = desc['camera']
mats = desc['materials']
objs = {o['name']: o for o in desc['objects']}
floor, ring = objs['floor'], objs['ring']
assert floor['shape']['type'] == 'plane' and 'transform' not in floor
fw, fd = floor['shape']['size']
albedo = mats[floor['material']]['albedo']
chrome = mats[ring['material']]
assert chrome['type'] == 'mirror'
(light,) = desc['lights']
assert light['type'] == 'environment' and 'radiance' not in light

ply = a.ply
if ply is None:
    ply = os.path.join(tempfile.mkdtemp(), 'ring.ply')
    subprocess.run(['cargo', 'run', '-q', '--example', 'export_ply', '--', a.scene, 'ring', ply], check=True)

def rgb(v):
    return {'type': 'rgb', 'value': v if isinstance(v, list) else [v] * 3}

scene = mi.load_dict({
    'type': 'scene',
    'integrator': {'type': a.integrator, 'max_depth': 16},
    'sensor': {'type': 'perspective', 'fov': cam['fov_y'], 'fov_axis': 'y',
               'to_world': T().look_at(origin=cam['eye'], target=cam['target'], up=cam.get('up', [0, 1, 0])),
               'sampler': {'type': 'independent', 'sample_count': a.spp, 'seed': a.seed},
               'film': {'type': 'hdrfilm', 'width': a.size, 'height': a.size, 'rfilter': {'type': 'box'}}},
    # The rectangle spans [-1,1]^2 in its local xy plane (normal +z): scale, then turn into y = 0.
    'floor': {'type': 'rectangle', 'to_world': T().rotate([1, 0, 0], -90).scale([fw / 2, fd / 2, 1]),
              'bsdf': {'type': 'diffuse', 'reflectance': rgb(albedo)}},
    'ring': {'type': 'ply', 'filename': ply, 'face_normals': False,
             'bsdf': {'type': 'conductor', 'material': 'none',
                      'specular_reflectance': rgb(chrome['reflectance'])}},
    'light': {'type': 'envmap', 'filename': os.path.join(scene_dir, light['path']),
              'scale': light.get('scale', 1.0)},
})
t0 = time.time()
img = mi.render(scene, spp=a.spp)
bmp = mi.Bitmap(img)
bmp.write(a.out)
print(f'{a.variant} {a.integrator} {a.scene} {a.spp} spp {a.size}px: {time.time() - t0:.1f} s -> {a.out}')
