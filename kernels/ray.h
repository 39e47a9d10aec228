/* ray.h: rounding-error bounds and robust spawning of rays from surfaces.
 *
 * Reads: nothing. Writes: nothing. Why: a fixed epsilon cannot serve smallpt's walls (spheres of
 * radius 1e5, where f32 has a spacing of 0.008) and its small spheres at once. Each intersection
 * routine refines its hit point and bounds the point's error per component; a new ray starts
 * that bound away from the surface, on the side it leaves to, rounded away once more
 * (pbrt-v4, section 6.8.6 "Robust spawned ray origins"; Ray Tracing Gems, chapter 6).
 */
#ifndef CLPT_RAY_H
#define CLPT_RAY_H

/* gamma(n) = n u / (1 - n u), u = 2^-24: the bound on the relative error of n chained f32
 * operations (Higham; pbrt-v4 section 6.8.1). */
inline float error_gamma(float n) {
    const float u = 0x1.0p-24f;
    return (n * u) / (1.0f - n * u);
}

/* The spawn point for leaving p (error bound p_error, geometric normal n) in direction w. */
inline float3 offset_ray_origin(float3 p, float3 p_error, float3 n, float3 w) {
    const float dist = dot(fabs(n), p_error);
    float3 offset = dist * n;
    if (dot(w, n) < 0.0f) {
        offset = -offset;
    }
    float3 po = p + offset;
    /* Round away from p, so rounding the sum cannot pull po back inside the error box. */
    po.x = offset.x > 0.0f ? nextafter(po.x, INFINITY) : (offset.x < 0.0f ? nextafter(po.x, -INFINITY) : po.x);
    po.y = offset.y > 0.0f ? nextafter(po.y, INFINITY) : (offset.y < 0.0f ? nextafter(po.y, -INFINITY) : po.y);
    po.z = offset.z > 0.0f ? nextafter(po.z, INFINITY) : (offset.z < 0.0f ? nextafter(po.z, -INFINITY) : po.z);
    return po;
}

#endif
