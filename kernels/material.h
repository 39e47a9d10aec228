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

#define GLASS_IOR 1.5f

/* Cosine-weighted direction about unit n (Malley's method: a uniform disk point lifted). */
inline float3 sample_cosine_hemisphere(float3 n, float2 u) {
    const float2 c = sqrt(u.y) * turn(u.x);
    float3 t, b;
    orthonormal_basis(n, &t, &b);
    return normalize(t * c.x + b * c.y + n * sqrt(fmax(0.0f, 1.0f - u.y)));
}

inline float3 reflect_about(float3 wo, float3 n) {
    return 2.0f * dot(wo, n) * n - wo;
}

/* Whether material `type` scatters into a single direction (mirror, glass): a delta lobe. */
inline bool bsdf_is_delta(uint type) {
    return type == MATERIAL_SPECULAR || type == MATERIAL_REFRACTIVE;
}

/* The solid-angle density with which bsdf_sample's diffuse branch returns wi, from the side
 * whose geometric normal is facing_g and shading normal facing: the cosine density about facing,
 * plus that of the direction mirrored into wi across the geometric surface. The branch returns
 * the weight `color`, so its f cos is color times this density, whatever the shading normal.
 * With facing == facing_g the mirrored term is 0 and this is pbrt's cos / pi. */
inline float diffuse_pdf(float3 wi, float3 facing, float3 facing_g) {
    const float side = dot(wi, facing_g);
    if (!(side > 0.0f)) {
        return 0.0f;
    }
    const float3 mirrored = wi - 2.0f * side * facing_g;
    return (fmax(0.0f, dot(wi, facing)) + fmax(0.0f, dot(mirrored, facing))) * M_1_PI_F;
}

#if CLPT_NEE
/* The density and value of a given direction are needed only where light sampling weighs its
 * own samples (nee.h) and by the probes; a program without light sampling leaves them out. */

/* The solid-angle density with which bsdf_sample returns wi for a path arriving from wo: 0 for
 * a delta lobe (no density; bsdf_sample reports the lobe's probability instead). */
inline float bsdf_pdf(uint type, float3 wo, float3 wi, float3 n, float3 ns) {
    if (bsdf_is_delta(type)) {
        return 0.0f;
    }
    /* The side the path arrived on, by the geometric normal; the shading normal turned to it. */
    const bool front = dot(wo, n) >= 0.0f;
    return diffuse_pdf(wi, front ? ns : -ns, front ? n : -n);
}

/* f cos for the pair (wo, wi): 0 for a delta lobe. Diffuse: the colour times bsdf_pdf, since
 * the sampler's weight f cos / pdf is the colour. */
inline float3 bsdf_eval(uint type, float3 color, float3 wo, float3 wi, float3 n, float3 ns) {
    return bsdf_is_delta(type) ? (float3)(0.0f) : color * bsdf_pdf(type, wo, wi, n, ns);
}
#endif

/* Samples wi for a path arriving from wo at a surface of `type`; returns the throughput weight
 * f cos / pdf, sets *pdf to bsdf_pdf(wi) (for a delta lobe: the probability of the lobe taken,
 * 1 for a mirror or total internal reflection, Schlick's F or 1 - F for glass) and *is_delta.
 * u.xy: direction, u.z: reflect or refract. */
inline float3 bsdf_sample(uint type, float3 color, float3 wo, float3 n, float3 ns, float4 u,
                          float3* wi, float* pdf, bool* is_delta) {
    const float cos_o = dot(wo, n);
    /* The side the path arrived on (by the geometric normal), and the shading normal turned to
     * it: diffuse and mirror surfaces scatter back to that side. */
    const float3 facing_g = cos_o >= 0.0f ? n : -n;
    const float3 facing = cos_o >= 0.0f ? ns : -ns;
    float3 dir;
    bool transmitted = false;
    float lobe = 1.0f; /* the probability of the delta lobe taken */
    if (type == MATERIAL_SPECULAR) {
        dir = reflect_about(wo, facing);
    } else if (type == MATERIAL_REFRACTIVE) {
        const bool entering = cos_o > 0.0f;
        const float eta = entering ? 1.0f / GLASS_IOR : GLASS_IOR; /* eta_i / eta_t */
        const float cos_i = fabs(dot(wo, facing));
        const float sin2_t = eta * eta * fmax(0.0f, 1.0f - cos_i * cos_i);
        dir = reflect_about(wo, facing);
        if (sin2_t < 1.0f) { /* else total internal reflection */
            const float cos_t = sqrt(1.0f - sin2_t);
            /* Schlick with the cosine on the optically thinner side, as smallpt. */
            const float r0 = ((GLASS_IOR - 1.0f) * (GLASS_IOR - 1.0f)) /
                             ((GLASS_IOR + 1.0f) * (GLASS_IOR + 1.0f));
            const float c = 1.0f - (entering ? cos_i : cos_t);
            const float c2 = c * c;
            const float fresnel = r0 + (1.0f - r0) * c2 * c2 * c;
            lobe = fresnel;
            if (u.z >= fresnel) {
                dir = normalize(-wo * eta + facing * (eta * cos_i - cos_t));
                transmitted = true;
                lobe = 1.0f - fresnel;
            }
        }
    } else {
        dir = sample_cosine_hemisphere(facing, u.xy);
    }
    /* A bent shading normal can send a reflection below the surface or a transmission back
     * above it: mirror such a direction across the geometric surface, so no path leaks
     * through and no energy is lost (diffuse_pdf counts the mirrored directions). Without a
     * bump map this never happens. */
    const float side = dot(dir, facing_g);
    if (transmitted ? side > 0.0f : side < 0.0f) {
        dir -= 2.0f * side * facing_g;
    }
    *wi = dir;
    *is_delta = bsdf_is_delta(type);
    *pdf = *is_delta ? lobe : diffuse_pdf(dir, facing, facing_g);
    return color;
}

#endif
