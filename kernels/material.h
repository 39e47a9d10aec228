/* material.h: how a surface scatters a path (port of material.cuh and the BSDF part of
 * pathtracer.cuh).
 *
 * Reads: one Material. Writes: nothing. Conventions: `wo` points from the surface back along
 * the incoming path, `wi` is the sampled new direction, `n` the outward geometric normal.
 * Every sampler returns the throughput weight f cos / pdf, which for these three materials is
 * the colour: Lambertian with cosine-weighted directions; perfect mirror; glass of index 1.5
 * choosing reflection with probability equal to Schlick's Fresnel reflectance (smallpt's
 * model, kept for the original's look; choosing by Fresnel makes the weight exactly the colour).
 */
#ifndef CLPT_MATERIAL_H
#define CLPT_MATERIAL_H

#include "vecmath.h"

#define GLASS_IOR 1.5f

/* Cosine-weighted direction about unit n (Malley's method: a uniform disk point lifted). */
inline float3 sample_cosine_hemisphere(float3 n, float2 u) {
    const float phi = 2.0f * M_PI_F * u.x;
    const float r = sqrt(u.y);
    float3 t, b;
    orthonormal_basis(n, &t, &b);
    return normalize(t * (r * cos(phi)) + b * (r * sin(phi)) + n * sqrt(fmax(0.0f, 1.0f - u.y)));
}

inline float3 reflect_about(float3 wo, float3 n) {
    return 2.0f * dot(wo, n) * n - wo;
}

/* Samples wi for a path arriving from wo at a surface of `type` with geometric normal n and
 * shading normal ns (n itself, or bent by a bump map); returns the throughput weight.
 * u.xy: direction, u.z: reflect or refract. */
inline float3 material_sample(uint type, float3 color, float3 wo, float3 n, float3 ns, float4 u,
                              float3* wi) {
    const float cos_o = dot(wo, n);
    /* The side the path arrived on (by the geometric normal), and the shading normal turned to
     * it: diffuse and mirror surfaces scatter back to that side. */
    const float3 facing_g = cos_o >= 0.0f ? n : -n;
    const float3 facing = cos_o >= 0.0f ? ns : -ns;
    float3 dir;
    bool transmitted = false;
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
            if (u.z >= fresnel) {
                dir = normalize(-wo * eta + facing * (eta * cos_i - cos_t));
                transmitted = true;
            }
        }
    } else {
        dir = sample_cosine_hemisphere(facing, u.xy);
    }
    /* A bent shading normal can send a reflection below the surface or a transmission back
     * above it: mirror such a direction across the geometric surface, so no path leaks
     * through and no energy is lost. Without a bump map this never happens. */
    const float side = dot(dir, facing_g);
    if (transmitted ? side > 0.0f : side < 0.0f) {
        dir -= 2.0f * side * facing_g;
    }
    *wi = dir;
    return color;
}

#if CLPT_NEE
/* The solid-angle density with which material_sample's diffuse branch returns wi, from the side
 * whose geometric normal is facing_g and shading normal facing: the cosine density about facing,
 * plus that of the direction mirrored into wi across the geometric surface. The branch returns
 * the weight `color`, so its BSDF times cosine is color times this density, whatever the
 * shading normal: light sampling (nee.h) needs both to weigh the two strategies alike. With
 * facing == facing_g the mirrored term is 0 and this is pbrt's cos / pi. */
inline float diffuse_pdf(float3 wi, float3 facing, float3 facing_g) {
    const float side = dot(wi, facing_g);
    if (!(side > 0.0f)) {
        return 0.0f;
    }
    const float3 mirrored = wi - 2.0f * side * facing_g;
    return (fmax(0.0f, dot(wi, facing)) + fmax(0.0f, dot(mirrored, facing))) * M_1_PI_F;
}
#endif

#endif
