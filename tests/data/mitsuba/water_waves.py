"""Ground truth for tests/data/mitsuba/water-waves.json: the floor under one wavy frame of a
water surface, rendered by Mitsuba 3's particle tracer (`ptracer`).

Set-up (once):  python3 -m venv venv && venv/bin/pip install mitsuba numpy
                (llvm_ad_rgb also needs libllvm, e.g. apt-get install -y libllvm19)
Run from the repository root:
    venv/bin/python tests/data/mitsuba/water_waves.py --variant llvm_ad_rgb --spp 16384 \
        --out tests/data/mitsuba/water-waves-ptracer-16384spp.exr

The scene is read from our JSON so that both renderers see the same numbers:
  camera  perspective under the surface, eye/target/up and vertical field of view of the
          scene, box filter
  surface our exact tessellation of the wave height field at the scene's time (world space,
          vertex normals from the waves' analytic gradient), exported by our loader
          (`cargo run --example export_ply -- SCENE sea sea.ply`), as Mitsuba's `dielectric`
          with int_ior 1.33 (the water below the surface, air above) and ext_ior 1.0; an open
          sheet, so the side a ray hits tells in from out. No absorption (the scene's is 0):
          Mitsuba would need a medium for it
  floor   our water's floor: a rectangle of the water's size at y = -depth, diffuse albedo of
          the scene
  light   `directional` with the scene's direction and irradiance
Output: linear radiance (W/(m2 sr)) per pixel, row 0 at the top.
"""
import argparse, json, os, subprocess, tempfile, time
import mitsuba as mi

p = argparse.ArgumentParser()
p.add_argument('--scene', default='tests/data/mitsuba/water-waves.json')
p.add_argument('--spp', type=int, default=1024)
p.add_argument('--variant', default='scalar_rgb')
p.add_argument('--seed', type=int, default=0)
p.add_argument('--ply', default=None, help='the surface mesh; exported with cargo when omitted')
p.add_argument('--out', default='water-waves.exr')
a = p.parse_args()

mi.set_variant(a.variant)
T = mi.ScalarTransform4f
desc = json.load(open(a.scene))
cam = desc['camera']
light = desc['lights'][0]
sea = desc['objects'][0]
shape = sea['shape']
ply = a.ply
if ply is None:
    ply = os.path.join(tempfile.mkdtemp(), 'sea.ply')
    subprocess.run(['cargo', 'run', '--quiet', '--release', '--example', 'export_ply', '--',
                    a.scene, sea['name'], ply], check=True)
sx, sz = shape['size']
depth = shape['depth']
albedo = shape['floor']
scene = mi.load_dict({
    'type': 'scene',
    'integrator': {'type': 'ptracer', 'max_depth': 16},
    'sensor': {'type': 'perspective', 'fov': cam['fov_y'], 'fov_axis': 'y',
               'to_world': T().look_at(origin=cam['eye'], target=cam['target'], up=cam.get('up', [0, 1, 0])),
               'sampler': {'type': 'independent', 'sample_count': a.spp, 'seed': a.seed},
               'film': {'type': 'hdrfilm', 'width': cam['width'], 'height': cam['height'],
                        'rfilter': {'type': 'box'}}},
    # Mitsuba's rectangle spans [-1,1]^2 in its local xy plane, facing +z: turn it to face +y.
    'floor': {'type': 'rectangle',
              'to_world': T().translate([0, -depth, 0]).rotate([1, 0, 0], -90).scale([sx / 2, sz / 2, 1]),
              'bsdf': {'type': 'diffuse', 'reflectance': {'type': 'rgb', 'value': albedo}}},
    'surface': {'type': 'ply', 'filename': ply, 'face_normals': False,
                'bsdf': {'type': 'dielectric', 'int_ior': shape.get('ior', 1.33), 'ext_ior': 1.0}},
    'light': {'type': 'directional', 'direction': light['direction'],
              'irradiance': {'type': 'rgb', 'value': light['irradiance']}},
})
t0 = time.time()
img = mi.render(scene, spp=a.spp)
mi.Bitmap(img).write(a.out)
print(f'{a.variant} ptracer {a.spp} spp {cam["width"]}x{cam["height"]}: {time.time() - t0:.1f} s -> {a.out}')
