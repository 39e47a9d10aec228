/* nee.h: next-event estimation with multiple importance sampling (Veach 1997, ch. 9; pbrt-v4
 * section 13.4).
 *
 * Reads: the light list (types.h `Light` entries the host chose and placed in world space,
 * src/pack/lights.rs: spheres, squares of planes and mesh triangles of constant
 * emission) and their materials. Writes: nothing. Why: a small bright light is found by BSDF
 * sampling only rarely, so pure path tracing converges slowly on it (the original's report says
 * so of its light balls). At every vertex whose material is not a delta lobe, one light is
 * picked in proportion to its power and sampled, and joined by a shadow ray. Paths that hit a
 * listed light by BSDF sampling after such a vertex weigh its emission by the power heuristic,
 * and light samples the complement, so the two strategies add up to one estimate of the same
 * integral: unbiased, as pure path tracing.
 *
 * Each emitter kind has a trio, as each material has in material.h (pbrt-v4's Light interface:
 * SampleLi, PDF_Li, L): light_sample (a sphere by the cone it subtends, uniformly in solid
 * angle; an emitting wall of the closed room, marked by the host, uniformly in the solid angle
 * it subtends where that is between SPH_RECT_MIN and SPH_RECT_MAX; other squares, what
 * clipping leaves of them, walls outside those bounds and triangles uniformly over their area),
 * light_pdf (its solid-angle density, which light_sample returns and BSDF-sampled hits are
 * weighed with) and light_emitted (constant). sample_light joins them to material.h's trio,
 * bsdf_eval and bsdf_pdf, and assumes nothing of the surface; tests/chi2.rs checks each
 * light_sample against light_pdf with the chi-square harness of tests/common/chi2.rs.
 */
#ifndef CLPT_NEE_H
#define CLPT_NEE_H

#include "types.h"
#include "objects.h"
#include "material.h"

/* Whether light entry l is keyed before (kind, index, triangle). */
inline bool light_before(__global const Light* l, uint kind, uint index, uint triangle) {
    if (l->kind != kind) {
        return l->kind < kind;
    }
    if (l->index != index) {
        return l->index < index;
    }
    return l->triangle < triangle;
}

/* The light-list triangle of a hit: its triangle on a mesh, 0 elsewhere. */
inline luint light_triangle_of(Hit hit) {
    return lselect((luint)(0u), hit.prim, hit.kind == OBJECT_MESH);
}

/* Whether `hit` is on light l. */
inline lmask light_is_hit(__global const Light* l, Hit hit) {
    return l->kind == hit.kind && l->index == hit.index &&
           l->triangle == light_triangle_of(hit);
}

/* The light-list entry keyed (kind, index, triangle), by binary search of the sorted list, or
 * -1 when it is not listed: the host's choice is the only rule. */
inline int find_light_key(const Scene* sc, uint kind, uint index, uint triangle) {
    uint lo = 0u, hi = sc->params->num_lights;
    while (lo < hi) {
        const uint mid = (lo + hi) / 2u;
        if (light_before(&sc->lights[mid], kind, index, triangle)) {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    __global const Light* l = &sc->lights[lo];
    return lo < sc->params->num_lights && l->kind == kind && l->index == index &&
                   l->triangle == triangle
               ? (int)lo
               : -1;
}

/* The light-list entry of what each lane's `hit` hit, or -1 (lane by lane). */
inline lint find_light(const Scene* sc, Hit hit) {
    const luint kind = hit.kind, triangle = light_triangle_of(hit);
#if CLPT_WIDE
    lint entry;
    for (uint l = 0u; l < CLPT_LANES; ++l) {
        ((int*)&entry)[l] = find_light_key(sc, lane_uint(kind, l), lane_uint(hit.index, l),
                                           lane_uint(triangle, l));
    }
    return entry;
#else
    return find_light_key(sc, kind, hit.index, triangle);
#endif
}

/* The entry a uniform u picks: the first whose cdf exceeds u (entries of prob 0 are never
 * picked), the last if rounding left u above every cdf. */
inline uint pick_light_at(const Scene* sc, float u) {
    uint lo = 0u, hi = sc->params->num_lights - 1u;
    while (lo < hi) {
        const uint mid = (lo + hi) / 2u;
        if (sc->lights[mid].cdf <= u) {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    return lo;
}

/* The entry each lane's u picks (lane by lane). */
inline luint pick_light(const Scene* sc, lfloat u) {
#if CLPT_WIDE
    luint pick;
    for (uint l = 0u; l < CLPT_LANES; ++l) {
        lane_set_uint(&pick, l, pick_light_at(sc, lane_float(u, l)));
    }
    return pick;
#else
    return pick_light_at(sc, u);
#endif
}

/* 1 - cos of the half-angle of the cone a sphere of squared radius r2 subtends from squared
 * distance d2 (> r2), without cancelling for small cones: sin^2 / (1 + cos). */
inline lfloat cone_one_minus_cos(float r2, lfloat d2) {
    const lfloat sin2 = r2 / d2;
    return sin2 / (1.0f + sqrt(fmax(0.0f, 1.0f - sin2)));
}

#if CLPT_PLANES
/* Rectangle lights by solid angle (Urena, Fajardo and King 2013, "An Area-Preserving
 * Parametrization for Spherical Rectangles", EGSR; Cycles and Arnold sample rectangle lights so,
 * pbrt-v4 its bilinear patches). By area, a big emitter close by, as the ceiling of a room, is
 * sampled in proportion to its area while its light arrives in proportion to solid angle: the
 * estimate carries the whole r^2 / cos variation across it. By solid angle it carries only the
 * receiver's cosine (and visibility): in ceiling_room's room the relative variance of one light
 * sample at a point of the floor or walls falls 2.5 to 15 times (f64 quadrature of the MIS
 * estimate with BSDF sampling), and the render's relMSE at equal samples about halves.
 *
 * Which rectangles: those the host marks (Light.solid_angle), the emitting walls of a closed
 * room (src/pack/lights.rs), whose shading points come right up to them. The mapping costs a
 * few hundred instructions a sample, and on a GPU a warp runs them whenever one of its lanes
 * picks such a light: lights.txt's panel, hung in its room at 0.2 sr from most points, took
 * 15 to 23% more time by solid angle for 0.4% less relMSE (H200), so lights other than walls
 * keep the cheaper area sampling.
 *
 * The frame: x along edge1, z the light's normal, y = z x x (along edge2: a wall's edges lie
 * along two axes). Seen from p in that frame, the rectangle is [x0, x1] x [y0, y1] at height
 * z0 < 0 (p in front of the one-sided emitter). Its solid angle is the sum of the spherical
 * quadrilateral's interior angles less 2 pi; the angle at a corner (x, y), between the planes
 * through p and its two edges, has cosine and sine along (+-x y, |z0| |(x, y, z0)|): atan2 of
 * that is well conditioned where the paper's acos of a cosine near 1 is not (grazing angles),
 * and two angles' sum is the atan2 of the product of their complex numbers. Angles are kept in
 * units of pi (atan2pi, sinpi, cospi: no range reduction). Outside [SPH_RECT_MIN,
 * SPH_RECT_MAX] the light is sampled by area: below, the sum of angles cancels to a few f32
 * ulps of 2 pi (at 0.01 sr its relative error is below 1e-4, at 0.1 sr 5e-6, against f64 over
 * random rectangles), and a rectangle that small in solid angle gains little; above (p a
 * rounding off the plane, inside the rectangle's footprint) the mapping loses its precision.
 * light_sample and light_pdf decide alike from the same function of (l, p), so each
 * strategy's density is the one it is weighed by. */
#define SPH_RECT_MIN 0.01f
#define SPH_RECT_MAX 6.2f

typedef struct SphRect {
    float3 ex, ey;        /* the frame's x and y; z is the light's normal */
    lfloat x0, x1, y0, y1, z0;
    lfloat b0, b1, k;     /* the paper's constants of the mapping, k in units of pi */
    lfloat solid_angle;   /* 0: sample by area */
} SphRect;

/* Rectangle light l seen from each lane's p, or solid_angle 0 where it is sampled by area. */
inline SphRect sph_rect(__global const Light* l, LFloat3 p) {
    SphRect r;
    r.solid_angle = 0.0f;
    if (!l->solid_angle) {
        return r;
    }
    const float3 e1 = vload3(0, l->edge1), e2 = vload3(0, l->edge2), n = vload3(0, l->normal);
    const float w = length(e1);
    r.ex = e1 / w;
    r.ey = cross(n, r.ex);
    const LFloat3 d = v3_sub(v3_splat(vload3(0, l->corner)), p);
    r.x0 = v3_dot(d, v3_splat(r.ex));
    r.x1 = r.x0 + w;
    r.y0 = v3_dot(d, v3_splat(r.ey));
    r.y1 = r.y0 + dot(e2, r.ey);
    r.z0 = v3_dot(d, v3_splat(n));
    /* p behind the emitter or on its plane: sampled by area, which gives 0 */
    const lmask behind = !(r.z0 < 0.0f);
    if (lane_all(behind)) {
        return r;
    }
    /* The angles in coordinates scaled to at most 1, so that the products below neither
     * overflow nor underflow (angles do not change with scale). */
    const lfloat unit =
        1.0f / fmax(fmax(fmax(fabs(r.x0), fabs(r.x1)), fmax(fabs(r.y0), fabs(r.y1))), -r.z0);
    const lfloat x0 = r.x0 * unit, x1 = r.x1 * unit, y0 = r.y0 * unit, y1 = r.y1 * unit;
    const lfloat z = -r.z0 * unit, z2 = z * z;
    /* Each angle as a complex number (cos, sin) times a positive length, and two angles' sum as
     * their product: two atan2 instead of four. Each angle is in (0, pi) (sin > 0), so each
     * sum is in (0, 2 pi): atan2pi's (-1, 1] plus 2 where it is negative, in units of pi. */
    const LFloat2 a0 = make_lfloat2(y0 * x1, z * sqrt(x1 * x1 + y0 * y0 + z2));
    const LFloat2 a1 = make_lfloat2(-x1 * y1, z * sqrt(x1 * x1 + y1 * y1 + z2));
    const LFloat2 a2 = make_lfloat2(x0 * y1, z * sqrt(x0 * x0 + y1 * y1 + z2));
    const LFloat2 a3 = make_lfloat2(-x0 * y0, z * sqrt(x0 * x0 + y0 * y0 + z2));
    lfloat g01 = atan2pi(a0.x * a1.y + a0.y * a1.x, a0.x * a1.x - a0.y * a1.y);
    lfloat g23 = atan2pi(a2.x * a3.y + a2.y * a3.x, a2.x * a3.x - a2.y * a3.y);
    g01 += lselect((lfloat)(0.0f), (lfloat)(2.0f), g01 < 0.0f);
    g23 += lselect((lfloat)(0.0f), (lfloat)(2.0f), g23 < 0.0f);
    r.b0 = -y0 / sqrt(z2 + y0 * y0);
    r.b1 = y1 / sqrt(z2 + y1 * y1);
    r.k = 2.0f - g23;
    const lfloat s = M_PI_F * (g01 - r.k);
    r.solid_angle =
        lselect((lfloat)(0.0f), s, s >= SPH_RECT_MIN && s <= SPH_RECT_MAX && !behind);
    return r;
}

/* The point (x, y) of rectangle r that uniforms u map to, uniformly in solid angle (the paper's
 * algorithm: x from the area swept by u.x, then y along the great-circle arc at x). Clamps keep
 * rounding inside the rectangle; fmax/fmin also map a NaN (0 / 0 at a measure-zero u) there. */
inline LFloat2 sph_rect_sample(SphRect r, lfloat ux, lfloat uy) {
    const lfloat au = ux * (r.solid_angle * M_1_PI_F) + r.k;
    const lfloat fu = (cospi(au) * r.b0 - r.b1) / sinpi(au);
    const lfloat cu = fmin(fmax(copysign(rsqrt(fu * fu + r.b0 * r.b0), fu), -1.0f), 1.0f);
    const lfloat x_free = -(cu * r.z0) / sqrt(fmax((1.0f - cu) * (1.0f + cu), FLT_MIN));
    const lfloat x = fmin(fmax(x_free, r.x0), r.x1);
    const lfloat d2 = x * x + r.z0 * r.z0;
    const lfloat h0 = r.y0 * rsqrt(d2 + r.y0 * r.y0), h1 = r.y1 * rsqrt(d2 + r.y1 * r.y1);
    const lfloat h = h0 + uy * (h1 - h0);
    const lfloat y = h * sqrt(d2) / sqrt(fmax((1.0f - h) * (1.0f + h), FLT_MIN));
    return make_lfloat2(x, fmin(fmax(y, r.y0), r.y1));
}
#endif

/* The cosine at light l of a direction d arriving there: a plane's square emits to its
 * normal's side only, a triangle to both. */
inline lfloat light_cosine(__global const Light* l, LFloat3 d) {
    const lfloat c = -v3_dot(v3_splat(vload3(0, l->normal)), d);
    return l->kind == OBJECT_MESH ? fabs(c) : c;
}

/* The solid-angle density, from p, with which light sampling picks light l and the direction d
 * that reaches it at distance t (light_sample's, the pick included). 0 where it would not have
 * been (p inside a sphere, a square seen from behind). The caller knows d meets l: a sphere's
 * density is the same at every direction of its cone. */
inline lfloat light_pdf(__global const Light* l, LFloat3 p, LFloat3 d, lfloat t) {
    if (l->kind == OBJECT_SPHERE && l->cap_height > 0.0f) {
        /* Uniform over the visible cap's area (src/pack/lights.rs `visible_cap`); 0 off it,
         * where light sampling never lands. */
        const float3 c = vload3(0, l->corner);
        const LFloat3 n = v3_div(v3_sub(v3_add(p, v3_scale(t, d)), v3_splat(c)), l->radius);
        const lfloat cos_l = -v3_dot(n, d);
        /* A point light_sample put on the rim (u.x = 1) has its height recomputed here from
         * p, d and t, which rounds it to either side by a few ulps of those coordinates, and
         * differently where the compiler contracts differently (NVIDIA's lost one of 500000
         * rim samples of tests/chi2.rs): the rim counts as the cap within that rounding. */
        const lfloat slack = 16.0f * FLT_EPSILON * (l->radius + t + v3_length(v3_sub(p, v3_splat(c))));
        const lmask on_cap =
            v3_dot(n, v3_splat(vload3(0, l->normal))) * l->radius >= l->radius - l->cap_height - slack;
        return lselect((lfloat)(0.0f), l->prob * t * t / (cos_l * l->area), on_cap && cos_l > 0.0f);
    }
    if (l->kind == OBJECT_SPHERE) {
        const LFloat3 pc = v3_sub(v3_splat(vload3(0, l->corner)), p);
        const lfloat d2 = v3_dot(pc, pc);
        const float r2 = l->radius * l->radius;
        return lselect((lfloat)(0.0f), l->prob / (2.0f * M_PI_F * cone_one_minus_cos(r2, d2)),
                       d2 > r2);
    }
#if CLPT_PLANES
    lfloat by_angle = 0.0f;
    if (l->kind == OBJECT_PLANE) {
        by_angle = sph_rect(l, p).solid_angle;
        if (lane_all(by_angle > 0.0f)) {
            return l->prob / by_angle;
        }
    }
#endif
    const lfloat cos_l = light_cosine(l, d);
    const lfloat by_area = lselect((lfloat)(0.0f), l->prob * t * t / (cos_l * l->area), cos_l > 0.0f);
#if CLPT_PLANES
    return lselect(by_area, l->prob / by_angle, by_angle > 0.0f);
#else
    return by_area;
#endif
}

/* The power heuristic's weight of a strategy of density a against one of density b. */
inline lfloat mis_weight(lfloat a, lfloat b) {
    const lfloat a2 = a * a, b2 = b * b;
    return lselect((lfloat)(0.0f), a2 / (a2 + b2), a2 + b2 > 0.0f);
}

/* The weight of emission found by BSDF sampling from p (which sampled the unit direction d with
 * density pdf_bsdf and also sampled a light) at the surface s of hit. The light sample at p
 * picked entry `picked`, whose density from p was `picked_pdf` at every direction (0 where it
 * varies): when the hit is on that entry, light_pdf would compute the same again. */
inline lfloat emission_weight(const Scene* sc, Hit hit, Surface s, LFloat3 p, lfloat pdf_bsdf,
                              LFloat3 d, luint picked, lfloat picked_pdf) {
    const lint entry = find_light(sc, hit);
    const lfloat t = v3_length(v3_sub(s.p, p));
    /* The density of the entry hit, where it is not the one picked with a density known. */
    lmask pending = entry >= 0 && !(LANE_CONVERT(uint, entry) == picked && picked_pdf > 0.0f);
    lfloat pdf_light = picked_pdf;
#if CLPT_WIDE
    while (lane_any(pending)) {
        const int one = ((const int*)&entry)[lane_first(pending)];
        const lmask same = pending && entry == one;
        pdf_light = select(pdf_light, light_pdf(&sc->lights[one], p, d, t), same);
        pending = pending && !same;
    }
#else
    if (pending) {
        pdf_light = light_pdf(&sc->lights[entry], p, d, t);
    }
#endif
    return lselect((lfloat)(1.0f), mis_weight(pdf_bsdf, pdf_light), entry >= 0);
}

/* Whether the segment from the surface s (left towards the point q sampled on light l, of
 * error bound q_error and geometric normal q_normal there) to q is free of any surface: a
 * shadow ray to a point (pbrt-v4's SpawnRayTo, section 6.8.6), leaving the spawned origin
 * towards q itself, not along the direction sampled from s.p, its far end pulled in by the
 * distance's rounding.
 * - A sphere or a plane light can meet the segment only at q (q lies on the sphere's side that
 *   faces s, light_pdf being 0 on the other, and a square is one-sided): a hit on the light
 *   itself ends the segment unblocked. Anything else before it blocks, however close to q:
 *   smallpt's light meets its ceiling at a rim, and samples of its hidden part a rounding
 *   above the ceiling are the ceiling's, as intersection finds them. (Pulling the end in by q's
 *   error instead let through 0.16% of the light from those; and fell short at low angles to
 *   the light, where q rounded inside it shadowed itself: a 0.2% loss.)
 * - A triangle's neighbours on the same mesh are other primitives, which q may round onto: q
 *   is moved off its triangle's plane by its error bound, to the side of s, and the end pulled
 *   in by that error along the ray, for the light's own intersection routine. Whatever else
 *   lies on the segment blocks it. */
inline lmask segment_unblocked(const Scene* sc, Surface s, __global const Light* l, LFloat3 q,
                               LFloat3 q_error, LFloat3 q_normal, LFloat3 wi, lmask wanted) {
    const LFloat3 o = offset_ray_origin(s.p, s.p_error, s.n, wi);
    const bool triangle = l->kind == OBJECT_MESH;
    if (triangle) {
        q = offset_ray_origin(q, q_error, q_normal, v3_sub(o, q));
    }
    const LFloat3 to = v3_sub(q, o);
    const lfloat dist = v3_length(to);
    /* q at the spawned origin: nothing fits between */
    lmask free = !(dist > 0.0f);
    if (lane_all(free)) {
        return free;
    }
    const LFloat3 d = v3_div(to, dist);
    const lfloat pull =
        error_gamma(4.0f) * dist + (triangle ? v3_dot(v3_fabs(d), q_error) : (lfloat)(0.0f));
    const lfloat t_max = dist - pull;
    /* within rounding of the surface: nothing fits between */
    free = free || !(t_max > 0.0f);
#if CLPT_WIDE
    free = free || !wanted;
#endif
    if (lane_all(free)) {
        return free;
    }
#if CLPT_WIDE
    /* Lanes that trace nothing ask nothing (a mesh walks its tree lane by lane). */
    const Hit hit = scene_intersect_until(sc, o, d, lselect(t_max, (lfloat)(0.0f), free));
#else
    const Hit hit = scene_intersect_until(sc, o, d, t_max);
#endif
    return free || hit.kind == OBJECT_NONE || (!triangle && light_is_hit(l, hit));
}

/* The error bound of a point q = c + offset sampled on a sphere light: the offset's few
 * roundings (at most 5), the sum's, and the list's centre c against the sphere the
 * intersection routines see (the f32 rounding of the same centre, or its double-float):
 * u |c| <= u (|q| + |offset|). Not gamma (|c| + |offset|): far from the device's origin that
 * counts |c| six times. */
inline LFloat3 sphere_sample_error(LFloat3 q, LFloat3 offset) {
    return v3_add(v3_scale(error_gamma(2.0f), v3_fabs(q)), v3_scale(error_gamma(6.0f), v3_fabs(offset)));
}

/* Samples light l from p: a direction *wi towards the point *q on it (of rounding-error bound
 * *q_error, geometric normal *q_normal) with the solid-angle density *pdf = light_pdf(l, p,
 * *wi, |q - p|), the chance of picking l included; *uniform says whether that density is the
 * same at every direction of l (a sphere's cone, a rectangle by solid angle). u.x and u.y place
 * the point. Returns false where l offers p nothing (p inside a sphere, a square seen from
 * behind, a triangle edge-on). */
inline lmask light_sample(__global const Light* l, LFloat3 p, lfloat ux, lfloat uy, LFloat3* wi,
                          LFloat3* q, LFloat3* q_error, LFloat3* q_normal, lfloat* pdf,
                          lmask* uniform) {
    *uniform = !LANE_TRUE;
    if (l->kind == OBJECT_SPHERE && l->cap_height > 0.0f) {
        /* The visible cap (src/pack/lights.rs `visible_cap`), uniformly by area: a sphere's
         * area is uniform in height along any axis (Archimedes), so the depth below the cap's
         * top is cap_height u.x. */
        const float3 c = vload3(0, l->corner), axis = vload3(0, l->normal);
        const float r = l->radius;
        const lfloat below = l->cap_height * ux;
        const lfloat rho = sqrt(fmax(0.0f, below * (2.0f * r - below)));
        const LFloat2 around = turn(uy);
        LFloat3 t, b;
        orthonormal_basis(v3_splat(axis), &t, &b);
        const LFloat3 offset =
            v3_add(v3_scale(r - below, v3_splat(axis)),
                   v3_scale(rho, v3_add(v3_scale(around.x, t), v3_scale(around.y, b))));
        *q = v3_add(v3_splat(c), offset);
        *q_error = sphere_sample_error(*q, offset);
        *q_normal = v3_div(offset, r);
        const LFloat3 to = v3_sub(*q, p);
        const lfloat dist = sqrt(v3_dot(to, to));
        *wi = v3_div(to, dist);
        /* 0 on the cap's far side, which its near side hides from p. */
        *pdf = light_pdf(l, p, *wi, dist);
        return *pdf > 0.0f;
    }
    if (l->kind == OBJECT_SPHERE) {
        /* Uniformly in the cone the sphere subtends (pbrt-v4 section 6.2.4). */
        const float3 c = vload3(0, l->corner);
        const LFloat3 pc = v3_sub(v3_splat(c), p);
        const lfloat d2 = v3_dot(pc, pc);
        const float r2 = l->radius * l->radius;
        const lmask outside = !(d2 <= r2);
        if (!lane_any(outside)) {
            return outside;
        }
        const lfloat v = ux * cone_one_minus_cos(r2, d2); /* 1 - cos theta */
        const lfloat cos_t = 1.0f - v;
        const lfloat sin_t = sqrt(fmax(0.0f, v * (2.0f - v)));
        const LFloat2 turned = turn(uy);
        const LFloat2 around = make_lfloat2(sin_t * turned.x, sin_t * turned.y);
        const LFloat3 w = v3_div(pc, sqrt(d2));
        LFloat3 t, b;
        orthonormal_basis(w, &t, &b);
        *wi = v3_normalize(
            v3_add(v3_add(v3_scale(around.x, t), v3_scale(around.y, b)), v3_scale(cos_t, w)));
        /* The nearer point where wi meets the sphere, from the centre's distance to the ray
         * (no cancellation for tiny spheres far away); a direction that rounding put just past
         * the rim takes the tangent point. */
        const lfloat along = v3_dot(pc, *wi);
        const LFloat3 perp = v3_sub(pc, v3_scale(along, *wi));
        const lfloat t_hit = along - sqrt(fmax(0.0f, r2 - v3_dot(perp, perp)));
        const LFloat3 n = v3_normalize(v3_sub(v3_add(p, v3_scale(t_hit, *wi)), v3_splat(c)));
        *q = v3_add(v3_splat(c), v3_scale(l->radius, n));
        *q_error = sphere_sample_error(*q, v3_scale(l->radius, n));
        *q_normal = n;
        *pdf = light_pdf(l, p, *wi, t_hit);
        *uniform = outside;
        return outside;
    }
    const float3 corner = vload3(0, l->corner);
#if CLPT_PLANES
    lmask by_angle = !LANE_TRUE;
    LFloat3 angle_q, angle_wi, angle_q_error;
    lfloat angle_pdf;
    if (l->kind == OBJECT_PLANE) {
        const SphRect r = sph_rect(l, p);
        by_angle = r.solid_angle > 0.0f;
        if (lane_any(by_angle)) {
            const LFloat2 xy = sph_rect_sample(r, ux, uy);
            const LFloat3 e1 = v3_scale(xy.x - r.x0, v3_splat(r.ex));
            const LFloat3 e2 = v3_scale(xy.y - r.y0, v3_splat(r.ey));
            angle_q = v3_add(v3_add(v3_splat(corner), e1), e2);
            angle_q_error = v3_scale(
                error_gamma(6.0f), v3_add(v3_add(v3_splat(fabs(corner)), v3_fabs(e1)), v3_fabs(e2)));
            *q_normal = v3_splat(vload3(0, l->normal));
            const LFloat3 to = v3_sub(angle_q, p);
            angle_wi = v3_div(to, sqrt(v3_dot(to, to)));
            angle_pdf = l->prob / r.solid_angle;
            if (lane_all(by_angle)) {
                *q = angle_q;
                *q_error = angle_q_error;
                *wi = angle_wi;
                *pdf = angle_pdf;
                *uniform = LANE_TRUE;
                return LANE_TRUE;
            }
        }
    }
#endif
    /* Uniform over the parallelogram, or over the triangle by folding the square's far half onto
     * it (pbrt-v4 section A.5.5 samples triangles otherwise; this is equally uniform). */
    lfloat a = ux, b = uy;
    const lmask fold = l->kind == OBJECT_MESH && a + b > 1.0f;
    a = lselect(a, 1.0f - a, fold);
    b = lselect(b, 1.0f - b, fold);
    const LFloat3 e1 = v3_scale(a, v3_splat(vload3(0, l->edge1)));
    const LFloat3 e2 = v3_scale(b, v3_splat(vload3(0, l->edge2)));
    *q = v3_add(v3_add(v3_splat(corner), e1), e2);
    /* Rounding of the sum, and of the list's corner and edges against the geometry the
     * intersection routines see (both rounded to f32 from the same f64 values). */
    *q_error = v3_scale(error_gamma(6.0f),
                        v3_add(v3_add(v3_splat(fabs(corner)), v3_fabs(e1)), v3_fabs(e2)));
    *q_normal = v3_splat(vload3(0, l->normal));
    const LFloat3 to = v3_sub(*q, p);
    const lfloat dist = sqrt(v3_dot(to, to));
    *wi = v3_div(to, dist);
    *pdf = light_pdf(l, p, *wi, dist);
    lmask sampled = *pdf > 0.0f;
#if CLPT_PLANES
    if (lane_any(by_angle)) {
        *q = v3_select(*q, angle_q, by_angle);
        *wi = v3_select(*wi, angle_wi, by_angle);
        *q_error = v3_select(*q_error, angle_q_error, by_angle);
        *pdf = lselect(*pdf, angle_pdf, by_angle);
        *uniform = by_angle;
        sampled = sampled || by_angle;
    }
#endif
    return sampled;
}

/* The radiance light l emits towards any point it is sampled from: its material's emission,
 * constant over the light (the host lists only emitters of constant emission). */
inline float3 light_emitted(const Scene* sc, __global const Light* l) {
    return vload3(0, sc->materials[l->material].emission);
}

/* Light l's sample from the surface s of material `type` and `color` (shading normal ns), for
 * the path arriving from wo, in each lane (of `lanes`, wider than one): its MIS-weighted
 * contribution f cos Le w / pdf, or 0; *picked_pdf is its density where that is the same at
 * every direction of l, else 0. */
inline LFloat3 light_contribution(const Scene* sc, __global const Light* l, Surface s, luint type,
                                  LFloat3 color, LFloat3 wo, LFloat3 ns, lfloat ux, lfloat uy,
                                  lmask lanes, lfloat* picked_pdf) {
    LFloat3 wi, q, q_error, q_normal;
    lfloat pdf;
    lmask uniform;
    const LFloat3 none = v3_splat((float3)(0.0f));
    *picked_pdf = 0.0f;
    lmask ok = light_sample(l, s.p, ux, uy, &wi, &q, &q_error, &q_normal, &pdf, &uniform);
#if CLPT_WIDE
    ok = ok && lanes; /* the shadow rays of the lanes that picked l only */
#endif
    if (!lane_any(ok)) {
        return none;
    }
    *picked_pdf = lselect((lfloat)(0.0f), pdf, ok && uniform);
    const lfloat pdf_bsdf = bsdf_pdf(type, wo, wi, s.n, ns);
    ok = ok && pdf_bsdf > 0.0f && pdf > 0.0f && isfinite(pdf);
    if (!lane_any(ok)) {
        return none;
    }
    ok = ok && segment_unblocked(sc, s, l, q, q_error, q_normal, wi, ok);
    if (!lane_any(ok)) {
        return none;
    }
    const LFloat3 f = bsdf_eval(type, color, wo, wi, s.n, ns);
    return v3_select(none,
                     v3_scale(mis_weight(pdf, pdf_bsdf) / pdf,
                              v3_mul(f, v3_splat(light_emitted(sc, l)))),
                     ok);
}

/* One light sample from the surface s in each lane (of `lanes`, wider than one; the arguments
 * of light_contribution, u.x picking the light): its MIS-weighted contribution, or 0. Delta
 * materials take none: their f is 0 at every direction a light sample could choose. *picked is
 * the entry it picked, *picked_pdf that entry's density where it is the same at every
 * direction, else 0 (emission_weight's, for the BSDF sample's hit). */
inline LFloat3 sample_light(const Scene* sc, Surface s, luint type, LFloat3 color, LFloat3 wo,
                            LFloat3 ns, LFloat4 u, lmask lanes, luint* picked,
                            lfloat* picked_pdf) {
    const luint pick = pick_light(sc, u.x);
    *picked = pick;
    *picked_pdf = 0.0f;
    const lmask takes = !bsdf_is_delta(type);
#if CLPT_WIDE
    /* One pass per light some lane picked. */
    LFloat3 sum = v3_splat((float3)(0.0f));
    lmask pending = takes && lanes;
    while (lane_any(pending)) {
        const uint entry = lane_uint(pick, lane_first(pending));
        const lmask same = pending && pick == entry;
        lfloat density;
        const LFloat3 c = light_contribution(sc, &sc->lights[entry], s, type, color, wo, ns, u.y,
                                             u.z, same, &density);
        sum = v3_select(sum, c, same);
        *picked_pdf = select(*picked_pdf, density, same);
        pending = pending && !same;
    }
    return sum;
#else
    if (!takes) {
        return (float3)(0.0f);
    }
    return light_contribution(sc, &sc->lights[pick], s, type, color, wo, ns, u.y, u.z, takes,
                              picked_pdf);
#endif
}

#endif
