/* camera.h: primary rays (port of camera.cuh's getRay).
 *
 * Reads: the Camera struct. Writes: nothing. Why: the original's scene files must frame the
 * same picture, so the image plane is smallpt's: cx = (w*a/h, 0, 0), cy = normalize(cx x d)*a,
 * and the ray through (x, y) is cx*(x/w - 1/2) + cy*(y/h - 1/2) + d, y = 0 the bottom row.
 * Each pixel is split 2x2 and a tent filter of width one sub-pixel jitters inside the sub-pixel
 * (smallpt's filter, as main.cu's renderPixel). The original picked the sub-pixel by the sample
 * index; here the top bit of each of u.x and u.y picks it and the rest jitters, so the filter is
 * the same and a quasi-random u (rng.h) spreads over the sub-pixels as well as within them.
 *
 * Thin lens (focus_distance > 0): the lens is a disk of radius lens_radius (the original's
 * `aperture`) spanned by lens_u, lens_v; every ray through the lens meets the ray through its
 * centre on the plane at distance focus_distance along forward. The original sampled a square
 * of half-size `aperture` and focused on a sphere of radius `flength` around the camera;
 * see README "Camera".
 */
#ifndef CLPT_CAMERA_H
#define CLPT_CAMERA_H

/* smallpt's tent filter: maps u in [0,1) to [-1, 1) with a triangular density. */
inline float tent(float u) {
    const float r = 2.0f * u;
    return r < 1.0f ? sqrt(r) - 1.0f : 1.0f - sqrt(2.0f - r);
}

#if CLPT_THIN_LENS
/* Shirley and Chiu's concentric map of the unit square onto the unit disk: area-preserving and
 * continuous, so stratified lens samples stay stratified. */
inline float2 concentric_disk(float2 u) {
    const float2 p = 2.0f * u - 1.0f;
    if (p.x == 0.0f && p.y == 0.0f) {
        return (float2)(0.0f, 0.0f);
    }
    /* The angle in turns: an eighth of a turn times the ratio of the two coordinates. */
    float r, phi;
    if (fabs(p.x) > fabs(p.y)) {
        r = p.x;
        phi = 0.125f * (p.y / p.x);
    } else {
        r = p.y;
        phi = 0.25f - 0.125f * (p.x / p.y);
    }
    return r * turn(phi);
}
#endif

/* The primary ray for pixel (px, py) from four uniform numbers: u.xy pick the sub-pixel (u < 1/2
 * the first) and jitter the image point inside it, u.zw pick the lens point. 2u - s is exact
 * in floating point, so the jitter's number stays uniform. */
inline void camera_ray(__global const Camera* cam, uint px, uint py, float4 u, float3* origin,
                       float3* direction) {
    const float sx = u.x < 0.5f ? 0.0f : 1.0f;
    const float sy = u.y < 0.5f ? 0.0f : 1.0f;
    const float fx =
        (((sx + 0.5f + tent(2.0f * u.x - sx)) * 0.5f + (float)px) / (float)cam->width) - 0.5f;
    const float fy =
        (((sy + 0.5f + tent(2.0f * u.y - sy)) * 0.5f + (float)py) / (float)cam->height) - 0.5f;
    const float3 forward = vload3(0, cam->forward);
    const float3 d = vload3(0, cam->cx) * fx + vload3(0, cam->cy) * fy + forward;
    const float3 o = vload3(0, cam->origin);
#if CLPT_THIN_LENS
    if (cam->focus_distance > 0.0f) {
        const float3 focus = o + d * (cam->focus_distance / dot(d, forward));
        const float2 lens = cam->lens_radius * concentric_disk(u.zw);
        const float3 lens_point =
            o + vload3(0, cam->lens_u) * lens.x + vload3(0, cam->lens_v) * lens.y;
        *origin = lens_point;
        *direction = normalize(focus - lens_point);
        return;
    }
#endif
    *origin = o;
    *direction = normalize(d);
}

#endif
