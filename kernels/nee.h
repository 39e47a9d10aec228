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
 * room (src/device/lights.rs), whose shading points come right up to them. The mapping costs a
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
    float3 ex, ey;       /* the frame's x and y; z is the light's normal */
    float x0, x1, y0, y1, z0;
    float b0, b1, k;     /* the paper's constants of the mapping, k in units of pi */
    float solid_angle;   /* 0: sample by area */
} SphRect;

/* Rectangle light l seen from p, or solid_angle 0 where it is sampled by area. */
inline SphRect sph_rect(__global const Light* l, float3 p) {
    SphRect r;
    r.solid_angle = 0.0f;
    if (!l->solid_angle) {
        return r;
    }
    const float3 e1 = vload3(0, l->edge1), e2 = vload3(0, l->edge2), n = vload3(0, l->normal);
    const float w = length(e1);
    r.ex = e1 / w;
    r.ey = cross(n, r.ex);
    const float3 d = vload3(0, l->corner) - p;
    r.x0 = dot(d, r.ex);
    r.x1 = r.x0 + w;
    r.y0 = dot(d, r.ey);
    r.y1 = r.y0 + dot(e2, r.ey);
    r.z0 = dot(d, n);
    if (!(r.z0 < 0.0f)) {
        return r; /* p behind the emitter or on its plane: sampled by area, which gives 0 */
    }
    /* The angles in coordinates scaled to at most 1, so that the products below neither
     * overflow nor underflow (angles do not change with scale). */
    const float unit =
        1.0f / fmax(fmax(fmax(fabs(r.x0), fabs(r.x1)), fmax(fabs(r.y0), fabs(r.y1))), -r.z0);
    const float x0 = r.x0 * unit, x1 = r.x1 * unit, y0 = r.y0 * unit, y1 = r.y1 * unit;
    const float z = -r.z0 * unit, z2 = z * z;
    /* Each angle as a complex number (cos, sin) times a positive length, and two angles' sum as
     * their product: two atan2 instead of four. Each angle is in (0, pi) (sin > 0), so each
     * sum is in (0, 2 pi): atan2pi's (-1, 1] plus 2 where it is negative, in units of pi. */
    const float2 a0 = (float2)(y0 * x1, z * sqrt(x1 * x1 + y0 * y0 + z2));
    const float2 a1 = (float2)(-x1 * y1, z * sqrt(x1 * x1 + y1 * y1 + z2));
    const float2 a2 = (float2)(x0 * y1, z * sqrt(x0 * x0 + y1 * y1 + z2));
    const float2 a3 = (float2)(-x0 * y0, z * sqrt(x0 * x0 + y0 * y0 + z2));
    float g01 = atan2pi(a0.x * a1.y + a0.y * a1.x, a0.x * a1.x - a0.y * a1.y);
    float g23 = atan2pi(a2.x * a3.y + a2.y * a3.x, a2.x * a3.x - a2.y * a3.y);
    g01 += g01 < 0.0f ? 2.0f : 0.0f;
    g23 += g23 < 0.0f ? 2.0f : 0.0f;
    r.b0 = -y0 / sqrt(z2 + y0 * y0);
    r.b1 = y1 / sqrt(z2 + y1 * y1);
    r.k = 2.0f - g23;
    const float s = M_PI_F * (g01 - r.k);
    r.solid_angle = s >= SPH_RECT_MIN && s <= SPH_RECT_MAX ? s : 0.0f;
    return r;
}

/* The point (x, y) of rectangle r that uniforms u map to, uniformly in solid angle (the paper's
 * algorithm: x from the area swept by u.x, then y along the great-circle arc at x). Clamps keep
 * rounding inside the rectangle; fmax/fmin also map a NaN (0 / 0 at a measure-zero u) there. */
inline float2 sph_rect_sample(SphRect r, float2 u) {
    const float au = u.x * (r.solid_angle * M_1_PI_F) + r.k;
    const float fu = (cospi(au) * r.b0 - r.b1) / sinpi(au);
    const float cu = fmin(fmax(copysign(rsqrt(fu * fu + r.b0 * r.b0), fu), -1.0f), 1.0f);
    const float x_free = -(cu * r.z0) / sqrt(fmax((1.0f - cu) * (1.0f + cu), FLT_MIN));
    const float x = fmin(fmax(x_free, r.x0), r.x1);
    const float d2 = x * x + r.z0 * r.z0;
    const float h0 = r.y0 * rsqrt(d2 + r.y0 * r.y0), h1 = r.y1 * rsqrt(d2 + r.y1 * r.y1);
    const float h = h0 + u.y * (h1 - h0);
    const float y = h * sqrt(d2) / sqrt(fmax((1.0f - h) * (1.0f + h), FLT_MIN));
    return (float2)(x, fmin(fmax(y, r.y0), r.y1));
}
#endif

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
#if CLPT_PLANES
    if (l->kind == OBJECT_PLANE) {
        const float solid_angle = sph_rect(l, p).solid_angle;
        if (solid_angle > 0.0f) {
            return l->prob / solid_angle;
        }
    }
#endif
    const float cos_l = light_cosine(l, d);
    return cos_l > 0.0f ? l->prob * t * t / (cos_l * l->area) : 0.0f;
}

/* The power heuristic's weight of a strategy of density a against one of density b. */
inline float mis_weight(float a, float b) {
    const float a2 = a * a, b2 = b * b;
    return a2 + b2 > 0.0f ? a2 / (a2 + b2) : 0.0f;
}

/* The weight of emission found by BSDF sampling from p (which sampled the unit direction d with
 * density pdf_bsdf and also sampled a light) at the surface s of hit. The light sample at p
 * picked entry `picked`, whose density from p was `picked_pdf` at every direction (0 where it
 * varies): when the hit is on that entry, light_pdf would compute the same again. */
inline float emission_weight(const Scene* sc, Hit hit, Surface s, float3 p, float pdf_bsdf,
                             float3 d, uint picked, float picked_pdf) {
    const int entry = find_light(sc, hit);
    if (entry < 0) {
        return 1.0f;
    }
    const float pdf_light = (uint)entry == picked && picked_pdf > 0.0f
                                ? picked_pdf
                                : light_pdf(&sc->lights[entry], p, d, length(s.p - p));
    return mis_weight(pdf_bsdf, pdf_light);
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
 * *wi, |q - p|), the chance of picking l included; *uniform says whether that density is the
 * same at every direction of l (a sphere's cone, a rectangle by solid angle). u.x and u.y place
 * the point. Returns false where l offers p nothing (p inside a sphere, a square seen from
 * behind, a triangle edge-on). */
inline bool light_sample(__global const Light* l, float3 p, float2 u, float3* wi, float3* q,
                         float3* q_error, float3* q_normal, float* pdf, bool* uniform) {
    *uniform = false;
    if (l->kind == OBJECT_SPHERE && l->cap_height > 0.0f) {
        /* The visible cap (src/device/lights.rs `visible_cap`), uniformly by area: a sphere's
         * area is uniform in height along any axis (Archimedes), so the depth below the cap's
         * top is cap_height u.x. */
        const float3 c = vload3(0, l->corner), axis = vload3(0, l->normal);
        const float r = l->radius;
        const float below = l->cap_height * u.x;
        const float rho = sqrt(fmax(0.0f, below * (2.0f * r - below)));
        const float2 around = turn(u.y);
        float3 t, b;
        orthonormal_basis(axis, &t, &b);
        const float3 offset = axis * (r - below) + (t * around.x + b * around.y) * rho;
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
        const float2 around = sin_t * turn(u.y);
        const float3 w = pc / sqrt(d2);
        float3 t, b;
        orthonormal_basis(w, &t, &b);
        *wi = normalize(t * around.x + b * around.y + w * cos_t);
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
        *uniform = true;
        return true;
    }
    const float3 corner = vload3(0, l->corner);
#if CLPT_PLANES
    if (l->kind == OBJECT_PLANE) {
        const SphRect r = sph_rect(l, p);
        if (r.solid_angle > 0.0f) {
            const float2 xy = sph_rect_sample(r, u);
            const float3 e1 = r.ex * (xy.x - r.x0), e2 = r.ey * (xy.y - r.y0);
            *q = corner + e1 + e2;
            *q_error = error_gamma(6.0f) * (fabs(corner) + fabs(e1) + fabs(e2));
            *q_normal = vload3(0, l->normal);
            const float3 to = *q - p;
            *wi = to / sqrt(dot(to, to));
            *pdf = l->prob / r.solid_angle;
            *uniform = true;
            return true;
        }
    }
#endif
    /* Uniform over the parallelogram, or over the triangle by folding the square's far half onto
     * it (pbrt-v4 section A.5.5 samples triangles otherwise; this is equally uniform). */
    float a = u.x, b = u.y;
    if (l->kind == OBJECT_MESH && a + b > 1.0f) {
        a = 1.0f - a;
        b = 1.0f - b;
    }
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
 * materials take none: their f is 0 at every direction a light sample could choose. *picked
 * is the entry it picked, *picked_pdf that entry's density where it is the same at every
 * direction, else 0 (emission_weight's, for the BSDF sample's hit). */
inline float3 sample_light(const Scene* sc, Surface s, uint type, float3 color, float3 wo,
                           float3 ns, float4 u, uint* picked, float* picked_pdf) {
    const uint pick = pick_light(sc, u.x);
    __global const Light* l = &sc->lights[pick];
    float3 wi, q, q_error, q_normal;
    float pdf;
    bool uniform;
    *picked = pick;
    *picked_pdf = 0.0f;
    if (bsdf_is_delta(type) ||
        !light_sample(l, s.p, u.yz, &wi, &q, &q_error, &q_normal, &pdf, &uniform)) {
        return (float3)(0.0f);
    }
    *picked_pdf = uniform ? pdf : 0.0f;
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
