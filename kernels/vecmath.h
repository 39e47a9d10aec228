/* vecmath.h: small vector helpers (the original used the course's Vecmath library).
 *
 * Reads: nothing. Writes: nothing.
 */
#ifndef CLPT_VECMATH_H
#define CLPT_VECMATH_H

#include "lanes.h"

/* Three-vectors of lanes, LFloat3 (float3 at width 1), and their arithmetic as functions, since
 * OpenCL C has no operators on structs: at width 1 each is the very expression it names (v3_add(a,
 * b) is a + b), so a routine written on them compiles to what it was on float3. */
#if CLPT_WIDE
typedef struct LFloat3 {
    lfloat x, y, z;
} LFloat3;
inline LFloat3 make_lfloat3(lfloat x, lfloat y, lfloat z) {
    LFloat3 v = {x, y, z};
    return v;
}
/* A value the same in every lane (scene data). */
inline LFloat3 v3_splat(float3 v) {
    return make_lfloat3((lfloat)(v.x), (lfloat)(v.y), (lfloat)(v.z));
}
inline LFloat3 v3_add(LFloat3 a, LFloat3 b) {
    return make_lfloat3(a.x + b.x, a.y + b.y, a.z + b.z);
}
/* a plus s in each coordinate. */
inline LFloat3 v3_add_s(LFloat3 a, lfloat s) {
    return make_lfloat3(a.x + s, a.y + s, a.z + s);
}
inline LFloat3 v3_sub(LFloat3 a, LFloat3 b) {
    return make_lfloat3(a.x - b.x, a.y - b.y, a.z - b.z);
}
inline LFloat3 v3_neg(LFloat3 a) {
    return make_lfloat3(-a.x, -a.y, -a.z);
}
inline LFloat3 v3_mul(LFloat3 a, LFloat3 b) {
    return make_lfloat3(a.x * b.x, a.y * b.y, a.z * b.z);
}
inline LFloat3 v3_scale(lfloat s, LFloat3 a) {
    return make_lfloat3(s * a.x, s * a.y, s * a.z);
}
inline LFloat3 v3_div(LFloat3 a, lfloat s) {
    return make_lfloat3(a.x / s, a.y / s, a.z / s);
}
inline lfloat v3_dot(LFloat3 a, LFloat3 b) {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}
inline LFloat3 v3_cross(LFloat3 a, LFloat3 b) {
    return make_lfloat3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
inline lfloat v3_length(LFloat3 a) {
    return sqrt(v3_dot(a, a));
}
/* Scaled by its largest component first, as the builtin, so that huge and tiny vectors keep
 * their direction. */
inline LFloat3 v3_normalize(LFloat3 a) {
    const LFloat3 b = v3_div(a, fmax(fabs(a.x), fmax(fabs(a.y), fabs(a.z))));
    return v3_div(b, v3_length(b));
}
inline LFloat3 v3_fabs(LFloat3 a) {
    return make_lfloat3(fabs(a.x), fabs(a.y), fabs(a.z));
}
/* Each lane of a where m is false, of b where it is true. */
inline LFloat3 v3_select(LFloat3 a, LFloat3 b, lmask m) {
    return make_lfloat3(select(a.x, b.x, m), select(a.y, b.y, m), select(a.z, b.z, m));
}
/* Lane `lane` of v, and v with that lane set to x. */
inline float3 lane_float3(LFloat3 v, uint lane) {
    return (float3)(lane_float(v.x, lane), lane_float(v.y, lane), lane_float(v.z, lane));
}
inline void lane_set_float3(LFloat3* v, uint lane, float3 x) {
    lane_set_float(&v->x, lane, x.x);
    lane_set_float(&v->y, lane, x.y);
    lane_set_float(&v->z, lane, x.z);
}
#else
typedef float3 LFloat3;
#define make_lfloat3(x, y, z) ((float3)((x), (y), (z)))
#define v3_splat(v) (v)
#define v3_add(a, b) ((a) + (b))
#define v3_add_s(a, s) ((a) + (s))
#define v3_sub(a, b) ((a) - (b))
#define v3_neg(a) (-(a))
#define v3_mul(a, b) ((a) * (b))
#define v3_scale(s, a) ((s) * (a))
#define v3_div(a, s) ((a) / (s))
#define v3_dot(a, b) dot((a), (b))
#define v3_cross(a, b) cross((a), (b))
#define v3_length(a) length(a)
#define v3_normalize(a) normalize(a)
#define v3_fabs(a) fabs(a)
#define v3_select(a, b, m) ((m) ? (b) : (a))
#endif

inline lfloat max_component(LFloat3 v) {
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
inline LFloat2 turn(lfloat u) {
    return make_lfloat2(cospi(2.0f * u), sinpi(2.0f * u));
}

/* An orthonormal basis around unit n without branches on its direction (Duff et al., "Building
 * an orthonormal basis, revisited", JCGT 2017). */
inline void orthonormal_basis(LFloat3 n, LFloat3* t, LFloat3* b) {
    const lfloat sign = copysign((lfloat)(1.0f), n.z);
    const lfloat a = -1.0f / (sign + n.z);
    const lfloat c = n.x * n.y * a;
    *t = make_lfloat3(1.0f + sign * n.x * n.x * a, sign * c, -sign * n.x);
    *b = make_lfloat3(c, sign + n.y * n.y * a, -n.y);
}

#endif
