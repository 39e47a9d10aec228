/* pathtracer.cl: the render kernel (port of pathtracer.cuh and main.cu's renderPixel).
 *
 * Reads: the whole scene (scene.h's Scene: parameters, materials, objects, textures,
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
#if CLPT_WIDE && (CLPT_TEXTURES || CLPT_REGENERATE)
#error "a wide program (CLPT_WIDE) traces paths without textures or the warp vote"
#endif

#define RR_MAX_SURVIVAL 0.95f

/* What a material is at one surface point: its plain values, or its maps' values there. */
typedef struct SurfaceMaterial {
    LFloat3 emission;
    LFloat3 color;
    LFloat3 shading_normal;
    luint type;
} SurfaceMaterial;

inline SurfaceMaterial material_at(const Scene* sc, Hit hit, Surface s) {
    SurfaceMaterial sm;
    sm.shading_normal = s.ns;
#if CLPT_WIDE
    /* One pass per material some lane has (a scene has few). */
    sm.emission = sm.color = v3_splat((float3)(0.0f));
    sm.type = (luint)(0u);
    lmask pending = LANE_TRUE;
    while (lane_any(pending)) {
        const uint index = lane_uint(s.material, lane_first(pending));
        const lmask same = pending && s.material == index;
        __global const Material* m = &sc->materials[index];
        sm.emission = v3_select(sm.emission, v3_splat(vload3(0, m->emission)), same);
        sm.color = v3_select(sm.color, v3_splat(vload3(0, m->color)), same);
        sm.type = select(sm.type, (luint)(m->kind), same);
        pending = pending && !same;
    }
#else
    __global const Material* m = &sc->materials[s.material];
    sm.emission = vload3(0, m->emission);
    sm.color = vload3(0, m->color);
    sm.type = m->kind;
#endif
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
    LFloat3 o, d, radiance, throughput; /* the ray to trace next; the sums so far */
    luint depth;
#if CLPT_NEE
    lmask sampled_light; /* the previous vertex sampled a light too (nee.h) */
    LFloat3 prev_p;
    lfloat prev_pdf;
    luint prev_light;      /* the entry it picked, and its density there if the same at every */
    lfloat prev_light_pdf; /* direction, else 0 (nee.h emission_weight) */
#endif
} Path;

/* The path of sample index `sample` (each lane's) through pixel (px, py): its random numbers
 * and camera ray. */
inline Path path_start(const Scene* sc, luint px, uint py, luint sample) {
    __global const RenderParams* params = sc->params;
    Path p;
    p.rng = rng_for_path(params->seed_lo, params->seed_hi, py * params->camera.width + px, sample);
    camera_ray(&params->camera, px, py, rng_next4(&p.rng), &p.o, &p.d);
    p.radiance = v3_splat((float3)(0.0f));
    p.throughput = v3_splat((float3)(1.0f));
    p.depth = (luint)(0u);
#if CLPT_NEE
    p.sampled_light = !LANE_TRUE;
    p.prev_p = v3_splat((float3)(0.0f));
    p.prev_pdf = 0.0f;
    p.prev_light = (luint)(0u);
    p.prev_light_pdf = 0.0f;
#endif
    return p;
}

#if CLPT_WIDE
/* The lanes m of p taken from q. */
inline void path_select(Path* p, Path q, lmask m) {
    p->rng.pixel = select(p->rng.pixel, q.rng.pixel, m);
    p->rng.sample = select(p->rng.sample, q.rng.sample, m);
    p->rng.dimension = select(p->rng.dimension, q.rng.dimension, m);
    p->rng.quasi0 = select_luint4(p->rng.quasi0, q.rng.quasi0, m);
    p->rng.quasi1 = select_luint4(p->rng.quasi1, q.rng.quasi1, m);
    p->rng.quasi2 = select_luint4(p->rng.quasi2, q.rng.quasi2, m);
    p->o = v3_select(p->o, q.o, m);
    p->d = v3_select(p->d, q.d, m);
    p->radiance = v3_select(p->radiance, q.radiance, m);
    p->throughput = v3_select(p->throughput, q.throughput, m);
    p->depth = select(p->depth, q.depth, m);
#if CLPT_NEE
    p->sampled_light = select(p->sampled_light, q.sampled_light, m);
    p->prev_p = v3_select(p->prev_p, q.prev_p, m);
    p->prev_pdf = select(p->prev_pdf, q.prev_pdf, m);
    p->prev_light = select(p->prev_light, q.prev_light, m);
    p->prev_light_pdf = select(p->prev_light_pdf, q.prev_light_pdf, m);
#endif
}
#endif

/* The stages of one path vertex, in pbrt-v4's names (its wavefront integrator: intersect, add
 * emitted, sample light, sample BSDF, Russian roulette), each over the lanes of `alive`. A stage
 * is always inlined: it takes the path, the surface and its material, structs that a call
 * passes through memory (left to PoCL's inliner, the stages cost the room 6.5% more user CPU at
 * 16 lanes; inlined, the time of one function). */
#define PATH_STAGE inline __attribute__((always_inline))

/* Intersect: the nearest hit of each live lane's ray. */
PATH_STAGE Hit path_intersect(const Scene* sc, const Path* p, lmask alive) {
#if CLPT_WIDE
    /* Ended lanes ask nothing (a mesh walks its tree lane by lane). */
    return scene_intersect_until(sc, p->o, p->d,
                                 lselect((lfloat)(0.0f), (lfloat)(INFINITY), alive));
#else
    return scene_intersect(sc, p->o, p->d);
#endif
}

/* Add emitted: what the surface hit emits towards the ray (direction d), weighed by MIS
 * against the light sample the previous vertex took, if it took one (nee.h). */
PATH_STAGE void path_add_emitted(const Scene* sc, Path* p, Hit hit, Surface s,
                                 SurfaceMaterial sm, LFloat3 d, lmask alive) {
#if CLPT_NEE
    const lmask emits =
        alive && (sm.emission.x != 0.0f || sm.emission.y != 0.0f || sm.emission.z != 0.0f);
    if (lane_any(emits)) {
        lfloat w_emission = 1.0f;
        if (lane_any(emits && p->sampled_light)) {
            w_emission = lselect(w_emission,
                                 emission_weight(sc, hit, s, p->prev_p, p->prev_pdf, d,
                                                 p->prev_light, p->prev_light_pdf),
                                 p->sampled_light);
        }
        p->radiance = v3_select(
            p->radiance,
            v3_add(p->radiance, v3_scale(w_emission, v3_mul(p->throughput, sm.emission))), emits);
    }
#else
    p->radiance = v3_select(p->radiance, v3_add(p->radiance, v3_mul(p->throughput, sm.emission)),
                            alive);
#endif
}

#if CLPT_NEE
/* Sample light: a light sample at every vertex but a delta lobe's, bent shading normals (bump
 * maps, smooth meshes) included: nee.h joins the light's trio to material.h's. */
PATH_STAGE void path_sample_light(const Scene* sc, Path* p, Surface s, SurfaceMaterial sm,
                                  LFloat3 d, lmask alive) {
    p->sampled_light = alive && !bsdf_is_delta(sm.type) && sc->params->num_lights > 0u;
    if (lane_any(p->sampled_light)) {
        const LFloat3 light = sample_light(sc, s, sm.type, sm.color, v3_neg(d), sm.shading_normal,
                                           rng_light4(&p->rng, p->depth), p->sampled_light,
                                           &p->prev_light, &p->prev_light_pdf);
        p->radiance = v3_select(p->radiance, v3_add(p->radiance, v3_mul(p->throughput, light)),
                                p->sampled_light);
    }
}
#endif

/* Sample BSDF: the next direction from the uniforms u, the throughput times its weight, and
 * (with light sampling) the density it was found with, the next hit's MIS weight. */
PATH_STAGE LFloat3 path_sample_bsdf(Path* p, Surface s, SurfaceMaterial sm, LFloat3 d,
                                    LFloat4 u, lmask alive) {
    LFloat3 wi;
    lfloat pdf;
    lmask is_delta;
    const LFloat3 weight = bsdf_sample(sm.type, sm.color, v3_neg(d), s.n, sm.shading_normal, u,
                                       &wi, &pdf, &is_delta);
    p->throughput = v3_select(p->throughput, v3_mul(p->throughput, weight), alive);
#if CLPT_NEE
    p->prev_p = v3_select(p->prev_p, s.p, p->sampled_light);
    p->prev_pdf = lselect(p->prev_pdf, pdf, p->sampled_light);
#endif
    return wi;
}

/* Russian roulette as the lower edge of a weight window (Vorba and Krivanek 2016,
 * "Adjoint-driven Russian roulette and splitting", without the splitting): from bounce
 * rr_depth on, a path whose largest throughput component m is below rr_threshold survives with
 * probability m / rr_threshold and then carries rr_threshold, so no survivor's weight grows
 * past the window. rr_threshold 1 is pbrt-v4's throughput roulette (section 14.1.5); lower
 * thresholds let bright paths run on (the host picks it by measured efficiency,
 * render/strategy.rs). Survival is capped at 0.95, as Mitsuba 3 does, so every path past
 * rr_depth ends with probability >= 0.05 a bounce: even a closed room of albedo 1 (the
 * original's untextured defaults) has paths of at most rr_depth + 20 bounces on average. A zero
 * (or non-finite) throughput ends the path at once. The 1/survive weight keeps the estimate
 * unbiased. Counts the bounce; returns the lanes whose paths go on. */
PATH_STAGE lmask path_roulette(__global const RenderParams* params, Path* p, lfloat u,
                               lmask alive) {
    const lfloat m = max_component(p->throughput);
    alive = alive && m > 0.0f;
    if (!lane_any(alive)) {
        return alive;
    }
    p->depth = lselect(p->depth, p->depth + 1u, alive);
    const lmask roulette = alive && p->depth >= params->rr_depth;
    if (lane_any(roulette)) {
        const lfloat survive = fmin(m / params->rr_threshold, RR_MAX_SURVIVAL);
        alive = alive && !(roulette && !(u < survive));
        if (!lane_any(alive)) {
            return alive;
        }
        p->throughput = v3_select(p->throughput, v3_div(p->throughput, survive), roulette);
    }
    return alive;
}

/* One vertex of path p in each lane of `active`, stage by stage: intersect, add emitted,
 * sample light, sample BSDF, Russian roulette, and the next ray spawned off the surface.
 * Returns the lanes whose paths go on; where a path does not, p->radiance is the sample's
 * value. At width 1 (lanes.h) `active` is true and each mask a plain condition. */
inline lmask path_bounce(const Scene* sc, Path* p, lmask active) {
    __global const RenderParams* params = sc->params;
    lmask alive = active && p->depth < params->max_depth;
    if (!lane_any(alive)) {
        return alive;
    }
    const LFloat3 d = p->d; /* the ray's direction; p->d becomes the next one */
    const Hit hit = path_intersect(sc, p, alive);
    alive = alive && hit.kind != OBJECT_NONE; /* the background is black */
    if (!lane_any(alive)) {
        return alive;
    }
    const Surface s = scene_surface(sc, hit, p->o, d);
    const SurfaceMaterial sm = material_at(sc, hit, s);
    path_add_emitted(sc, p, hit, s, sm, d, alive);
    const LFloat4 u = rng_next4(&p->rng);
#if CLPT_NEE
    path_sample_light(sc, p, s, sm, d, alive);
#endif
    const LFloat3 wi = path_sample_bsdf(p, s, sm, d, u, alive);
    alive = path_roulette(params, p, u.w, alive);
    if (!lane_any(alive)) {
        return alive;
    }
    p->o = v3_select(p->o, offset_ray_origin(s.p, s.p_error, s.n, wi), alive);
    p->d = v3_select(p->d, wi, alive);
    return alive;
}

/* Adds x to the double-float hi + lo (|lo| at most half an ulp of hi): Knuth's TwoSum gives
 * the rounding error of hi + x exactly, lo joins it, and Dekker's FastTwoSum renormalizes, so
 * lo never grows into a sum of its own (Joldes, Muller and Popescu, "Tight and rigorous error
 * bounds for basic building blocks of double-word arithmetic", 2017). Plain f32 sums drift
 * once a pixel holds millions of samples (0.8% low at 2^22 samples of 0.3; an unrenormalized
 * lo still 0.06% high); hi + lo stays within about 1e-7 relative up to 2^32 samples, for nine
 * adds a sample. Needs IEEE adds in program order: no build option here allows reassociation. */
inline void add_compensated(LFloat3* hi, LFloat3* lo, LFloat3 x, lmask m) {
    const LFloat3 s = v3_add(*hi, x);
    const LFloat3 x_part = v3_sub(s, *hi);
    const LFloat3 e = v3_add(v3_add(v3_sub(*hi, v3_sub(s, x_part)), v3_sub(x, x_part)), *lo);
    const LFloat3 t = v3_add(s, e);
    *lo = v3_select(*lo, v3_sub(e, v3_sub(t, s)), m);
    *hi = v3_select(*hi, t, m);
}

/* A pixel's running sums in each lane (render_pass): of its samples (compensated: sum +
 * sum_lo), of their squares, and of the odd half's (odd + odd_lo); the samples that were not
 * finite, and the index of the first. */
typedef struct Film {
    LFloat3 sum, sum_lo, sum_sq, odd, odd_lo;
    luint bad, first;
} Film;

/* The three floats of a film buffer's pixel in each lane of m (zeros elsewhere), and back. */
inline LFloat3 film_load3(__global const float4* buffer, luint pixel, lmask m) {
#if CLPT_WIDE
    LFloat3 v = v3_splat((float3)(0.0f));
    for (uint l = 0u; l < CLPT_LANES; ++l) {
        if (lane_on(m, l)) {
            lane_set_float3(&v, l, buffer[lane_uint(pixel, l)].xyz);
        }
    }
    return v;
#else
    return buffer[pixel].xyz;
#endif
}

/* The .w of each pixel is left as it is. */
inline void film_store3(__global float4* buffer, luint pixel, lmask m, LFloat3 v) {
#if CLPT_WIDE
    for (uint l = 0u; l < CLPT_LANES; ++l) {
        if (lane_on(m, l)) {
            vstore3(lane_float3(v, l), 0, (__global float*)&buffer[lane_uint(pixel, l)]);
        }
    }
#else
    vstore3(v, 0, (__global float*)&buffer[pixel]);
#endif
}

/* Adds sample `sample` of value l to a pixel's running sums in each lane of m: its value
 * (compensated), its square, and, for odd-numbered groups of four, the odd half. A value that
 * is not finite is not added: it is counted, and the first such sample index kept. */
inline void film_add(Film* f, LFloat3 l, luint sample, lmask m) {
    const lmask finite = isfinite(l.x) && isfinite(l.y) && isfinite(l.z);
    const lmask bad = m && !finite;
    if (lane_any(bad)) {
        f->first = lselect(f->first, sample, bad && f->bad == 0u);
        f->bad = lselect(f->bad, f->bad + 1u, bad);
    }
    const lmask add = m && finite;
    if (!lane_any(add)) {
        return;
    }
    add_compensated(&f->sum, &f->sum_lo, l, add);
    f->sum_sq = v3_select(f->sum_sq, v3_add(f->sum_sq, v3_mul(l, l)), add);
    const lmask odd = add && ((sample >> 2) & 1u) != 0u;
    if (lane_any(odd)) {
        add_compensated(&f->odd, &f->odd_lo, l, odd);
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
__kernel void render_pass(SCENE_KERNEL_ARGS __global float4* sum, __global float4* sum_lo,
                          __global float4* sum_sq, __global float4* sum_odd,
                          __global float4* sum_odd_lo, __global uint* bad,
                          __global uint* bad_first, uint sample_start,
                          uint sample_count, uint row_start, uint row_count, uint row_step,
                          uint col_start, uint col_step) {
    const Scene scene = SCENE_FROM_KERNEL_ARGS;
    /* A work-item's lanes take CLPT_LANES consecutive pixels of its row's (lanes.h). */
    const luint px = col_start + ((uint)get_global_id(0) * CLPT_LANES + LANE_INDEX) * col_step;
    const lmask in_image = px < params->camera.width && get_global_id(1) < row_count;
    if (!lane_any(in_image)) {
        return; /* padding of the global size to whole work-groups */
    }
    const uint py = row_start + get_global_id(1) * row_step;
    const luint pixel = py * params->camera.width + px;
    Film film;
    film.sum = film_load3(sum, pixel, in_image);
    film.sum_lo = film_load3(sum_lo, pixel, in_image);
    film.sum_sq = film_load3(sum_sq, pixel, in_image);
    film.odd = film_load3(sum_odd, pixel, in_image);
    film.odd_lo = film_load3(sum_odd_lo, pixel, in_image);
    film.bad = (luint)(0u);
    film.first = (luint)(0xffffffffu);
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
        if (!ended && !path_bounce(&scene, &path, LANE_TRUE)) {
            ended = true;
            film_add(&film, path.radiance, sample_start + i, LANE_TRUE);
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
#if CLPT_WIDE
    /* Lanes of one work-item, as a warp's lanes, regenerate paths: each lane adds its pixel's
     * samples in index order, and a lane whose path has ended starts its next sample when
     * half the lanes with samples left have ended (or none traces on). */
    luint done = (luint)(0u);
    lmask live = in_image && sample_count > 0u;
    lmask tracing = live;
    Path path = path_start(&scene, px, py, (luint)(sample_start));
    while (lane_any(live)) {
        const lmask on = path_bounce(&scene, &path, tracing);
        const lmask ended = tracing && !on;
        if (lane_any(ended)) {
            film_add(&film, path.radiance, sample_start + done, ended);
            done = lselect(done, done + 1u, ended);
            live = live && !(ended && done >= sample_count);
        }
        tracing = on;
        const lmask waiting = live && !tracing;
        if (lane_any(waiting) &&
            (!lane_any(tracing) || 2u * popcount_mask(waiting) >= popcount_mask(live))) {
            path_select(&path, path_start(&scene, px, py, sample_start + done), waiting);
            tracing = tracing || waiting;
        }
    }
#else
    /* A CPU runs each work-item's loop alone: nothing idles while another path runs on. */
    for (uint i = 0u; i < sample_count; ++i) {
        Path path = path_start(&scene, px, py, sample_start + i);
        while (path_bounce(&scene, &path, LANE_TRUE)) {
        }
        film_add(&film, path.radiance, sample_start + i, LANE_TRUE);
    }
#endif
#endif
    film_store3(sum, pixel, in_image, film.sum);
    film_store3(sum_lo, pixel, in_image, film.sum_lo);
    film_store3(sum_sq, pixel, in_image, film.sum_sq);
    film_store3(sum_odd, pixel, in_image, film.odd);
    film_store3(sum_odd_lo, pixel, in_image, film.odd_lo);
#if CLPT_WIDE
    for (uint l = 0u; l < CLPT_LANES; ++l) {
        const uint count = lane_uint(film.bad, l);
        if (count > 0u) {
            const uint p = lane_uint(pixel, l);
            bad_first[p] = bad[p] == 0u ? lane_uint(film.first, l) : bad_first[p];
            bad[p] += count;
        }
    }
#else
    if (film.bad > 0u) {
        bad_first[pixel] = bad[pixel] == 0u ? film.first : bad_first[pixel];
        bad[pixel] += film.bad;
    }
#endif
}

/* Error sums of one image row after `spp` samples, for the per-pass report (render/mod.rs).
 * Reads: the film sums, and with has_reference the reference image (linear rgb). Writes: the
 * row's ErrorRow (types.h): the estimated squared error of the mean and its relative form
 * (spp >= 5, so that both halves have samples), and with a reference the squared, relative
 * squared and absolute errors. */
__kernel void error_rows(__global const float4* sum, __global const float4* sum_lo,
                         __global const float4* sum_odd, __global const float4* sum_odd_lo,
                         __global const float4* reference, uint has_reference, uint width,
                         uint spp, float eps, __global ErrorRow* out) {
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
    __global ErrorRow* o = out + row;
    o->estimate = est;
    o->estimate_rel = est_rel;
    o->squared = se;
    o->squared_rel = se_rel;
    o->absolute = ae;
}
