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

#include "types.h"
#include "vecmath.h"

/* smallpt's tent filter: maps u in [0,1) to [-1, 1) with a triangular density. */
inline lfloat tent(lfloat u) {
    const lfloat r = 2.0f * u;
    return lselect(1.0f - sqrt(2.0f - r), sqrt(r) - 1.0f, r < 1.0f);
}

#if CLPT_THIN_LENS
/* Shirley and Chiu's concentric map of the unit square onto the unit disk: area-preserving and
 * continuous, so stratified lens samples stay stratified. */
inline LFloat2 concentric_disk(lfloat ux, lfloat uy) {
    const lfloat px = 2.0f * ux - 1.0f, py = 2.0f * uy - 1.0f;
    /* The angle in turns: an eighth of a turn times the ratio of the two coordinates. */
    const lmask by_x = fabs(px) > fabs(py);
    const lfloat r = lselect(py, px, by_x);
    const lfloat phi = lselect(0.25f - 0.125f * (px / py), 0.125f * (py / px), by_x);
    const LFloat2 c = turn(phi);
    const lmask centre = px == 0.0f && py == 0.0f;
    return make_lfloat2(lselect(r * c.x, (lfloat)(0.0f), centre), lselect(r * c.y, (lfloat)(0.0f), centre));
}
#endif

/* The primary ray for pixel (px, py) from four uniform numbers: u.xy pick the sub-pixel (u < 1/2
 * the first) and jitter the image point inside it, u.zw pick the lens point. 2u - s is exact
 * in floating point, so the jitter's number stays uniform. */
inline void camera_ray(__global const Camera* cam, luint px, uint py, LFloat4 u, LFloat3* origin,
                       LFloat3* direction) {
    const lfloat sx = lselect((lfloat)(1.0f), (lfloat)(0.0f), u.x < 0.5f);
    const lfloat sy = lselect((lfloat)(1.0f), (lfloat)(0.0f), u.y < 0.5f);
    const lfloat fx =
        (((sx + 0.5f + tent(2.0f * u.x - sx)) * 0.5f + LANE_CONVERT(float, px)) / (float)cam->width) -
        0.5f;
    const lfloat fy =
        (((sy + 0.5f + tent(2.0f * u.y - sy)) * 0.5f + (float)py) / (float)cam->height) - 0.5f;
    const float3 forward = vload3(0, cam->forward);
    const LFloat3 d = v3_add(v3_add(v3_scale(fx, v3_splat(vload3(0, cam->cx))),
                                    v3_scale(fy, v3_splat(vload3(0, cam->cy)))),
                             v3_splat(forward));
    const float3 o = vload3(0, cam->origin);
#if CLPT_THIN_LENS
    if (cam->focus_distance > 0.0f) {
        const LFloat3 focus =
            v3_add(v3_splat(o), v3_scale(cam->focus_distance / v3_dot(d, v3_splat(forward)), d));
        const LFloat2 disk = concentric_disk(u.z, u.w);
        const lfloat lens_x = cam->lens_radius * disk.x, lens_y = cam->lens_radius * disk.y;
        const LFloat3 lens_point =
            v3_add(v3_add(v3_splat(o), v3_scale(lens_x, v3_splat(vload3(0, cam->lens_u)))),
                   v3_scale(lens_y, v3_splat(vload3(0, cam->lens_v))));
        *origin = lens_point;
        *direction = v3_normalize(v3_sub(focus, lens_point));
        return;
    }
#endif
    *origin = v3_splat(o);
    *direction = v3_normalize(d);
}

#endif
