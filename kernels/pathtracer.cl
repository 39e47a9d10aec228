/* pathtracer.cl: the render kernel (port of pathtracer.cuh and main.cu's renderPixel).
 *
 * Reads: the whole scene (objects.h's Scene: parameters, materials, objects, textures,
 * meshes and the BVH). Writes: adds, for every pixel of rows [row_start, row_start + row_count),
 * the `sample_count` path samples of indices sample_start... to `sum` (compensated by
 * `sum_lo`), their squares to `sum_sq`, and those of odd-numbered groups of four to `sum_odd`
 * (compensated by `sum_odd_lo`) (float4 per pixel, .w unused; row 0 is the bottom of the
 * image). Samples are added one at a time onto the running sums, so the image is
 * bit for bit the same however the host splits the work into launches. error_rows reduces the
 * film to the error figures of the per-pass report.
 *
 * Why this shape: one work-item per pixel and a loop over samples, so the host can size each
 * launch (rows x samples) to a target (render/mod.rs, default_launch_target) and never trip a
 * display watchdog. Paths are iterative (the original unrolled recursion with templates and
 * stopped at depth 8): Russian roulette ends them without bias; `max_depth` is only a safety
 * cap, far past where roulette has ended every path that matters. No sample is clamped. A vertex scatters through its material's
 * trio (material.h: bsdf_sample here, bsdf_eval and bsdf_pdf in light sampling) and samples a
 * light through the emitter's (nee.h), so neither assumes what the other is.
 */
#include "types.h"
#include "vecmath.h"
#include "rng.h"
#include "ray.h"
#include "camera.h"
#include "objects.h"
#if CLPT_TEXTURES
#include "texture.h"
#endif
#include "material.h"
#if CLPT_NEE
#include "nee.h"
#endif

#define RR_MAX_SURVIVAL 0.95f

/* What a material is at one surface point: its plain values, or its maps' values there. */
typedef struct SurfaceMaterial {
    float3 emission;
    float3 color;
    float3 shading_normal;
    uint type;
} SurfaceMaterial;

inline SurfaceMaterial material_at(const Scene* sc, Hit hit, Surface s) {
    __global const Material* m = &sc->materials[s.material];
    SurfaceMaterial sm;
    sm.emission = vload3(0, m->emission);
    sm.color = vload3(0, m->color);
    sm.shading_normal = s.ns;
    sm.type = m->type;
#if CLPT_TEXTURES
    if ((m->color_map & m->emission_map & m->type_map & m->bump_map) == MAP_NONE) {
        return sm; /* no maps */
    }
    float3 dpdu, dpdv;
    const float2 uv = scene_mapping(sc, hit, s, &dpdu, &dpdv);
    const uint filter = sc->params->texture_filter;
    if (m->color_map != MAP_NONE) {
        sm.color = texture_lookup(sc->maps, sc->texels, m->color_map, uv, filter).xyz;
    }
    if (m->emission_map != MAP_NONE) {
        sm.emission = texture_lookup(sc->maps, sc->texels, m->emission_map, uv, filter).xyz;
    }
    if (m->type_map != MAP_NONE) {
        sm.type = (uint)texture_lookup(sc->maps, sc->texels, m->type_map, uv, filter).x;
    }
    if (m->bump_map != MAP_NONE) {
        const float2 g = texture_lookup(sc->maps, sc->texels, m->bump_map, uv, filter).xy;
        sm.shading_normal = bump_normal(s.ns, dpdu, dpdv, g);
    }
#endif
    return sm;
}

/* One path in flight: what the next bounce needs. A path is started by path_start and advanced
 * one vertex at a time by path_bounce, so render_pass can start a lane's next sample the moment
 * its path ends (see there for why). */
typedef struct Path {
    Rng rng;
    float3 o, d, radiance, throughput; /* the ray to trace next; the sums so far */
    uint depth;
#if CLPT_NEE
    bool sampled_light; /* the previous vertex sampled a light too (nee.h) */
    float3 prev_p;
    float prev_pdf;
    uint prev_light;      /* the entry it picked, and its density there if the same at every */
    float prev_light_pdf; /* direction, else 0 (nee.h emission_weight) */
#endif
} Path;

/* The path of sample index `sample` through pixel (px, py): its random numbers and camera ray. */
inline Path path_start(const Scene* sc, uint px, uint py, uint sample) {
    __global const RenderParams* params = sc->params;
    Path p;
    p.rng = rng_for_path(params->seed_lo, params->seed_hi, py * params->camera.width + px, sample);
    camera_ray(&params->camera, px, py, rng_next4(&p.rng), &p.o, &p.d);
    p.radiance = (float3)(0.0f);
    p.throughput = (float3)(1.0f);
    p.depth = 0u;
#if CLPT_NEE
    p.sampled_light = false;
    p.prev_p = (float3)(0.0f);
    p.prev_pdf = 0.0f;
    p.prev_light = 0u;
    p.prev_light_pdf = 0.0f;
#endif
    return p;
}

/* One vertex of path p: traces its ray, adds the emission found there (and, with light
 * sampling, a light sample), scatters, and plays roulette. Returns whether the path goes on;
 * when it does not, p->radiance is the sample's value. */
inline bool path_bounce(const Scene* sc, Path* p) {
    __global const RenderParams* params = sc->params;
    if (p->depth >= params->max_depth) {
        return false;
    }
    const float3 d = p->d; /* the ray's direction; p->d becomes the next one */
    const Hit hit = scene_intersect(sc, p->o, d);
    if (hit.kind == HIT_NONE) {
        return false; /* the background is black */
    }
    const Surface s = scene_surface(sc, hit, p->o, d);
    const SurfaceMaterial sm = material_at(sc, hit, s);
#if CLPT_NEE
    if (any(sm.emission != (float3)(0.0f))) {
        const float w_emission =
            p->sampled_light ? emission_weight(sc, hit, s, p->prev_p, p->prev_pdf, d,
                                               p->prev_light, p->prev_light_pdf)
                             : 1.0f;
        p->radiance += p->throughput * sm.emission * w_emission;
    }
#else
    p->radiance += p->throughput * sm.emission;
#endif

    const float4 u = rng_next4(&p->rng);
#if CLPT_NEE
    /* Light sampling at every vertex but a delta lobe's, bent shading normals (bump maps,
     * smooth meshes) included: nee.h joins the light's trio to material.h's. */
    p->sampled_light = !bsdf_is_delta(sm.type) && params->num_lights > 0u;
    if (p->sampled_light) {
        p->radiance += p->throughput * sample_light(sc, s, sm.type, sm.color, -d, sm.shading_normal,
                                                    rng_light4(&p->rng, p->depth),
                                                    &p->prev_light, &p->prev_light_pdf);
    }
#endif
    float3 wi;
    float pdf;
    lmask is_delta;
    p->throughput *= bsdf_sample(sm.type, sm.color, -d, s.n, sm.shading_normal, u, &wi, &pdf,
                                 &is_delta);
#if CLPT_NEE
    if (p->sampled_light) {
        /* The density with which this vertex found wi: the next hit's MIS weight. */
        p->prev_p = s.p;
        p->prev_pdf = pdf;
    }
#endif

    /* Russian roulette as the lower edge of a weight window (Vorba and Krivanek 2016,
     * "Adjoint-driven Russian roulette and splitting", without the splitting): from bounce
     * rr_depth on, a path whose largest throughput component m is below rr_threshold
     * survives with probability m / rr_threshold and then carries rr_threshold, so no
     * survivor's weight grows past the window. rr_threshold 1 is pbrt-v4's throughput
     * roulette (section 14.1.5); lower thresholds let bright paths run on (the host picks
     * it by measured efficiency, render/strategy.rs). Survival is capped at 0.95, as
     * Mitsuba 3 does, so every path past rr_depth ends with probability >= 0.05 a bounce:
     * even a closed room of albedo 1 (the original's untextured defaults) has paths of at
     * most rr_depth + 20 bounces on average. A zero (or non-finite) throughput ends the
     * path at once. The 1/survive weight keeps the estimate unbiased. */
    const float m = max_component(p->throughput);
    if (!(m > 0.0f)) {
        return false;
    }
    p->depth += 1u;
    if (p->depth >= params->rr_depth) {
        const float survive = fmin(RR_MAX_SURVIVAL, m / params->rr_threshold);
        if (!(u.w < survive)) {
            return false;
        }
        p->throughput /= survive;
    }
    p->o = offset_ray_origin(s.p, s.p_error, s.n, wi);
    p->d = wi;
    return true;
}

/* Adds x to the double-float hi + lo (|lo| at most half an ulp of hi): Knuth's TwoSum gives
 * the rounding error of hi + x exactly, lo joins it, and Dekker's FastTwoSum renormalizes, so
 * lo never grows into a sum of its own (Joldes, Muller and Popescu, "Tight and rigorous error
 * bounds for basic building blocks of double-word arithmetic", 2017). Plain f32 sums drift
 * once a pixel holds millions of samples (0.8% low at 2^22 samples of 0.3; an unrenormalized
 * lo still 0.06% high); hi + lo stays within about 1e-7 relative up to 2^32 samples, for nine
 * adds a sample. Needs IEEE adds in program order: no build option here allows reassociation. */
inline void add_compensated(float4* hi, float4* lo, float4 x) {
    const float4 s = *hi + x;
    const float4 x_part = s - *hi;
    const float4 e = ((*hi - (s - x_part)) + (x - x_part)) + *lo;
    const float4 t = s + e;
    *lo = e - (t - s);
    *hi = t;
}

/* Adds sample `sample` of value l to a pixel's running sums (render_pass): its value
 * (compensated), its square, and, for odd-numbered groups of four, the odd half. A value that
 * is not finite is not added: it is counted, and the first such sample index kept. */
inline void film_add(float3 l, uint sample, float4* acc, float4* acc_lo, float4* acc_sq,
                     float4* acc_odd, float4* acc_odd_lo, uint* bad_count, uint* first) {
    if (!(isfinite(l.x) && isfinite(l.y) && isfinite(l.z))) {
        *first = *bad_count == 0u ? sample : *first;
        *bad_count += 1u;
        return;
    }
    add_compensated(acc, acc_lo, (float4)(l, 0.0f));
    *acc_sq += (float4)(l * l, 0.0f);
    if ((sample >> 2) & 1u) {
        add_compensated(acc_odd, acc_odd_lo, (float4)(l, 0.0f));
    }
}

#if CLPT_REGENERATE
/* Whether at least half of the warp's lanes that are running now say `p` (PTX activemask and
 * vote.sync.ballot: NVIDIA only, hence the switch). Lanes that have left the loop are not
 * counted, so the last lanes of a launch still restart. */
inline bool warp_vote_half(bool p) {
    uint active, votes;
    asm volatile("activemask.b32 %0;" : "=r"(active));
    asm volatile("{\n\t.reg .pred q;\n\tsetp.ne.u32 q, %1, 0;\n\t"
                 "vote.sync.ballot.b32 %0, q, %2;\n\t}"
                 : "=r"(votes)
                 : "r"((uint)p), "r"(active));
    return 2u * popcount(votes) >= popcount(active);
}
#endif

/* Accumulates sample_count samples from sample_start into every col_step-th pixel from
 * col_start (render/mod.rs, `Rows`) of rows row_start, row_start + row_step, ... (row_count of them; steps
 * above 1 only for the strategy trial of render/strategy.rs): the sums of radiance (compensated: sum + sum_lo) and of its squares,
 * and apart the (compensated) sum of the samples of odd-numbered groups of four, so that the even and odd halves give two independent
 * estimates of each pixel whose difference measures the error (error_rows). The halves are two
 * independent quasi-random sequences (rng.h), so the difference measures the error of their
 * mean without bias. A sample that is not finite (an overflow, a NaN from a scene or a kernel fault) is
 * never added: it counts as 0, and the pixel's `bad` count and first bad sample index record it,
 * so the host can warn and name it. */
__kernel void render_pass(SCENE_KERNEL_ARGS, __global float4* sum, __global float4* sum_lo,
                          __global float4* sum_sq, __global float4* sum_odd,
                          __global float4* sum_odd_lo, __global uint* bad,
                          __global uint* bad_first, uint sample_start,
                          uint sample_count, uint row_start, uint row_count, uint row_step,
                          uint col_start, uint col_step) {
    const Scene scene = SCENE_FROM_KERNEL_ARGS;
    const uint px = col_start + get_global_id(0) * col_step;
    if (px >= params->camera.width || get_global_id(1) >= row_count) {
        return; /* padding of the global size to whole work-groups */
    }
    const uint py = row_start + get_global_id(1) * row_step;
    const uint pixel = py * params->camera.width + px;
    float4 acc = sum[pixel], acc_lo = sum_lo[pixel];
    float4 acc_sq = sum_sq[pixel];
    float4 acc_odd = sum_odd[pixel], acc_odd_lo = sum_odd_lo[pixel];
    uint bad_count = 0u, first = 0xffffffffu;
#if CLPT_REGENERATE
    /* Path regeneration (Novak, Havran and Dachsbacher, "Path regeneration for interactive path
     * tracing", Eurographics 2010): one loop over bounces, in which a lane whose path has ended
     * starts its next sample while the others trace on, instead of idling until the longest
     * path of its warp has ended. Roulette makes path lengths vary widely (a warp of 32 waits
     * for the longest of 32), so nested loops left most lanes idle. Starting a path costs
     * several bounces' worth of code (rng_for_path's Sobol blocks), and the warp runs it
     * whenever any lane starts, so a lane that has ended waits until half the warp's active
     * lanes have (warp_vote_half): measured on the H200 against nested loops, 1.03 to 1.68
     * times the speed on the showcases and the project's scenes, 0.94 on case1; restarting at
     * once lost up to 2x on the small rooms, waiting for 3/4 or 7/8 of the warp was slower
     * everywhere (BENCHMARKS.md, "Path regeneration"). Each pixel still adds its samples in
     * index order with the same code, so the image does not depend on the schedule. */
    uint i = 0u;
    bool ended = false;
    Path path;
    if (sample_count > 0u) {
        path = path_start(&scene, px, py, sample_start);
    }
    while (i < sample_count) {
        if (!ended && !path_bounce(&scene, &path)) {
            ended = true;
            film_add(path.radiance, sample_start + i, &acc, &acc_lo, &acc_sq, &acc_odd,
                     &acc_odd_lo, &bad_count, &first);
            if (++i == sample_count) {
                break;
            }
        }
        if (warp_vote_half(ended) && ended) {
            path = path_start(&scene, px, py, sample_start + i);
            ended = false;
        }
    }
#else
    /* A CPU runs each work-item's loop alone: nothing idles while another path runs on. */
    for (uint i = 0u; i < sample_count; ++i) {
        Path path = path_start(&scene, px, py, sample_start + i);
        while (path_bounce(&scene, &path)) {
        }
        film_add(path.radiance, sample_start + i, &acc, &acc_lo, &acc_sq, &acc_odd, &acc_odd_lo,
                 &bad_count, &first);
    }
#endif
    sum[pixel] = acc;
    sum_lo[pixel] = acc_lo;
    sum_sq[pixel] = acc_sq;
    sum_odd[pixel] = acc_odd;
    sum_odd_lo[pixel] = acc_odd_lo;
    if (bad_count > 0u) {
        bad_first[pixel] = bad[pixel] == 0u ? first : bad_first[pixel];
        bad[pixel] += bad_count;
    }
}

/* Error sums of one image row after `spp` samples, for the per-pass report (render/mod.rs).
 * Reads: the film sums, and with has_reference the reference image (linear rgb). Writes: five
 * sums over the row's pixels and channels: the estimated squared error of the mean (the
 * difference of the even and odd halves squared, times n_even n_odd / n^2: its expectation is
 * the variance of the mean; spp >= 5, so that both halves have samples), the same over (mean^2 + eps), and with a reference the squared error, the squared
 * error over (ref^2 + eps), and the absolute error. */
__kernel void error_rows(__global const float4* sum, __global const float4* sum_lo,
                         __global const float4* sum_odd, __global const float4* sum_odd_lo,
                         __global const float4* reference, uint has_reference, uint width,
                         uint spp, float eps, __global float* out) {
    const uint row = get_global_id(0);
    const float n = (float)spp;
    const uint rest = spp % 8u;
    const float n_odd = (float)((spp / 8u) * 4u + (rest > 4u ? rest - 4u : 0u));
    const float n_even = n - n_odd;
    const float k = n_even * n_odd / (n * n);
    float est = 0.0f, est_rel = 0.0f, se = 0.0f, se_rel = 0.0f, ae = 0.0f;
    for (uint x = 0u; x < width; ++x) {
        const uint i = row * width + x;
        const float3 all = sum[i].xyz + sum_lo[i].xyz;
        const float3 odd = sum_odd[i].xyz + sum_odd_lo[i].xyz;
        const float3 mean = all / n;
        const float3 diff = (all - odd) / n_even - odd / n_odd;
        const float3 var = diff * diff * k;
        est += var.x + var.y + var.z;
        const float3 rel = var / (mean * mean + eps);
        est_rel += rel.x + rel.y + rel.z;
        if (has_reference) {
            const float3 r = reference[i].xyz;
            const float3 e = mean - r;
            const float3 e2 = e * e;
            se += e2.x + e2.y + e2.z;
            const float3 er = e2 / (r * r + eps);
            se_rel += er.x + er.y + er.z;
            const float3 a = fabs(e);
            ae += a.x + a.y + a.z;
        }
    }
    __global float* o = out + 5u * row;
    o[0] = est;
    o[1] = est_rel;
    o[2] = se;
    o[3] = se_rel;
    o[4] = ae;
}
