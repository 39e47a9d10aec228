/* nee.h: next-event estimation with multiple importance sampling (Veach 1997, ch. 9; pbrt-v4
 * section 13.4).
 *
 * Reads: the light list (ObjectRef entries the host chose, upload.rs `collect_lights`: spheres
 * and axis-aligned planes of constant emission, untransformed), their spheres, planes and
 * materials. Writes: nothing. Why: a small bright light is found by BSDF sampling only rarely,
 * so pure path tracing converges slowly on it (the original's report says so of its light
 * balls). At every diffuse vertex one light, chosen uniformly, is sampled (a sphere by the cone
 * it subtends, uniformly in solid angle; a plane uniformly over its square) and joined by a
 * shadow ray. Paths that hit a listed light by BSDF sampling after such a vertex weigh its
 * emission by the power heuristic, and light samples the complement, so the two strategies
 * add up to one estimate of the same integral: unbiased, as pure path tracing.
 */
#ifndef CLPT_NEE_H
#define CLPT_NEE_H

/* Whether `hit` is on an object of the light list. A search of the list, so that the host's
 * choice is the only rule. */
inline bool is_listed_light(const Scene* sc, Hit hit) {
    const uint kind = hit.kind == HIT_SPHERE ? OBJECT_SPHERE
                      : hit.kind == HIT_PLANE ? OBJECT_PLANE
                                              : 0xffffffffu;
    for (uint i = 0u; i < sc->params->num_lights; ++i) {
        if (sc->lights[i].kind == kind && sc->lights[i].index == hit.index) {
            return true;
        }
    }
    return false;
}

/* 1 - cos of the half-angle of the cone a sphere of squared radius r2 subtends from squared
 * distance d2 (> r2), without cancelling for small cones: sin^2 / (1 + cos). */
inline float cone_one_minus_cos(float r2, float d2) {
    const float sin2 = r2 / d2;
    return sin2 / (1.0f + sqrt(fmax(0.0f, 1.0f - sin2)));
}

/* The solid-angle density, from p, with which light `ref` would have been sampled in the
 * direction that reaches it at distance t with cosine cos_l at the light (times the choice of
 * the light, 1 / num_lights). 0 where it would not have been (p inside a sphere). */
inline float light_pdf(const Scene* sc, ObjectRef ref, float3 p, float t, float cos_l) {
    const float choose = 1.0f / (float)sc->params->num_lights;
    if (ref.kind == OBJECT_SPHERE) {
        __global const Sphere* s = &sc->spheres[ref.index];
        const float3 c = vload3(0, s->center);
        const float d2 = dot(c - p, c - p);
        const float r2 = s->radius * s->radius;
        if (d2 <= r2) {
            return 0.0f;
        }
        return choose / (2.0f * M_PI_F * cone_one_minus_cos(r2, d2));
    }
    __global const Plane* pl = &sc->planes[ref.index];
    const float area = 4.0f * pl->range * pl->range;
    return cos_l > 0.0f ? choose * t * t / (cos_l * area) : 0.0f;
}

/* The power heuristic's weight of a strategy of density a against one of density b. */
inline float mis_weight(float a, float b) {
    const float a2 = a * a, b2 = b * b;
    return a2 + b2 > 0.0f ? a2 / (a2 + b2) : 0.0f;
}

/* The weight of emission found by BSDF sampling from p (which sampled the direction with
 * density pdf_bsdf and also sampled a light) on hit, at distance t with unit direction d. */
inline float emission_weight(const Scene* sc, Hit hit, Surface s, float3 p, float pdf_bsdf,
                             float3 d) {
    if (!is_listed_light(sc, hit)) {
        return 1.0f;
    }
    ObjectRef ref;
    ref.kind = hit.kind == HIT_SPHERE ? OBJECT_SPHERE : OBJECT_PLANE;
    ref.index = hit.index;
    const float pdf_light = light_pdf(sc, ref, p, length(s.p - p), -dot(s.n, d));
    return mis_weight(pdf_bsdf, pdf_light);
}

/* One light sample from the diffuse surface s (albedo `color`, facing normal `facing`, geometric
 * facing normal `facing_g`): its MIS-weighted contribution f cos Le w / pdf, or 0. */
inline float3 sample_light(const Scene* sc, Surface s, float3 facing, float3 facing_g,
                           float3 color, float4 u) {
    const uint count = sc->params->num_lights;
    const uint pick = min((uint)(u.x * (float)count), count - 1u);
    const ObjectRef ref = sc->lights[pick];
    float3 wi;
    float pdf;
    uint material;
    if (ref.kind == OBJECT_SPHERE) {
        __global const Sphere* sp = &sc->spheres[ref.index];
        const float3 c = vload3(0, sp->center);
        const float d2 = dot(c - s.p, c - s.p);
        const float r2 = sp->radius * sp->radius;
        if (d2 <= r2) {
            return (float3)(0.0f);
        }
        const float one_minus = cone_one_minus_cos(r2, d2);
        const float v = u.y * one_minus; /* 1 - cos theta */
        const float cos_t = 1.0f - v;
        const float sin_t = sqrt(fmax(0.0f, v * (2.0f - v)));
        const float phi = 2.0f * M_PI_F * u.z;
        const float3 w = (c - s.p) / sqrt(d2);
        float3 t, b;
        orthonormal_basis(w, &t, &b);
        wi = normalize(t * (sin_t * cos(phi)) + b * (sin_t * sin(phi)) + w * cos_t);
        pdf = 1.0f / (2.0f * M_PI_F * one_minus * (float)count);
        material = sp->material;
    } else {
        __global const Plane* pl = &sc->planes[ref.index];
        const float3 n = vload3(0, pl->normal);
        /* The square is n * offset + [-range, range] along the two other axes. */
        const float3 a = fabs(n.x) > 0.0f ? (float3)(0.0f, 1.0f, 0.0f) : (float3)(1.0f, 0.0f, 0.0f);
        const float3 b = fabs(n.z) > 0.0f ? (float3)(0.0f, 1.0f, 0.0f) : (float3)(0.0f, 0.0f, 1.0f);
        const float3 q = n * pl->offset + a * ((2.0f * u.y - 1.0f) * pl->range) +
            b * ((2.0f * u.z - 1.0f) * pl->range);
        const float3 to = q - s.p;
        const float dist2 = dot(to, to);
        wi = to / sqrt(dist2);
        const float cos_l = -dot(n, wi);
        if (!(cos_l > 0.0f)) {
            return (float3)(0.0f); /* the plane's back: it emits to the side n points to */
        }
        pdf = dist2 / (cos_l * 4.0f * pl->range * pl->range * (float)count);
        material = pl->material;
    }
    const float cos_s = dot(wi, facing);
    if (!(cos_s > 0.0f && dot(wi, facing_g) > 0.0f && pdf > 0.0f && isfinite(pdf))) {
        return (float3)(0.0f);
    }
    const float3 o = offset_ray_origin(s.p, s.p_error, s.n, wi);
    const Hit h = scene_intersect(sc, o, wi);
    const uint wanted = ref.kind == OBJECT_SPHERE ? HIT_SPHERE : HIT_PLANE;
    if (h.kind != wanted || h.index != ref.index) {
        return (float3)(0.0f); /* blocked */
    }
    const float3 le = vload3(0, sc->materials[material].emission);
    const float pdf_bsdf = cos_s * M_1_PI_F;
    return color * M_1_PI_F * cos_s * le * (mis_weight(pdf, pdf_bsdf) / pdf);
}

#endif
