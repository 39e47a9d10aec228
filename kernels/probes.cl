/* probes.cl: small kernels that the tests call, one routine in, results out.
 *
 * Reads: the inputs each probe names. Writes: one output record per work-item. Why: every
 * device routine is checked against an f64 Rust reference (tests/), and these are the doors.
 */
#include "types.h"
#include "rng.h"
#include "ray.h"
#include "camera.h"
#include "objects.h"
#include "material.h"

/* Philox 4x32-10 on given counters and keys (known-answer tests). */
__kernel void probe_philox(__global const uint4* ctr, __global const uint2* key,
                           __global uint4* out) {
    const uint i = get_global_id(0);
    out[i] = philox4x32_10(ctr[i], key[i]);
}

/* `dims` blocks of the stream of (seed, pixel = work-item, sample). */
__kernel void probe_rng_stream(uint seed_lo, uint seed_hi, uint sample, uint dims,
                               __global float4* out) {
    const uint pixel = get_global_id(0);
    Rng rng = rng_for_path(seed_lo, seed_hi, pixel, sample);
    for (uint k = 0u; k < dims; ++k) {
        out[pixel * dims + k] = rng_next4(&rng);
    }
}

/* Primary rays: input (px, py, sub, -) and four uniforms; output origin and direction. */
__kernel void probe_camera(__global const RenderParams* params, __global const uint4* pixel,
                           __global const float4* u, __global float* out) {
    const uint i = get_global_id(0);
    float3 o, d;
    camera_ray(&params->camera, pixel[i].x, pixel[i].y, pixel[i].z, u[i], &o, &d);
    vstore3(o, 2 * i, out);
    vstore3(d, 2 * i + 1, out);
}

/* Nearest hit of ray (o, d) and the ray spawned from it towards w: input 9 floats per ray
 * (o, d, w); output 16 floats: t, kind, index, p[3], n[3], p_error[3], then for the spawned
 * ray t2, kind2, index2, and the spawn origin's distance from p along n (signed). */
__kernel void probe_hit(__global const RenderParams* params, __global const Sphere* spheres,
                        __global const Plane* planes, __global const float* rays,
                        __global float* out) {
    const uint i = get_global_id(0);
    const float3 o = vload3(3 * i, rays);
    const float3 d = vload3(3 * i + 1, rays);
    const float3 w = vload3(3 * i + 2, rays);
    __global float* r = out + 16 * i;
    const Hit hit = scene_intersect(params, spheres, planes, o, d);
    r[0] = hit.t;
    r[1] = (float)hit.kind;
    r[2] = (float)hit.index;
    if (hit.kind == HIT_NONE) {
        for (int k = 3; k < 16; ++k) {
            r[k] = 0.0f;
        }
        return;
    }
    const Surface s = scene_surface(spheres, planes, hit, o, d);
    vstore3(s.p, 1, r);
    vstore3(s.n, 2, r);
    vstore3(s.p_error, 3, r);
    const float3 o2 = offset_ray_origin(s.p, s.p_error, s.n, w);
    const Hit next = scene_intersect(params, spheres, planes, o2, w);
    r[12] = next.t;
    r[13] = (float)next.kind;
    r[14] = (float)next.index;
    r[15] = dot(o2 - s.p, s.n);
}

/* Material sampling: input wo, n (unit) and four uniforms, type per work-item; output wi and
 * the weight. */
__kernel void probe_material(__global const uint* type, __global const float* wo_n,
                             __global const float4* u, __global float* out) {
    const uint i = get_global_id(0);
    float3 wi;
    const float3 weight = material_sample(type[i], (float3)(1.0f), vload3(2 * i, wo_n),
                                          vload3(2 * i + 1, wo_n), u[i], &wi);
    vstore3(wi, 2 * i, out);
    vstore3(weight, 2 * i + 1, out);
}
