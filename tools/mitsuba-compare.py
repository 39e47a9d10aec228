#!/usr/bin/env python3
"""clpt and Mitsuba 3 side by side at equal time on a room, for BENCHMARKS.md.

--scene room: scenes/ceiling_room.txt; --scene dragon_room: tools/dragon_room.txt, the same room
with the Stanford dragon (100k triangles, the original's data: --seed-dir, default
$CLPT_SEED_DIR or ../shared/seed) in place of its green ball. Each is written out for Mitsuba
here (rectangles for the six walls, the ceiling an area emitter with a black BSDF, diffuse
spheres, the dragon an `obj` shape with face normals as clpt shades a mesh without normals, the
same camera: the original's `angle` a gives a vertical field of view of 2 atan(a / 2)). Each
renderer renders the room for about --seconds, and a reference of --reference-factor times its samples with another seed; the
error of each render is measured against its own renderer's reference (`clpt compare`), so
small differences between the two renderers' pictures (pixel filters, the 2x2 sub-pixels) do
not count as error. A reference's own error adds to what is measured, by about 1/factor of it
for the same estimator: the table subtracts that. Mitsuba runs its `path` integrator with its
defaults (emitter sampling with MIS, Russian roulette from depth 5, no depth limit), the LLVM
variant on the CPU or the CUDA variant with --cuda, once per sampler of --mitsuba-samplers
(default: its default, `independent`; its quasi-random ones are `ldsampler`, `multijitter`,
`orthogonal`, clpt's is always quasi-random). With quasi-random samples a reference of k times
the samples has less than 1/k of the render's error, so the subtraction below is then a little
too generous to both renderers alike.

    pip install mitsuba   # the LLVM variant needs libLLVM >= 16 (Debian: libllvm19)
    python3 tools/mitsuba-compare.py --clpt target/release/clpt --seconds 10 --out /tmp/cmp
    python3 tools/mitsuba-compare.py --scene dragon_room --seconds 10 --out /tmp/cmp-dragon
"""
import argparse
import math
import os
import re
import subprocess
import time


def rectangle(mi, center, normal, up, half_x, half_y, bsdf, emitter=None):
    """A Mitsuba rectangle centred at `center`, facing `normal`, half_x along up x normal and
    half_y along `up`."""
    center, normal, up = ([float(c) for c in v] for v in (center, normal, up))
    target = [c + n for c, n in zip(center, normal)]
    to_world = mi.ScalarTransform4f().look_at(
        origin=center, target=target, up=up
    ) @ mi.ScalarTransform4f().scale([half_x, half_y, 1.0])
    shape = {"type": "rectangle", "to_world": to_world, "bsdf": bsdf}
    if emitter is not None:
        shape["emitter"] = emitter
    return shape


def diffuse(rgb):
    return {"type": "diffuse", "reflectance": {"type": "rgb", "value": rgb}}


def room(mi, width, height, sampler, contents):
    """The ceiling-lit room of scenes/ceiling_room.txt for Mitsuba, `contents` (a dict of named
    shapes) on its floor."""
    grey, red, blue = GREY, [0.75, 0.25, 0.25], [0.25, 0.25, 0.75]
    a = math.radians(30.0)  # the file's `angle`
    fov = math.degrees(2.0 * math.atan(a / 2.0))
    scene = {
        "type": "scene",
        "integrator": {"type": "path"},
        "sensor": {
            "type": "perspective",
            "fov_axis": "y",
            "fov": fov,
            "to_world": mi.ScalarTransform4f().look_at(
                origin=[0, 60, 250], target=[0, 60, 249], up=[0, 1, 0]
            ),
            "film": {
                "type": "hdrfilm",
                "width": width,
                "height": height,
                "rfilter": {"type": "box"},
                "pixel_format": "rgb",
            },
            "sampler": {"type": sampler},
        },
        # The room: x in [-100, 100], y in [0, 160], z in [-100, 300].
        "ceiling": rectangle(
            mi, [0, 160, 100], [0, -1, 0], [0, 0, 1], 100, 200, diffuse([0, 0, 0]),
            {"type": "area", "radiance": {"type": "rgb", "value": [0.42, 0.41, 0.4]}},
        ),
        "left": rectangle(mi, [-100, 80, 100], [1, 0, 0], [0, 1, 0], 200, 80, diffuse(red)),
        "right": rectangle(mi, [100, 80, 100], [-1, 0, 0], [0, 1, 0], 200, 80, diffuse(blue)),
        "floor": rectangle(mi, [0, 0, 100], [0, 1, 0], [0, 0, 1], 100, 200, diffuse(grey)),
        "back": rectangle(mi, [0, 80, -100], [0, 0, 1], [0, 1, 0], 100, 80, diffuse(grey)),
        "front": rectangle(mi, [0, 80, 300], [0, 0, -1], [0, 1, 0], 100, 80, diffuse(grey)),
    }
    scene.update(contents)
    return mi.load_dict(scene)


GREY, GREEN = [0.75] * 3, [0.25, 0.75, 0.25]


def ball(center, radius, rgb):
    return {"type": "sphere", "center": center, "radius": radius, "bsdf": diffuse(rgb)}


def ceiling_room(mi, width, height, sampler, seed_dir):
    """scenes/ceiling_room.txt: three balls."""
    return room(mi, width, height, sampler, {
        "ball1": ball([-50, 25, -40], 25, GREY),
        "ball2": ball([50, 25, 0], 25, GREY),
        "ball3": ball([0, 40, -70], 40, GREEN),
    })


def dragon_room(mi, width, height, sampler, seed_dir):
    """tools/dragon_room.txt: two balls and the dragon, `Translate 0 35.27 -55 UniformScale 50`.
    Two-sided as clpt's diffuse surfaces are (Mitsuba's `diffuse` is black from behind)."""
    to_world = mi.ScalarTransform4f().translate([0, 35.27, -55]) @ mi.ScalarTransform4f().scale(50)
    return room(mi, width, height, sampler, {
        "ball1": ball([-55, 20, 0], 20, GREY),
        "ball2": ball([55, 20, 20], 20, GREY),
        "dragon": {
            "type": "obj",
            "filename": os.path.join(seed_dir, "mesh", "dragon_100k.obj"),
            "face_normals": True,
            "to_world": to_world,
            "bsdf": {"type": "twosided", "bsdf": diffuse(GREEN)},
        },
    })


# --scene: (clpt's scene file, relative to the checkout; the same scene for Mitsuba).
SCENES = {
    "room": ("scenes/ceiling_room.txt", ceiling_room),
    "dragon_room": ("tools/dragon_room.txt", dragon_room),
}


def mitsuba_render(mi, dr, scene, spp, seed, path):
    """Seconds, and the samples a pixel rendered: the quasi-random samplers round the count asked
    for (`ldsampler` to a power of 4, `orthogonal` to a prime's square, `multijitter` up)."""
    start = time.perf_counter()
    image = mi.render(scene, spp=spp, seed=seed)
    dr.eval(image)
    dr.sync_thread()
    seconds = time.perf_counter() - start
    mi.util.write_bitmap(path, image, write_async=False)
    return seconds, scene.sensors()[0].sampler().sample_count()


def mitsuba_reference(mi, dr, scene, spp, k, path):
    """The mean of k renders of `spp` samples with seeds 1000, 1001, ...: one render of k times
    the samples fails on the GPU once it needs several wavefronts ("sample_count should be a
    multiple of samples_per_wavefront"). Returns the samples a pixel in all."""
    total = None
    for i in range(k):
        image = mi.render(scene, spp=spp, seed=1000 + i)
        total = image if total is None else total + image
    mean = total / k
    dr.eval(mean)
    mi.util.write_bitmap(path, mean, write_async=False)
    return scene.sensors()[0].sampler().sample_count() * k


def clpt_render(clpt, scene, args, path, cwd):
    """Renders in `cwd`, where seed/ names the original's data (the scenes' meshes)."""
    out = subprocess.run(
        [clpt, "render", scene, "-q", "-o", os.path.abspath(path)] + args,
        check=True, capture_output=True, text=True, cwd=cwd,
    ).stderr
    m = re.search(r"(\d+) spp in ([0-9.]+) s", out)
    return int(m.group(1)), float(m.group(2)), out


def relmse(clpt, image, reference):
    out = subprocess.run(
        [clpt, "compare", image, reference], check=True, capture_output=True, text=True
    ).stdout
    return float(re.search(r"relMSE ([0-9.eE+-]+)", out).group(1))


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--clpt", default="target/release/clpt")
    p.add_argument("--scene", choices=sorted(SCENES), default="room")
    p.add_argument("--seed-dir", default=os.environ.get("CLPT_SEED_DIR", "../shared/seed"),
                   help="the original's data (for the dragon)")
    p.add_argument("--seconds", type=float, default=10.0)
    p.add_argument("--width", type=int, default=320)
    p.add_argument("--height", type=int, default=240)
    p.add_argument("--reference-factor", type=int, default=16)
    p.add_argument("--cuda", action="store_true", help="Mitsuba's CUDA variant (a GPU)")
    p.add_argument("--mitsuba-samplers", default="independent",
                   help="comma-separated Mitsuba samplers, one row each")
    p.add_argument("--clpt-args", default="", help="more options for clpt render")
    p.add_argument("--out", default="mitsuba-compare")
    args = p.parse_args()
    os.makedirs(args.out, exist_ok=True)
    import drjit as dr
    import mitsuba as mi

    mi.set_variant("cuda_ad_rgb" if args.cuda else "llvm_ad_rgb")
    width, height = args.width, args.height
    out = lambda name: os.path.join(args.out, name)
    clpt = os.path.abspath(args.clpt)
    clpt_scene, mitsuba_scene = SCENES[args.scene]
    clpt_scene = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", clpt_scene)
    seed_dir = os.path.abspath(args.seed_dir)
    if args.scene == "dragon_room":  # the room needs none of the original's data
        if not os.path.isdir(os.path.join(seed_dir, "mesh")):
            p.error(f"no mesh/ in --seed-dir {seed_dir}")
        link = out("seed")
        if os.path.islink(link):
            os.remove(link)
        os.symlink(seed_dir, link)
    extra = args.clpt_args.split()
    k = args.reference_factor

    # Mitsuba, per sampler: its rate at a sample count that takes a quarter of the time or
    # more, then the timed render. Dr.Jit compiles a kernel for each sample count (and seed):
    # each count is rendered once to compile and once timed, so that no figure holds
    # compilation (clpt's figures hold no program build either).
    mitsuba_rows = []
    for sampler in args.mitsuba_samplers.split(","):
        scene = mitsuba_scene(mi, width, height, sampler, seed_dir)
        spp = 1
        while True:
            mitsuba_render(mi, dr, scene, spp, 1, out("warm.exr"))
            t, spp = mitsuba_render(mi, dr, scene, spp, 1, out("warm.exr"))
            if t >= args.seconds / 4 or spp >= 1 << 16:
                break
            spp = min(spp * 16, max(spp * 2, int(spp * args.seconds / 4 / max(t, 1e-4))))
        m_spp = max(1, int(spp * args.seconds / t))
        mitsuba_render(mi, dr, scene, m_spp, 1, out("warm.exr"))
        image, ref = f"mitsuba-{sampler}.exr", f"mitsuba-{sampler}-ref.exr"
        m_seconds, m_spp = mitsuba_render(mi, dr, scene, m_spp, 1, out(image))  # compiled above
        ref_spp = mitsuba_reference(mi, dr, scene, m_spp, k, out(ref))
        name = f"Mitsuba 3 {mi.__version__} {mi.variant()}, sampler {sampler}"
        mitsuba_rows.append((name, image, ref, m_spp, m_seconds, ref_spp))

    # clpt: the same time, then the reference with another seed.
    size = ["--width", str(width), "--height", str(height)]
    c_spp, c_seconds, log = clpt_render(
        clpt, clpt_scene, ["--time", str(args.seconds), "--seed", "1", "-v"] + size + extra,
        out("clpt.pfm"), args.out,
    )
    estimator = re.search(r"estimator: (.*)", log).group(1)
    clpt_render(
        clpt, clpt_scene, ["--spp", str(c_spp * k), "--seed", "1000"] + size + extra,
        out("clpt-ref.pfm"), args.out,
    )

    rows = []
    for name, image, ref, spp, seconds, ref_spp in [
        ("clpt (" + estimator + ")", "clpt.pfm", "clpt-ref.pfm", c_spp, c_seconds, c_spp * k),
    ] + mitsuba_rows:
        measured = relmse(clpt, out(image), out(ref))
        e = measured / (1.0 + spp / ref_spp)  # less the reference's own error
        rows.append((name, spp, seconds, e, e * seconds))
    print(f"{args.scene} ({SCENES[args.scene][0]}), {width}x{height}, about {args.seconds} s "
          f"each; error against each renderer's own reference of about {k}x the samples")
    print("| renderer | spp | seconds | relMSE | relMSE x s |")
    print("|---|---|---|---|---|")
    for name, spp, seconds, e, es in rows:
        print(f"| {name} | {spp} | {seconds:.2f} | {e:.3e} | {es:.3e} |")
    for row in rows[1:]:
        print(f"{row[0]}: relMSE x s over clpt's: {row[4] / rows[0][4]:.2f}")


if __name__ == "__main__":
    main()
