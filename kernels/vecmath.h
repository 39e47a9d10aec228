/* vecmath.h: small vector helpers (the original used the course's Vecmath library).
 *
 * Reads: nothing. Writes: nothing.
 */
#ifndef CLPT_VECMATH_H
#define CLPT_VECMATH_H

#include "features.h"

inline float max_component(float3 v) {
    return fmax(v.x, fmax(v.y, v.z));
}

#if CLPT_TEXTURES
/* The fractional part in [0, 1) (x - floor(x) rounds to 1 for tiny negative x), for texture
 * coordinates. */
inline float frac_unit(float x) {
    const float f = x - floor(x);
    return f < 1.0f ? f : 0.0f;
}
#endif

/* (cos 2 pi u, sin 2 pi u): a point of the unit circle at the fraction u of a turn. cospi and
 * sinpi reduce their argument exactly (a turn is an integer), where cos(2 pi u) rounds 2 pi u
 * first and PoCL 3.1 then calls its argument reduction out of line (5% of smallpt's time). */
inline float2 turn(float u) {
    return (float2)(cospi(2.0f * u), sinpi(2.0f * u));
}

/* An orthonormal basis around unit n without branches on its direction (Duff et al., "Building
 * an orthonormal basis, revisited", JCGT 2017). */
inline void orthonormal_basis(float3 n, float3* t, float3* b) {
    const float sign = copysign(1.0f, n.z);
    const float a = -1.0f / (sign + n.z);
    const float c = n.x * n.y * a;
    *t = (float3)(1.0f + sign * n.x * n.x * a, sign * c, -sign * n.x);
    *b = (float3)(c, sign + n.y * n.y * a, -n.y);
}

#endif
