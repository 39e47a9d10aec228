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

#define GLASS_IOR 1.5f

/* An orthonormal basis around unit n without branches on its direction (Duff et al., "Building
 * an orthonormal basis, revisited", JCGT 2017). */
inline void orthonormal_basis(float3 n, float3* t, float3* b) {
    const float sign = copysign(1.0f, n.z);
    const float a = -1.0f / (sign + n.z);
    const float c = n.x * n.y * a;
    *t = (float3)(1.0f + sign * n.x * n.x * a, sign * c, -sign * n.x);
    *b = (float3)(c, sign + n.y * n.y * a, -n.y);
}

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

/* Samples wi for a path arriving from wo at a surface of `type`; returns the throughput
 * weight. u.xy: direction, u.z: reflect or refract. */
inline float3 material_sample(uint type, float3 color, float3 wo, float3 n, float4 u, float3* wi) {
    const float cos_o = dot(wo, n);
    /* The side the path arrived on: diffuse and mirror surfaces scatter back to it. */
    const float3 facing = cos_o >= 0.0f ? n : -n;
    if (type == MATERIAL_SPECULAR) {
        *wi = reflect_about(wo, facing);
        return color;
    }
    if (type == MATERIAL_REFRACTIVE) {
        const bool entering = cos_o > 0.0f;
        const float eta = entering ? 1.0f / GLASS_IOR : GLASS_IOR; /* eta_i / eta_t */
        const float cos_i = fabs(cos_o);
        const float sin2_t = eta * eta * fmax(0.0f, 1.0f - cos_i * cos_i);
        const float3 reflected = reflect_about(wo, facing);
        if (sin2_t >= 1.0f) {
            *wi = reflected; /* total internal reflection */
            return color;
        }
        const float cos_t = sqrt(1.0f - sin2_t);
        const float3 refracted = normalize(-wo * eta + facing * (eta * cos_i - cos_t));
        /* Schlick with the cosine on the optically thinner side, as smallpt. */
        const float r0 = ((GLASS_IOR - 1.0f) * (GLASS_IOR - 1.0f)) /
                         ((GLASS_IOR + 1.0f) * (GLASS_IOR + 1.0f));
        const float c = 1.0f - (entering ? cos_i : cos_t);
        const float c2 = c * c;
        const float fresnel = r0 + (1.0f - r0) * c2 * c2 * c;
        *wi = u.z < fresnel ? reflected : refracted;
        return color;
    }
    *wi = sample_cosine_hemisphere(facing, u.xy);
    return color;
}

#endif
