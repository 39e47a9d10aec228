/* material.h: how a surface scatters a path, as one trio per material type (pbrt-v4's BxDF
 * interface, section 9.1: Sample_f, f, PDF): bsdf_sample, bsdf_eval, bsdf_pdf (port of
 * material.cuh and the BSDF part of pathtracer.cuh).
 *
 * Reads: a material's type and colour and the local frame. Writes: nothing. Conventions: `wo`
 * points from the surface back along the incoming path, `wi` is the new direction, `n` the
 * outward geometric normal and `ns` the shading normal (n itself, or bent by a bump map or a
 * smooth mesh). "f cos" below is the BSDF times |cos| of wi, the factor a path's throughput
 * takes. Why a trio: path tracing needs only the sampler, but light sampling (nee.h) joins a
 * vertex to a point it did not choose, so it needs f cos there (bsdf_eval) and the density with
 * which the sampler would have found that direction (bsdf_pdf, for the MIS weight); the three
 * must describe one distribution, which tests/material.rs checks with the chi-square harness
 * of tests/common/chi2.rs.
 *
 * The three materials: Lambertian with cosine-weighted directions; perfect mirror; glass of
 * index 1.5 choosing reflection with probability equal to Schlick's Fresnel reflectance
 * (smallpt's model, kept for the original's look; choosing by Fresnel makes the weight exactly
 * the colour). Mirror and glass are delta lobes: bsdf_eval and bsdf_pdf are 0 for them (no other
 * strategy can find their one direction), and light sampling skips them.
 */
#ifndef CLPT_MATERIAL_H
#define CLPT_MATERIAL_H

#include "vecmath.h"
#include "types.h"

#define GLASS_IOR 1.5f

/* Cosine-weighted direction about unit n (Malley's method: a uniform disk point lifted). */
inline LFloat3 sample_cosine_hemisphere(LFloat3 n, lfloat ux, lfloat uy) {
    const LFloat2 around = turn(ux);
    const lfloat radius = sqrt(uy);
    LFloat3 t, b;
    orthonormal_basis(n, &t, &b);
    return v3_normalize(v3_add(v3_add(v3_scale(radius * around.x, t), v3_scale(radius * around.y, b)),
                               v3_scale(sqrt(fmax(0.0f, 1.0f - uy)), n)));
}

inline LFloat3 reflect_about(LFloat3 wo, LFloat3 n) {
    return v3_sub(v3_scale(2.0f * v3_dot(wo, n), n), wo);
}

/* Whether material `type` scatters into a single direction (mirror, glass): a delta lobe. */
inline lmask bsdf_is_delta(luint type) {
    return type == MATERIAL_SPECULAR || type == MATERIAL_REFRACTIVE;
}

/* The solid-angle density with which bsdf_sample's diffuse branch returns wi, from the side
 * whose geometric normal is facing_g and shading normal facing: the cosine density about facing,
 * plus that of the direction mirrored into wi across the geometric surface. The branch returns
 * the weight `color`, so its f cos is color times this density, whatever the shading normal.
 * With facing == facing_g the mirrored term is 0 and this is pbrt's cos / pi. */
inline lfloat diffuse_pdf(LFloat3 wi, LFloat3 facing, LFloat3 facing_g) {
    const lfloat side = v3_dot(wi, facing_g);
    const LFloat3 mirrored = v3_sub(wi, v3_scale(2.0f * side, facing_g));
    return lselect((lfloat)(0.0f),
                   (fmax(0.0f, v3_dot(wi, facing)) + fmax(0.0f, v3_dot(mirrored, facing))) * M_1_PI_F,
                   side > 0.0f);
}

#if CLPT_NEE
/* The density and value of a given direction are needed only where light sampling weighs its
 * own samples (nee.h) and by the probes; a program without light sampling leaves them out. */

/* The solid-angle density with which bsdf_sample returns wi for a path arriving from wo: 0 for
 * a delta lobe (no density; bsdf_sample reports the lobe's probability instead). */
inline lfloat bsdf_pdf(luint type, LFloat3 wo, LFloat3 wi, LFloat3 n, LFloat3 ns) {
    /* The side the path arrived on, by the geometric normal; the shading normal turned to it. */
    const lmask front = v3_dot(wo, n) >= 0.0f;
    return lselect(diffuse_pdf(wi, v3_select(v3_neg(ns), ns, front), v3_select(v3_neg(n), n, front)),
                   (lfloat)(0.0f), bsdf_is_delta(type));
}

/* f cos for the pair (wo, wi): 0 for a delta lobe. Diffuse: the colour times bsdf_pdf, since
 * the sampler's weight f cos / pdf is the colour. */
inline LFloat3 bsdf_eval(luint type, LFloat3 color, LFloat3 wo, LFloat3 wi, LFloat3 n, LFloat3 ns) {
    return v3_select(v3_scale(bsdf_pdf(type, wo, wi, n, ns), color), v3_splat((float3)(0.0f)),
                     bsdf_is_delta(type));
}
#endif

/* Samples wi for a path arriving from wo at a surface of `type`; returns the throughput weight
 * f cos / pdf, sets *pdf to bsdf_pdf(wi) (for a delta lobe: the probability of the lobe taken,
 * 1 for a mirror or total internal reflection, Schlick's F or 1 - F for glass) and *is_delta.
 * u.xy: direction, u.z: reflect or refract. */
inline LFloat3 bsdf_sample(luint type, LFloat3 color, LFloat3 wo, LFloat3 n, LFloat3 ns, LFloat4 u,
                           LFloat3* wi, lfloat* pdf, lmask* is_delta) {
    const lfloat cos_o = v3_dot(wo, n);
    /* The side the path arrived on (by the geometric normal), and the shading normal turned to
     * it: diffuse and mirror surfaces scatter back to that side. */
    const LFloat3 facing_g = v3_select(v3_neg(n), n, cos_o >= 0.0f);
    const LFloat3 facing = v3_select(v3_neg(ns), ns, cos_o >= 0.0f);
    const lmask glass = type == MATERIAL_REFRACTIVE;
    *is_delta = bsdf_is_delta(type);
    LFloat3 dir = facing; /* each lane takes its lobe's below */
    lmask transmitted = !LANE_TRUE;
    lfloat lobe = 1.0f; /* the probability of the delta lobe taken */
    if (lane_any(*is_delta)) {
        dir = v3_select(dir, reflect_about(wo, facing), *is_delta);
    }
    if (lane_any(glass)) {
        const lmask entering = cos_o > 0.0f;
        const lfloat eta = lselect((lfloat)(GLASS_IOR), (lfloat)(1.0f / GLASS_IOR), entering); /* eta_i / eta_t */
        const lfloat cos_i = fabs(v3_dot(wo, facing));
        const lfloat sin2_t = eta * eta * fmax(0.0f, 1.0f - cos_i * cos_i);
        const lmask passes = glass && sin2_t < 1.0f; /* else total internal reflection */
        const lfloat cos_t = sqrt(1.0f - sin2_t);
        /* Schlick with the cosine on the optically thinner side, as smallpt. */
        const float r0 = ((GLASS_IOR - 1.0f) * (GLASS_IOR - 1.0f)) /
                         ((GLASS_IOR + 1.0f) * (GLASS_IOR + 1.0f));
        const lfloat c = 1.0f - lselect(cos_t, cos_i, entering);
        const lfloat c2 = c * c;
        const lfloat fresnel = r0 + (1.0f - r0) * c2 * c2 * c;
        lobe = lselect(lobe, fresnel, passes);
        transmitted = passes && u.z >= fresnel;
        if (lane_any(transmitted)) {
            const LFloat3 refracted = v3_normalize(
                v3_add(v3_scale(-eta, wo), v3_scale(eta * cos_i - cos_t, facing)));
            dir = v3_select(dir, refracted, transmitted);
            lobe = lselect(lobe, 1.0f - fresnel, transmitted);
        }
    }
    if (!lane_all(*is_delta)) {
        dir = v3_select(sample_cosine_hemisphere(facing, u.x, u.y), dir, *is_delta);
    }
    /* A bent shading normal can send a reflection below the surface or a transmission back
     * above it: mirror such a direction across the geometric surface, so no path leaks
     * through and no energy is lost (diffuse_pdf counts the mirrored directions). Without a
     * bump map this never happens. */
    const lfloat side = v3_dot(dir, facing_g);
    const lmask flip = lselect(side < 0.0f, side > 0.0f, transmitted);
    if (lane_any(flip)) {
        dir = v3_select(dir, v3_sub(dir, v3_scale(2.0f * side, facing_g)), flip);
    }
    *wi = dir;
    *pdf = lselect(diffuse_pdf(dir, facing, facing_g), lobe, *is_delta);
    return color;
}

#endif
