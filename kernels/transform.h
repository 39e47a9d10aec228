/* transform.h: affine transforms of points, vectors, normals and point error bounds (port of
 * transform.cuh).
 *
 * Reads: one Transform (3x4 rows, and the inverse). Writes: nothing. Rays are taken into an
 * object's space by the inverse and NOT renormalised, so t means the same distance along the
 * ray in both spaces (the original renormalised and then compared object-space t with
 * world-space t, and got occlusion wrong). Normals go by the inverse transpose.
 */
#ifndef CLPT_TRANSFORM_H
#define CLPT_TRANSFORM_H

#include "types.h"
#include "vecmath.h"
#include "ray.h"

/* Written on lane vectors (vecmath.h): the matrix is the object's, the same in every lane. At
 * width 1 make_lfloat3 is the (float3) literal and each v3_ operation the float3 expression. */
inline LFloat3 xform_point(__global const float* m, LFloat3 p) {
    return make_lfloat3(m[0] * p.x + m[1] * p.y + m[2] * p.z + m[3],
                        m[4] * p.x + m[5] * p.y + m[6] * p.z + m[7],
                        m[8] * p.x + m[9] * p.y + m[10] * p.z + m[11]);
}

inline LFloat3 xform_vector(__global const float* m, LFloat3 v) {
    return make_lfloat3(m[0] * v.x + m[1] * v.y + m[2] * v.z, m[4] * v.x + m[5] * v.y + m[6] * v.z,
                        m[8] * v.x + m[9] * v.y + m[10] * v.z);
}

/* |M| v: the linear part with absolute entries, for error bounds. */
inline LFloat3 xform_abs(__global const float* m, LFloat3 v) {
    return make_lfloat3(fabs(m[0]) * v.x + fabs(m[1]) * v.y + fabs(m[2]) * v.z,
                        fabs(m[4]) * v.x + fabs(m[5]) * v.y + fabs(m[6]) * v.z,
                        fabs(m[8]) * v.x + fabs(m[9]) * v.y + fabs(m[10]) * v.z);
}

/* A normal: the inverse's transpose applied, normalised. */
inline LFloat3 xform_normal(__global const float* inv, LFloat3 n) {
    return v3_normalize(make_lfloat3(inv[0] * n.x + inv[4] * n.y + inv[8] * n.z,
                                     inv[1] * n.x + inv[5] * n.y + inv[9] * n.z,
                                     inv[2] * n.x + inv[6] * n.y + inv[10] * n.z));
}

/* The error bound of M p given p's bound e: the bound carried through, plus the rounding of
 * the product itself (pbrt-v4 section 6.8.5). */
inline LFloat3 xform_point_error(__global const float* m, LFloat3 p, LFloat3 e) {
    const float g3 = error_gamma(3.0f);
    const float3 t = (float3)(fabs(m[3]), fabs(m[7]), fabs(m[11]));
    return v3_add(v3_scale((lfloat)(1.0f + g3), xform_abs(m, e)),
                  v3_scale((lfloat)(g3), v3_add(xform_abs(m, v3_fabs(p)), v3_splat(t))));
}

#endif
