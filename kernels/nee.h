/* nee.h: next-event estimation with multiple importance sampling (Veach 1997, ch. 9; pbrt-v4
 * section 13.4).
 *
 * Reads: the light list (types.h `Light` entries the host chose and placed in world space,
 * src/device/lights.rs: spheres, squares of planes and mesh triangles of constant
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
 * angle; a square, or the parallelogram clipping leaves of it, and a triangle uniformly over
 * their area), light_pdf (its solid-angle density, which light_sample returns and BSDF-sampled
 * hits are weighed with) and light_emitted (constant). sample_light joins them to material.h's
 * trio, bsdf_eval and bsdf_pdf, and assumes nothing of the surface; tests/chi2.rs checks each
 * light_sample against light_pdf with the chi-square harness of tests/common/chi2.rs.
 */
#ifndef CLPT_NEE_H
#define CLPT_NEE_H

/* The light-list key of a hit: the entry it would have, if listed. */
inline uint light_kind_of(Hit hit) {
    return hit.kind == HIT_SPHERE  ? OBJECT_SPHERE
           : hit.kind == HIT_PLANE ? OBJECT_PLANE
           : hit.kind == HIT_MESH  ? OBJECT_MESH
                                   : 0xffffffffu;
}

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
inline uint light_triangle_of(Hit hit) {
    return hit.kind == HIT_MESH ? hit.prim : 0u;
}

/* Whether `hit` is on light l. */
inline bool light_is_hit(__global const Light* l, Hit hit) {
    return l->kind == light_kind_of(hit) && l->index == hit.index &&
           l->triangle == light_triangle_of(hit);
}

/* The light-list entry of what `hit` hit, by binary search of the sorted list, or -1 when it is
 * not listed: the host's choice is the only rule. */
inline int find_light(const Scene* sc, Hit hit) {
    const uint kind = light_kind_of(hit);
    const uint triangle = light_triangle_of(hit);
    uint lo = 0u, hi = sc->params->num_lights;
    while (lo < hi) {
        const uint mid = (lo + hi) / 2u;
        if (light_before(&sc->lights[mid], kind, hit.index, triangle)) {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    return lo < sc->params->num_lights && light_is_hit(&sc->lights[lo], hit) ? (int)lo : -1;
}

/* The entry a uniform u picks: the first whose cdf exceeds u (entries of prob 0 are never
 * picked), the last if rounding left u above every cdf. */
inline uint pick_light(const Scene* sc, float u) {
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

/* 1 - cos of the half-angle of the cone a sphere of squared radius r2 subtends from squared
 * distance d2 (> r2), without cancelling for small cones: sin^2 / (1 + cos). */
inline float cone_one_minus_cos(float r2, float d2) {
    const float sin2 = r2 / d2;
    return sin2 / (1.0f + sqrt(fmax(0.0f, 1.0f - sin2)));
}

/* The cosine at light l of a direction d arriving there: a plane's square emits to its
 * normal's side only, a triangle to both. */
inline float light_cosine(__global const Light* l, float3 d) {
    const float c = -dot(vload3(0, l->normal), d);
    return l->kind == OBJECT_MESH ? fabs(c) : c;
}

/* The solid-angle density, from p, with which light sampling picks light l and the direction d
 * that reaches it at distance t (light_sample's, the pick included). 0 where it would not have
 * been (p inside a sphere, a square seen from behind). The caller knows d meets l: a sphere's
 * density is the same at every direction of its cone. */
inline float light_pdf(__global const Light* l, float3 p, float3 d, float t) {
    if (l->kind == OBJECT_SPHERE && l->cap_height > 0.0f) {
        /* Uniform over the visible cap's area (src/device/lights.rs `visible_cap`); 0 off it,
         * where light sampling never lands. */
        const float3 c = vload3(0, l->corner);
        const float3 n = (p + d * t - c) / l->radius;
        const float cos_l = -dot(n, d);
        /* A point light_sample put on the rim (u.x = 1) has its height recomputed here from
         * p, d and t, which rounds it to either side by a few ulps of those coordinates, and
         * differently where the compiler contracts differently (NVIDIA's lost one of 500000
         * rim samples of tests/chi2.rs): the rim counts as the cap within that rounding. */
        const float slack = 16.0f * FLT_EPSILON * (l->radius + t + length(p - c));
        const bool on_cap =
            dot(n, vload3(0, l->normal)) * l->radius >= l->radius - l->cap_height - slack;
        return on_cap && cos_l > 0.0f ? l->prob * t * t / (cos_l * l->area) : 0.0f;
    }
    if (l->kind == OBJECT_SPHERE) {
        const float3 c = vload3(0, l->corner);
        const float d2 = dot(c - p, c - p);
        const float r2 = l->radius * l->radius;
        return d2 > r2 ? l->prob / (2.0f * M_PI_F * cone_one_minus_cos(r2, d2)) : 0.0f;
    }
    const float cos_l = light_cosine(l, d);
    return cos_l > 0.0f ? l->prob * t * t / (cos_l * l->area) : 0.0f;
}

/* The power heuristic's weight of a strategy of density a against one of density b. */
inline float mis_weight(float a, float b) {
    const float a2 = a * a, b2 = b * b;
    return a2 + b2 > 0.0f ? a2 / (a2 + b2) : 0.0f;
}

/* The weight of emission found by BSDF sampling from p (which sampled the unit direction d with
 * density pdf_bsdf and also sampled a light) at the surface s of hit. */
inline float emission_weight(const Scene* sc, Hit hit, Surface s, float3 p, float pdf_bsdf,
                             float3 d) {
    const int entry = find_light(sc, hit);
    if (entry < 0) {
        return 1.0f;
    }
    return mis_weight(pdf_bsdf, light_pdf(&sc->lights[entry], p, d, length(s.p - p)));
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
inline bool segment_unblocked(const Scene* sc, Surface s, __global const Light* l, float3 q,
                              float3 q_error, float3 q_normal, float3 wi) {
    const float3 o = offset_ray_origin(s.p, s.p_error, s.n, wi);
    const bool triangle = l->kind == OBJECT_MESH;
    if (triangle) {
        q = offset_ray_origin(q, q_error, q_normal, o - q);
    }
    const float3 to = q - o;
    const float dist = length(to);
    if (!(dist > 0.0f)) {
        return true; /* q at the spawned origin: nothing fits between */
    }
    const float3 d = to / dist;
    const float pull = error_gamma(4.0f) * dist + (triangle ? dot(fabs(d), q_error) : 0.0f);
    const float t_max = dist - pull;
    if (!(t_max > 0.0f)) {
        return true; /* within rounding of the surface: nothing fits between */
    }
    const Hit hit = scene_intersect_until(sc, o, d, t_max);
    return hit.kind == HIT_NONE || (!triangle && light_is_hit(l, hit));
}

/* The error bound of a point q = c + offset sampled on a sphere light: the offset's few
 * roundings (at most 5), the sum's, and the list's centre c against the sphere the
 * intersection routines see (the f32 rounding of the same centre, or its double-float):
 * u |c| <= u (|q| + |offset|). Not gamma (|c| + |offset|): far from the device's origin that
 * counts |c| six times. */
inline float3 sphere_sample_error(float3 q, float3 offset) {
    return error_gamma(2.0f) * fabs(q) + error_gamma(6.0f) * fabs(offset);
}

/* Samples light l from p: a direction *wi towards the point *q on it (of rounding-error bound
 * *q_error, geometric normal *q_normal) with the solid-angle density *pdf = light_pdf(l, p,
 * *wi, |q - p|), the chance of picking l included. u.x and u.y place the point. Returns false
 * where l offers p nothing (p inside a sphere, a square seen from behind, a triangle edge-on). */
inline bool light_sample(__global const Light* l, float3 p, float2 u, float3* wi, float3* q,
                         float3* q_error, float3* q_normal, float* pdf) {
    if (l->kind == OBJECT_SPHERE && l->cap_height > 0.0f) {
        /* The visible cap (src/device/lights.rs `visible_cap`), uniformly by area: a sphere's
         * area is uniform in height along any axis (Archimedes), so the depth below the cap's
         * top is cap_height u.x. */
        const float3 c = vload3(0, l->corner), axis = vload3(0, l->normal);
        const float r = l->radius;
        const float below = l->cap_height * u.x;
        const float rho = sqrt(fmax(0.0f, below * (2.0f * r - below)));
        const float phi = 2.0f * M_PI_F * u.y;
        float3 t, b;
        orthonormal_basis(axis, &t, &b);
        const float3 offset = axis * (r - below) + (t * cos(phi) + b * sin(phi)) * rho;
        *q = c + offset;
        *q_error = sphere_sample_error(*q, offset);
        *q_normal = offset / r;
        const float3 to = *q - p;
        const float dist = sqrt(dot(to, to));
        *wi = to / dist;
        /* 0 on the cap's far side, which its near side hides from p. */
        *pdf = light_pdf(l, p, *wi, dist);
        return *pdf > 0.0f;
    }
    if (l->kind == OBJECT_SPHERE) {
        /* Uniformly in the cone the sphere subtends (pbrt-v4 section 6.2.4). */
        const float3 c = vload3(0, l->corner);
        const float3 pc = c - p;
        const float d2 = dot(pc, pc);
        const float r2 = l->radius * l->radius;
        if (d2 <= r2) {
            return false;
        }
        const float v = u.x * cone_one_minus_cos(r2, d2); /* 1 - cos theta */
        const float cos_t = 1.0f - v;
        const float sin_t = sqrt(fmax(0.0f, v * (2.0f - v)));
        const float phi = 2.0f * M_PI_F * u.y;
        const float3 w = pc / sqrt(d2);
        float3 t, b;
        orthonormal_basis(w, &t, &b);
        *wi = normalize(t * (sin_t * cos(phi)) + b * (sin_t * sin(phi)) + w * cos_t);
        /* The nearer point where wi meets the sphere, from the centre's distance to the ray
         * (no cancellation for tiny spheres far away); a direction that rounding put just past
         * the rim takes the tangent point. */
        const float along = dot(pc, *wi);
        const float3 perp = pc - along * *wi;
        const float t_hit = along - sqrt(fmax(0.0f, r2 - dot(perp, perp)));
        const float3 n = normalize(p + *wi * t_hit - c);
        *q = c + n * l->radius;
        *q_error = sphere_sample_error(*q, n * l->radius);
        *q_normal = n;
        *pdf = light_pdf(l, p, *wi, t_hit);
        return true;
    }
    /* Uniform over the square, or over the triangle by folding the square's far half onto it
     * (pbrt-v4 section A.5.5 samples triangles otherwise; this is equally uniform). */
    float a = u.x, b = u.y;
    if (l->kind == OBJECT_MESH && a + b > 1.0f) {
        a = 1.0f - a;
        b = 1.0f - b;
    }
    const float3 corner = vload3(0, l->corner);
    const float3 e1 = vload3(0, l->edge1) * a, e2 = vload3(0, l->edge2) * b;
    *q = corner + e1 + e2;
    /* Rounding of the sum, and of the list's corner and edges against the geometry the
     * intersection routines see (both rounded to f32 from the same f64 values). */
    *q_error = error_gamma(6.0f) * (fabs(corner) + fabs(e1) + fabs(e2));
    *q_normal = vload3(0, l->normal);
    const float3 to = *q - p;
    const float dist = sqrt(dot(to, to));
    *wi = to / dist;
    *pdf = light_pdf(l, p, *wi, dist);
    return *pdf > 0.0f;
}

/* The radiance light l emits towards any point it is sampled from: its material's emission,
 * constant over the light (the host lists only emitters of constant emission). */
inline float3 light_emitted(const Scene* sc, __global const Light* l) {
    return vload3(0, sc->materials[l->material].emission);
}

/* One light sample from the surface s of material `type` and `color` (shading normal ns), for
 * the path arriving from wo: its MIS-weighted contribution f cos Le w / pdf, or 0. Delta
 * materials take none: their f is 0 at every direction a light sample could choose. */
inline float3 sample_light(const Scene* sc, Surface s, uint type, float3 color, float3 wo,
                           float3 ns, float4 u) {
    const uint pick = pick_light(sc, u.x);
    __global const Light* l = &sc->lights[pick];
    float3 wi, q, q_error, q_normal;
    float pdf;
    if (bsdf_is_delta(type) || !light_sample(l, s.p, u.yz, &wi, &q, &q_error, &q_normal, &pdf)) {
        return (float3)(0.0f);
    }
    const float pdf_bsdf = bsdf_pdf(type, wo, wi, s.n, ns);
    if (!(pdf_bsdf > 0.0f && pdf > 0.0f && isfinite(pdf))) {
        return (float3)(0.0f);
    }
    if (!segment_unblocked(sc, s, l, q, q_error, q_normal, wi)) {
        return (float3)(0.0f);
    }
    const float3 f = bsdf_eval(type, color, wo, wi, s.n, ns);
    return f * light_emitted(sc, l) * (mis_weight(pdf, pdf_bsdf) / pdf);
}

#endif
