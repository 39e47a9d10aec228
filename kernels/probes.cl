/* probes.cl: small kernels that the tests call, one routine in, results out.
 *
 * Reads: the inputs each probe names. Writes: one output record per work-item. Why: every
 * device routine is checked against an f64 Rust reference (tests/), and these are the doors;
 * the sampling trios of materials and lights (probe_bsdf, probe_light_sample, probe_light_pdf)
 * are checked against their own densities by the chi-square harness of tests/common/chi2.rs.
 */
#include "types.h"
#include "vecmath.h"
#include "ray.h"
#include "camera.h"
#include "objects.h"
#include "material.h"
#include "nee.h"

/* The three floats at a + (first + lane) * stride + offset, in each lane. */
inline LFloat3 probe_load3(__global const float* a, uint first, uint stride, uint offset) {
#if CLPT_WIDE
    lfloat x, y, z;
    for (uint l = 0u; l < CLPT_LANES; ++l) {
        __global const float* v = a + (first + l) * stride + offset;
        ((float*)&x)[l] = v[0];
        ((float*)&y)[l] = v[1];
        ((float*)&z)[l] = v[2];
    }
    return make_lfloat3(x, y, z);
#else
    return vload3(0, a + first * stride + offset);
#endif
}

/* Lane `lane` of v (a scalar program's v itself). */
#if CLPT_WIDE
#define PROBE_LANE(T, v, lane) (((const T*)&(v))[lane])
#define PROBE_LANE_SET(T, v, lane, x) (((T*)&(v))[lane] = (x))
#else
#define PROBE_LANE(T, v, lane) (v)
#define PROBE_LANE_SET(T, v, lane, x) ((v) = (x))
#endif

/* Rays first .. first + CLPT_LANES - 1 of a probe's input, 9 floats each (o, d, w), and the
 * nearest hits of (o, d). */
inline Hit probe_first_hit(const Scene* sc, __global const float* rays, uint first, LFloat3* o,
                           LFloat3* d, LFloat3* w) {
    *o = probe_load3(rays, first, 9u, 0u);
    *d = probe_load3(rays, first, 9u, 3u);
    *w = probe_load3(rays, first, 9u, 6u);
    return scene_intersect(sc, *o, *d);
}

/* Nearest hit of ray (o, d) and the ray spawned from it towards w: input 9 floats per ray
 * (o, d, w); output 16 floats: t, kind, index, p[3], n[3], p_error[3], then for the spawned
 * ray t2, kind2, index2, and the spawn origin's distance from p along n (signed). A work-item
 * takes CLPT_LANES rays (lanes.h): the geometry tests run the wide programs too. */
__kernel void probe_hit(SCENE_KERNEL_ARGS __global const float* rays, __global float* out) {
    const Scene scene = SCENE_FROM_KERNEL_ARGS;
    const uint first = get_global_id(0) * CLPT_LANES;
    LFloat3 o, d, w;
    const Hit hit = probe_first_hit(&scene, rays, first, &o, &d, &w);
    const lmask none = hit.kind == OBJECT_NONE;
    if (lane_all(none)) {
        for (int k = 0; k < 16 * CLPT_LANES; ++k) {
            out[16 * first + k] = k % 16 == 0 ? PROBE_LANE(float, hit.t, k / 16) : 0.0f;
        }
        return;
    }
    const Surface s = scene_surface(&scene, hit, o, d);
    const LFloat3 o2 = offset_ray_origin(s.p, s.p_error, s.n, w);
    const Hit next = scene_intersect(&scene, o2, w);
    const lfloat along = v3_dot(v3_sub(o2, s.p), s.n);
    for (uint l = 0u; l < CLPT_LANES; ++l) {
        __global float* r = out + 16 * (first + l);
        const float values[16] = {
            PROBE_LANE(float, hit.t, l),          (float)PROBE_LANE(uint, hit.kind, l),
            (float)PROBE_LANE(uint, hit.index, l), PROBE_LANE(float, s.p.x, l),
            PROBE_LANE(float, s.p.y, l),          PROBE_LANE(float, s.p.z, l),
            PROBE_LANE(float, s.n.x, l),          PROBE_LANE(float, s.n.y, l),
            PROBE_LANE(float, s.n.z, l),          PROBE_LANE(float, s.p_error.x, l),
            PROBE_LANE(float, s.p_error.y, l),    PROBE_LANE(float, s.p_error.z, l),
            PROBE_LANE(float, next.t, l),         (float)PROBE_LANE(uint, next.kind, l),
            (float)PROBE_LANE(uint, next.index, l), PROBE_LANE(float, along, l)};
        const bool missed = PROBE_LANE(int, none, l) != 0;
        for (int k = 0; k < 16; ++k) {
            r[k] = missed && k >= 3 ? 0.0f : values[k];
        }
    }
}

/* The four floats at a + (first + lane) * 4, in each lane. */
inline LFloat4 probe_load4(__global const float4* a, uint first) {
#if CLPT_WIDE
    lfloat x, y, z, w;
    for (uint l = 0u; l < CLPT_LANES; ++l) {
        const float4 v = a[first + l];
        ((float*)&x)[l] = v.x;
        ((float*)&y)[l] = v.y;
        ((float*)&z)[l] = v.z;
        ((float*)&w)[l] = v.w;
    }
    return make_lfloat4(x, y, z, w);
#else
    return a[first];
#endif
}

/* Writes lane `lane` of v to r[0..2]. */
inline void probe_store3(LFloat3 v, uint lane, __global float* r) {
    r[0] = PROBE_LANE(float, v.x, lane);
    r[1] = PROBE_LANE(float, v.y, lane);
    r[2] = PROBE_LANE(float, v.z, lane);
}

/* A material's trio (material.h): input per sample its type, 15 floats wo, n, ns, colour and
 * a direction w, and four uniforms; output 16 floats: bsdf_sample's wi, weight, pdf and
 * is_delta (1 or 0), then bsdf_eval and bsdf_pdf at that wi, then at w. A work-item takes
 * CLPT_LANES samples. */
__kernel void probe_bsdf(__global const uint* type, __global const float* frames,
                         __global const float4* u, __global float* out) {
    const uint first = get_global_id(0) * CLPT_LANES;
    const LFloat3 wo = probe_load3(frames, first, 15u, 0u);
    const LFloat3 n = probe_load3(frames, first, 15u, 3u);
    const LFloat3 ns = probe_load3(frames, first, 15u, 6u);
    const LFloat3 color = probe_load3(frames, first, 15u, 9u);
    const LFloat3 w = probe_load3(frames, first, 15u, 12u);
    luint t;
    for (uint l = 0u; l < CLPT_LANES; ++l) {
        PROBE_LANE_SET(uint, t, l, type[first + l]);
    }
    LFloat3 wi;
    lfloat pdf;
    lmask is_delta;
    const LFloat3 weight = bsdf_sample(t, color, wo, n, ns, probe_load4(u, first), &wi, &pdf, &is_delta);
    const LFloat3 eval_wi = bsdf_eval(t, color, wo, wi, n, ns);
    const lfloat pdf_wi = bsdf_pdf(t, wo, wi, n, ns);
    const LFloat3 eval_w = bsdf_eval(t, color, wo, w, n, ns);
    const lfloat pdf_w = bsdf_pdf(t, wo, w, n, ns);
    for (uint l = 0u; l < CLPT_LANES; ++l) {
        __global float* r = out + 16 * (first + l);
        probe_store3(wi, l, r);
        probe_store3(weight, l, r + 3);
        r[6] = PROBE_LANE(float, pdf, l);
        r[7] = PROBE_LANE(int, is_delta, l) ? 1.0f : 0.0f;
        probe_store3(eval_wi, l, r + 8);
        r[11] = PROBE_LANE(float, pdf_wi, l);
        probe_store3(eval_w, l, r + 12);
        r[15] = PROBE_LANE(float, pdf_w, l);
    }
}

/* An emitter's trio (nee.h), for light 0 of `lights`: input per sample p and two uniforms
 * (5 floats); output 12 floats: light_sample's wi, q, q_error, pdf and whether it sampled
 * (1 or 0), then light_pdf at that wi and the distance |q - p|. A work-item takes CLPT_LANES
 * samples. */
__kernel void probe_light_sample(__global const Light* lights, __global const float* p_u,
                                 __global float* out) {
    const uint first = get_global_id(0) * CLPT_LANES;
    const LFloat3 p = probe_load3(p_u, first, 5u, 0u);
    lfloat ux, uy;
    for (uint l = 0u; l < CLPT_LANES; ++l) {
        PROBE_LANE_SET(float, ux, l, p_u[5 * (first + l) + 3]);
        PROBE_LANE_SET(float, uy, l, p_u[5 * (first + l) + 4]);
    }
    const LFloat3 zero = v3_splat((float3)(0.0f));
    LFloat3 wi = zero, q = zero, q_error = zero, q_normal;
    lfloat pdf = 0.0f;
    lmask uniform;
    const lmask ok =
        light_sample(&lights[0], p, ux, uy, &wi, &q, &q_error, &q_normal, &pdf, &uniform);
    const lfloat pdf_again = light_pdf(&lights[0], p, wi, v3_length(v3_sub(q, p)));
    for (uint l = 0u; l < CLPT_LANES; ++l) {
        __global float* r = out + 12 * (first + l);
        const bool sampled = PROBE_LANE(int, ok, l) != 0;
        probe_store3(wi, l, r);
        probe_store3(q, l, r + 3);
        probe_store3(q_error, l, r + 6);
        r[9] = PROBE_LANE(float, pdf, l);
        r[10] = sampled ? 1.0f : 0.0f;
        r[11] = sampled ? PROBE_LANE(float, pdf_again, l) : 0.0f;
    }
}

/* light_pdf of light 0 of `lights`: input per sample p, a unit direction d that meets the
 * light and the distance t to where it does (7 floats); output the density. */
__kernel void probe_light_pdf(__global const Light* lights, __global const float* p_d_t,
                              __global float* out) {
    const uint first = get_global_id(0) * CLPT_LANES;
    lfloat t;
    for (uint l = 0u; l < CLPT_LANES; ++l) {
        PROBE_LANE_SET(float, t, l, p_d_t[7 * (first + l) + 6]);
    }
    const lfloat pdf = light_pdf(&lights[0], probe_load3(p_d_t, first, 7u, 0u),
                                 probe_load3(p_d_t, first, 7u, 3u), t);
    for (uint l = 0u; l < CLPT_LANES; ++l) {
        out[first + l] = PROBE_LANE(float, pdf, l);
    }
}

#if !CLPT_WIDE
#include "texture.h"

/* Primary rays: input (px, py, -, -) and four uniforms; output origin and direction. */
__kernel void probe_camera(__global const RenderParams* params, __global const uint4* pixel,
                           __global const float4* u, __global float* out) {
    const uint i = get_global_id(0);
    float3 o, d;
    camera_ray(&params->camera, pixel[i].x, pixel[i].y, u[i], &o, &d);
    vstore3(o, 2 * i, out);
    vstore3(d, 2 * i + 1, out);
}

/* A ray spawned off the first hit of (o, d), into the side the ray came from, towards w given
 * in the frame of that side's normal (z along it): input 9 floats (o, d, w); output 4 floats:
 * dot(d, n) at the first hit, the spawned ray's hit kind, dot(w, n2) at its hit (n, n2 the
 * geometric normals), and its t. A closed mesh seen from outside gives dot(w, n2) of the sign
 * of dot(d, n) always: the other sign is a ray that got inside. */
__kernel void probe_spawn(SCENE_KERNEL_ARGS __global const float* rays, __global float* out) {
    const Scene scene = SCENE_FROM_KERNEL_ARGS;
    const uint i = get_global_id(0);
    float3 o, d, wl;
    const Hit hit = probe_first_hit(&scene, rays, i, &o, &d, &wl);
    __global float* r = out + 4 * i;
    r[0] = 0.0f;
    r[1] = (float)OBJECT_NONE;
    r[2] = 0.0f;
    r[3] = 0.0f;
    if (hit.kind == OBJECT_NONE) {
        return;
    }
    const Surface s = scene_surface(&scene, hit, o, d);
    const float3 facing = dot(d, s.n) < 0.0f ? s.n : -s.n;
    float3 t, b;
    orthonormal_basis(facing, &t, &b);
    const float3 w = normalize(t * wl.x + b * wl.y + facing * wl.z);
    const float3 o2 = offset_ray_origin(s.p, s.p_error, s.n, w);
    const Hit next = scene_intersect(&scene, o2, w);
    r[0] = dot(d, s.n);
    r[1] = (float)next.kind;
    if (next.kind != OBJECT_NONE) {
        r[2] = dot(w, scene_surface(&scene, next, o2, w).n);
        r[3] = next.t;
    }
}

/* Texture coordinates and directions of a hit: input as probe_hit (9 floats, w unused); output
 * 8 floats: u, v, dpdu[3], dpdv[3] (zeros on a miss). */
__kernel void probe_mapping(SCENE_KERNEL_ARGS __global const float* rays,
                            __global float* out) {
    const Scene scene = SCENE_FROM_KERNEL_ARGS;
    const uint i = get_global_id(0);
    const float3 o = vload3(3 * i, rays);
    const float3 d = vload3(3 * i + 1, rays);
    __global float* r = out + 8 * i;
    for (int k = 0; k < 8; ++k) {
        r[k] = 0.0f;
    }
    const Hit hit = scene_intersect(&scene, o, d);
    if (hit.kind == OBJECT_NONE) {
        return;
    }
    const Surface s = scene_surface(&scene, hit, o, d);
    float3 dpdu, dpdv;
    const float2 uv = scene_mapping(&scene, hit, s, &dpdu, &dpdv);
    r[0] = uv.x;
    r[1] = uv.y;
    vstore3(dpdu, 0, r + 2);
    vstore3(dpdv, 1, r + 2);
}

/* Texture lookups: map index and filter per work-item, (u, v) in; the float4 value out. */
__kernel void probe_texture(__global const TextureMap* maps, __global const uchar* texels,
                            __global const uint2* index_filter, __global const float2* uv,
                            __global float4* out) {
    const uint i = get_global_id(0);
    out[i] = texture_lookup(maps, texels, index_filter[i].x, uv[i], index_filter[i].y);
}

/* Bump normals: n, dpdu, dpdv (9 floats) and gradients in; the bent normal out. */
__kernel void probe_bump(__global const float* frames, __global const float2* g,
                         __global float* out) {
    const uint i = get_global_id(0);
    const float3 n = bump_normal(vload3(3 * i, frames), vload3(3 * i + 1, frames),
                                 vload3(3 * i + 2, frames), g[i]);
    vstore3(n, i, out);
}

/* Surfaces of revolution alone, for benchmarks: rays (o, d; 6 floats) in device coordinates,
 * taken into the space revolved surface 0 is stored in by its transform (the host centres its
 * profile and moves it to the camera's origin, src/pack/mod.rs); output t in that space
 * (t_max = INFINITY when none), solver iterations and sub-segments visited. */
__kernel void probe_rev_work(__global const RevSurface* revsurfaces,
                             __global const Transform* transforms,
                             __global const float2* rev_points, __global const float* rays,
                             __global float* out) {
    const uint i = get_global_id(0);
    float3 o = vload3(2 * i, rays);
    float3 d = vload3(2 * i + 1, rays);
    const uint transform = revsurfaces[0].transform;
    if (transform != TRANSFORM_NONE) {
        o = xform_point(transforms[transform].inv, o);
        d = normalize(xform_vector(transforms[transform].inv, d));
    }
    uint seg = 0u;
    float u = 0.0f;
    RevWork work = {0u, 0u};
    const float t = revsurface_intersect(&revsurfaces[0], rev_points, o, d, INFINITY, &seg, &u,
                                         &work);
    vstore3((float3)(t, (float)work.iterations, (float)work.nodes), i, out);
}

/* Bezier evaluation: input (first point, degree, u) per query over the point array; output
 * the point and the derivative with respect to u (4 floats). */
__kernel void probe_bezier(__global const float2* points, __global const uint2* segment,
                           __global const float* u, __global float4* out) {
    const uint i = get_global_id(0);
    float2 s, ds;
    bezier_eval(points + segment[i].x, segment[i].y, u[i], &s, &ds);
    out[i] = (float4)(s, ds);
}
#endif
