"""spheremap's MatCaps against Blender's Cycles: a reference nobody here wrote.

Cycles renders a lone sphere (radius 1, smooth-shaded, 512 x 256 segments) through an
orthographic camera that frames it exactly, lit only by the world: the lat-long map as its
Environment Texture (linear interpolation), with a Glossy BSDF set to GGX (not Blender's default
Multiscatter GGX, which adds energy compensation) of the same perceptual roughness and white
colour, or a Diffuse BSDF of roughness 0 and colour 0.8 for Lambert. The camera looks along
Blender's +Y with +Z up, which is spheremap's default view (−Z, +Y up; Blender's world is Z-up:
(x, y, z)_blender = (x, −z, y)_spheremap), and the map's default lat-long preset is Cycles'
equirectangular convention. Each pixel is one ray through its centre (pixel filter 0.01 px), so
it holds the MatCap's value at that texel's normal; texels within 0.95 of the rim are compared
(the polygonal silhouette), after x/(1+x) and sRGB.

    python scripts/verify_cycles.py [--map testdata/hdri/park.exr] [--size 32] [--spp 1024]

Needs Blender's Python module: `pip install bpy` in a Python 3.11 environment, named by
$SPHEREMAP_BPY_PYTHON (default: this interpreter); the comparison runs here, with spheremap.
"""

import argparse
import math
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
MATERIALS = [("lambert", 0.0), ("ggx", 1.0), ("ggx", 0.5), ("ggx", 0.25), ("ggx", 0.15)]


def render(env_path, out_dir, size, spp):
    """Runs inside Blender's Python: one EXR per material."""
    import warnings

    import bpy

    # `use_nodes` is announced for removal in Blender 6; it is still what turns nodes on in 5.
    warnings.filterwarnings("ignore", category=DeprecationWarning)

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = spp
    scene.cycles.use_adaptive_sampling = False
    scene.cycles.use_denoising = False
    scene.cycles.filter_width = 0.01
    scene.cycles.seed = 1
    scene.cycles.max_bounces = 4
    scene.render.resolution_x = size
    scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    scene.view_settings.view_transform = "Standard"

    world = bpy.data.worlds.new("env")
    world.use_nodes = True
    nodes = world.node_tree.nodes
    tex = nodes.new("ShaderNodeTexEnvironment")
    tex.image = bpy.data.images.load(env_path)
    tex.interpolation = "Linear"
    tex.projection = "EQUIRECTANGULAR"
    bg = nodes["Background"]
    bg.inputs["Strength"].default_value = 1.0
    world.node_tree.links.new(tex.outputs["Color"], bg.inputs["Color"])
    scene.world = world

    cam_data = bpy.data.cameras.new("cam")
    cam_data.type = "ORTHO"
    cam_data.ortho_scale = 2.0
    cam = bpy.data.objects.new("cam", cam_data)
    cam.location = (0.0, -10.0, 0.0)
    cam.rotation_euler = (math.pi / 2, 0.0, 0.0)
    scene.collection.objects.link(cam)
    scene.camera = cam

    bpy.ops.mesh.primitive_uv_sphere_add(segments=512, ring_count=256, radius=1.0)
    sphere = bpy.context.active_object
    bpy.ops.object.shade_smooth()

    for name, roughness in MATERIALS:
        mat = bpy.data.materials.new(name)
        mat.use_nodes = True
        nt = mat.node_tree
        nt.nodes.clear()
        out = nt.nodes.new("ShaderNodeOutputMaterial")
        if name == "lambert":
            bsdf = nt.nodes.new("ShaderNodeBsdfDiffuse")
            bsdf.inputs["Color"].default_value = (0.8, 0.8, 0.8, 1.0)
            bsdf.inputs["Roughness"].default_value = 0.0
        else:
            bsdf = nt.nodes.new("ShaderNodeBsdfGlossy")
            bsdf.distribution = "GGX"
            bsdf.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
            bsdf.inputs["Roughness"].default_value = roughness
        nt.links.new(bsdf.outputs["BSDF"], out.inputs["Surface"])
        sphere.data.materials.clear()
        sphere.data.materials.append(mat)
        scene.render.filepath = os.path.join(out_dir, f"{name}_{roughness}.exr")
        bpy.ops.render.render(write_still=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--map", default=os.path.join(ROOT, "testdata", "hdri", "park.exr"))
    ap.add_argument("--size", type=int, default=32)
    ap.add_argument("--spp", type=int, default=1024)
    ap.add_argument("--render", nargs=2, metavar=("ENV", "OUT_DIR"), help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.render:
        render(a.render[0], a.render[1], a.size, a.spp)
        return
    print(f"{os.path.basename(a.map)}, {a.size}^2, Cycles {a.spp} spp; PSNR over the disc (r < 0.95):")
    for name, roughness, db, ratio in compare(a.map, a.size, a.spp):
        print(f"  {name:8s} {roughness:4.2f}: {db:5.1f} dB, mean Cycles/ours {ratio:.4f}")


def compare(map_path, size, spp, env=None):
    """(material, roughness, PSNR in dB, mean of Cycles over mean of spheremap) per material;
    `env` (an array) replaces the map read from `map_path`."""
    import numpy as np

    import spheremap as sm

    def tonemapped(x):
        x = np.clip(x / (1 + x), 0, 1)
        return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)

    if env is None:
        env = sm.read_image(map_path)[..., :3]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        env_path = os.path.join(tmp, "env.exr")
        sm.write_image(env_path, env)
        bpy_python = os.environ.get("SPHEREMAP_BPY_PYTHON", sys.executable)
        cmd = [bpy_python, os.path.abspath(__file__), "--size", str(size), "--spp", str(spp)]
        subprocess.run([*cmd, "--render", env_path, tmp], check=True, stdout=subprocess.DEVNULL)
        s = (np.arange(size) + 0.5) / size
        x, y = np.meshgrid(2 * s - 1, 1 - 2 * s)
        inside = np.hypot(x, y) < 0.95
        for name, roughness in MATERIALS:
            cycles = sm.read_image(os.path.join(tmp, f"{name}_{roughness}.exr"))[..., :3]
            ours = sm.bake_matcap(env, material=name, roughness=roughness, size=size, samples=1)
            mse = float(np.mean((tonemapped(cycles[inside]) - tonemapped(ours[inside])) ** 2))
            ratio = float(np.mean(cycles[inside]) / np.mean(ours[inside]))
            rows.append((name, roughness, -10 * math.log10(mse), ratio))
    return rows


if __name__ == "__main__":
    main()
