"""Ground truth for tests/data/mitsuba/fog-spot.json: a spot light in a box of homogeneous fog
over a diffuse floor, rendered by Mitsuba 3's volumetric path tracer (`volpath`).

Set-up (once):  python3 -m venv venv && venv/bin/pip install mitsuba numpy
                (llvm_ad_rgb also needs libllvm, e.g. apt-get install -y libllvm19)
Run from the repository root:
    venv/bin/python tests/data/mitsuba/fog_spot.py --variant llvm_ad_rgb --spp 131072 --seed 1 \
        --out tests/data/mitsuba/fog-spot-volpath-131072spp.exr   (Mitsuba 3.9.1, 459 s)

The scene is read from our JSON so that both renderers see the same numbers:
  camera  perspective, eye/target/up and vertical field of view of the scene, box filter
  floor   Mitsuba's rectangle turned to face +y, the plane's size, diffuse albedo
  fog     a `cube` of the medium's box (null BSDF) whose interior is a `homogeneous` medium,
          sigma_t = sigma_s + sigma_a and albedo = sigma_s / sigma_t per channel, `hg` phase
          with the scene's g (0.6 here, forward; Mitsuba's sign convention is ours); the camera
          is outside it, the floor and the light inside
  light   `spot` at the position, aimed at the target, with the intensity, cutoff_angle and
          beam_width of the scene (our spot light is Mitsuba's)
Output: linear radiance (W/(m2 sr)) per pixel, row 0 at the top; max_depth 16 as ours.
"""
import argparse, json, time
import mitsuba as mi

p = argparse.ArgumentParser()
p.add_argument('--scene', default='tests/data/mitsuba/fog-spot.json')
p.add_argument('--spp', type=int, default=1024)
p.add_argument('--variant', default='scalar_rgb')
p.add_argument('--seed', type=int, default=0)
p.add_argument('--out', default='fog-spot.exr')
a = p.parse_args()

mi.set_variant(a.variant)
T = mi.ScalarTransform4f
desc = json.load(open(a.scene))
cam = desc['camera']
light = desc['lights'][0]
floor = desc['objects'][0]
fx, fz = floor['shape']['size']
albedo = desc['materials'][floor['material']]['albedo']
med = desc['media'][0]
rgb = lambda v: [v] * 3 if isinstance(v, (int, float)) else v
ss, sa = rgb(med['sigma_s']), rgb(med.get('sigma_a', 0.0))
st = [s + b for s, b in zip(ss, sa)]
box = med['bounds']
bx, by, bz = box['size']
bt = box.get('transform', {}).get('translation', [0, 0, 0])
scene = mi.load_dict({
    'type': 'scene',
    'integrator': {'type': 'volpath', 'max_depth': 16},
    'sensor': {'type': 'perspective', 'fov': cam['fov_y'], 'fov_axis': 'y',
               'to_world': T().look_at(origin=cam['eye'], target=cam['target'], up=cam.get('up', [0, 1, 0])),
               'sampler': {'type': 'independent', 'sample_count': a.spp, 'seed': a.seed},
               'film': {'type': 'hdrfilm', 'width': cam['width'], 'height': cam['height'],
                        'rfilter': {'type': 'box'}}},
    'floor': {'type': 'rectangle',
              'to_world': T().rotate([1, 0, 0], -90).scale([fx / 2, fz / 2, 1]),
              'bsdf': {'type': 'diffuse', 'reflectance': {'type': 'rgb', 'value': rgb(albedo)}}},
    'fog': {'type': 'cube',
            'to_world': T().translate(bt).scale([bx / 2, by / 2, bz / 2]),
            'bsdf': {'type': 'null'},
            'interior': {'type': 'homogeneous',
                         'sigma_t': {'type': 'rgb', 'value': st},
                         'albedo': {'type': 'rgb', 'value': [s / t if t > 0 else 0 for s, t in zip(ss, st)]},
                         'phase': {'type': 'hg', 'g': med.get('g', 0.0)}}},
    'light': {'type': 'spot', 'to_world': T().look_at(origin=light['position'], target=light['target'], up=[0, 1, 0]),
              'cutoff_angle': light['cutoff_angle'], 'beam_width': light['beam_width'],
              'intensity': {'type': 'rgb', 'value': rgb(light['intensity'])}},
})
t0 = time.time()
img = mi.render(scene, spp=a.spp)
mi.Bitmap(img).write(a.out)
print(f'{a.variant} volpath {a.spp} spp {cam["width"]}x{cam["height"]}: {time.time() - t0:.1f} s -> {a.out}')
