#!/usr/bin/env python3
"""clpt and Mitsuba 3 side by side at equal time on scenes/ceiling_room.txt, for BENCHMARKS.md.

The room is written out for Mitsuba here (rectangles for the six walls, the ceiling an area
emitter with a black BSDF, three diffuse spheres, the same camera: the original's `angle` a
gives a vertical field of view of 2 atan(a / 2)). Each renderer renders the room for about
--seconds, and a reference of --reference-factor times its samples with another seed; the
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


def ceiling_room(mi, width, height, sampler="independent"):
    """scenes/ceiling_room.txt for Mitsuba."""
    grey, red, blue, green = [0.75] * 3, [0.75, 0.25, 0.25], [0.25, 0.25, 0.75], [0.25, 0.75, 0.25]
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
        "ball1": {"type": "sphere", "center": [-50, 25, -40], "radius": 25, "bsdf": diffuse(grey)},
        "ball2": {"type": "sphere", "center": [50, 25, 0], "radius": 25, "bsdf": diffuse(grey)},
        "ball3": {"type": "sphere", "center": [0, 40, -70], "radius": 40, "bsdf": diffuse(green)},
    }
    return mi.load_dict(scene)


def mitsuba_render(mi, dr, scene, spp, seed, path):
    start = time.perf_counter()
    image = mi.render(scene, spp=spp, seed=seed)
    dr.eval(image)
    dr.sync_thread()
    seconds = time.perf_counter() - start
    mi.util.write_bitmap(path, image, write_async=False)
    return seconds


def clpt_render(clpt, scene, args, path):
    out = subprocess.run(
        [clpt, "render", scene, "-q", "-o", path] + args,
        check=True, capture_output=True, text=True,
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
    p.add_argument("--scene", default="scenes/ceiling_room.txt")
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
    extra = args.clpt_args.split()
    k = args.reference_factor

    # Mitsuba, per sampler: its rate at a sample count that takes a quarter of the time or
    # more, then the timed render. Dr.Jit compiles a kernel for each sample count (and seed):
    # each count is rendered once to compile and once timed, so that no figure holds
    # compilation (clpt's figures hold no program build either).
    mitsuba_rows = []
    for sampler in args.mitsuba_samplers.split(","):
        scene = ceiling_room(mi, width, height, sampler)
        spp = 1
        while True:
            mitsuba_render(mi, dr, scene, spp, 1, out("warm.exr"))
            t = mitsuba_render(mi, dr, scene, spp, 1, out("warm.exr"))
            if t >= args.seconds / 4 or spp >= 1 << 16:
                break
            spp = min(spp * 16, max(spp * 2, int(spp * args.seconds / 4 / max(t, 1e-4))))
        m_spp = max(1, int(spp * args.seconds / t))
        mitsuba_render(mi, dr, scene, m_spp, 1, out("warm.exr"))
        image, ref = f"mitsuba-{sampler}.exr", f"mitsuba-{sampler}-ref.exr"
        m_seconds = mitsuba_render(mi, dr, scene, m_spp, 1, out(image))  # compiled above
        mitsuba_render(mi, dr, scene, m_spp * k, 1000, out(ref))
        name = f"Mitsuba 3 {mi.__version__} {mi.variant()}, sampler {sampler}"
        mitsuba_rows.append((name, image, ref, m_spp, m_seconds))

    # clpt: the same time, then the reference with another seed.
    size = ["--width", str(width), "--height", str(height)]
    c_spp, c_seconds, log = clpt_render(
        args.clpt, args.scene, ["--time", str(args.seconds), "--seed", "1", "-v"] + size + extra,
        out("clpt.pfm"),
    )
    estimator = re.search(r"estimator: (.*)", log).group(1)
    clpt_render(
        args.clpt, args.scene, ["--spp", str(c_spp * k), "--seed", "1000"] + size + extra,
        out("clpt-ref.pfm"),
    )

    rows = []
    for name, image, ref, spp, seconds in [
        ("clpt (" + estimator + ")", "clpt.pfm", "clpt-ref.pfm", c_spp, c_seconds),
    ] + mitsuba_rows:
        measured = relmse(args.clpt, out(image), out(ref))
        e = measured / (1.0 + 1.0 / k)  # less the reference's own error
        rows.append((name, spp, seconds, e, e * seconds))
    print(f"{args.scene}, {width}x{height}, about {args.seconds} s each; error against each "
          f"renderer's own {k}x reference")
    print("| renderer | spp | seconds | relMSE | relMSE x s |")
    print("|---|---|---|---|---|")
    for name, spp, seconds, e, es in rows:
        print(f"| {name} | {spp} | {seconds:.2f} | {e:.3e} | {es:.3e} |")
    for row in rows[1:]:
        print(f"{row[0]}: relMSE x s over clpt's: {row[4] / rows[0][4]:.2f}")


if __name__ == "__main__":
    main()
