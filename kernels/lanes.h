/* lanes.h: the lane types, with which one work-item carries CLPT_LANES paths at once
 * (docs/cpu-lanes.md).
 *
 * Reads: the -D options CLPT_LANES (1, 4, 8 or 16; 1 when absent) and CLPT_WIDE (whether
 * CLPT_LANES > 1, a switch so that a width-1 program carries no text of the wide types; both in
 * features.h). Writes: nothing. Why: PoCL runs each work-item of a kernel with loops inside alone
 * on its core, scalar (examples/pocl_vectorizer.rs), but code written on float8 runs 8 wide
 * as written. A routine written once on these types compiles at width 1 to what it would be on
 * plain scalars (GPUs: a warp already runs 32 work-items in lock step) and at width 8 or 16 to
 * SIMD on a CPU. At width 1 the four-wide types are OpenCL's own float4 and uint4, so code that
 * takes them is unchanged; wider, they are structs of lanes with the same field names.
 *
 * Masks (lmask) are what comparisons of lane values return: 1 or 0 at width 1, all bits set or
 * none wider. Both are true for select() and lane_any(), so masks are combined with & | and !
 * only (never ~, which turns a width-1 true into another true), and a mask true in every lane
 * is LANE_TRUE, not a cast of 1. lselect(a, b, m) is select() of lane values (at width 1 the
 * conditional expression, which a scalar program would have written).
 */
#ifndef CLPT_LANES_H
#define CLPT_LANES_H

#include "features.h"

#if CLPT_WIDE
#if CLPT_LANES != 4 && CLPT_LANES != 8 && CLPT_LANES != 16
#error "CLPT_LANES must be 4, 8 or 16 in a wide program"
#endif
#define LANE_PASTE_(a, b) a##b
#define LANE_PASTE(a, b) LANE_PASTE_(a, b)
/* The lane type of scalar type t (float -> float8 at width 8), and its conversion. */
#define LANE_TYPE(t) LANE_PASTE(t, CLPT_LANES)
#define LANE_CONVERT(t, x) LANE_PASTE(convert_, LANE_TYPE(t))(x)
typedef LANE_TYPE(float) lfloat;
typedef LANE_TYPE(uint) luint;
typedef LANE_TYPE(ulong) lulong;
typedef LANE_TYPE(int) lmask;
typedef LANE_TYPE(int) lint;
typedef struct LFloat2 {
    lfloat x, y;
} LFloat2;
typedef struct LFloat4 {
    lfloat x, y, z, w;
} LFloat4;
typedef struct LUint4 {
    luint x, y, z, w;
} LUint4;
inline LFloat2 make_lfloat2(lfloat x, lfloat y) {
    LFloat2 v = {x, y};
    return v;
}
inline LFloat4 make_lfloat4(lfloat x, lfloat y, lfloat z, lfloat w) {
    LFloat4 v = {x, y, z, w};
    return v;
}
inline LUint4 make_luint4(luint x, luint y, luint z, luint w) {
    LUint4 v = {x, y, z, w};
    return v;
}
/* Each field of a where m is false, of b where it is true. */
inline LUint4 select_luint4(LUint4 a, LUint4 b, lmask m) {
    return make_luint4(select(a.x, b.x, m), select(a.y, b.y, m), select(a.z, b.z, m),
                       select(a.w, b.w, m));
}
#define lselect(a, b, m) select((a), (b), (m))
/* Lane `lane` of v, and v with that lane set to x. */
inline uint lane_uint(luint v, uint lane) {
    return ((const uint*)&v)[lane];
}
inline float lane_float(lfloat v, uint lane) {
    return ((const float*)&v)[lane];
}
inline void lane_set_float(lfloat* v, uint lane, float x) {
    ((float*)v)[lane] = x;
}
inline void lane_set_uint(luint* v, uint lane, uint x) {
    ((uint*)v)[lane] = x;
}
/* Whether lane `lane` of m is true, and the lanes where m is true. */
inline bool lane_on(lmask m, uint lane) {
    return ((const int*)&m)[lane] != 0;
}
inline uint popcount_mask(lmask m) {
    uint n = 0u;
    for (uint l = 0u; l < CLPT_LANES; ++l) {
        n += lane_on(m, l);
    }
    return n;
}
/* The first lane where m is true (m true somewhere). */
inline uint lane_first(lmask m) {
    uint lane = 0u;
    while (!lane_on(m, lane)) {
        ++lane;
    }
    return lane;
}
/* Whether any (all) lanes of a mask are true: masks are all bits or none, so an OR (AND) of
 * its 64-bit halves folded down to one word tells; PoCL's any() and all() test the lanes one
 * by one, about 15 instructions, and a bounce asks a dozen times. */
#if CLPT_LANES == 4
#define LANE_FOLD(op, m) \
    ({ const ulong2 f2_ = as_ulong2(m); f2_.x op f2_.y; })
#elif CLPT_LANES == 8
#define LANE_FOLD(op, m) \
    ({ const ulong4 f4_ = as_ulong4(m); const ulong2 f2_ = f4_.lo op f4_.hi; f2_.x op f2_.y; })
#else
#define LANE_FOLD(op, m)                                                                      \
    ({ const ulong8 f8_ = as_ulong8(m); const ulong4 f4_ = f8_.lo op f8_.hi;                  \
       const ulong2 f2_ = f4_.lo op f4_.hi; f2_.x op f2_.y; })
#endif
#define lane_any(m) (LANE_FOLD(|, (m)) != 0ul)
#define lane_all(m) (LANE_FOLD(&, (m)) == ~0ul)
#define LANE_TRUE ((lmask)(-1))
#if CLPT_LANES == 4
#define LANE_INDEX ((uint4)(0u, 1u, 2u, 3u))
#elif CLPT_LANES == 8
#define LANE_INDEX ((uint8)(0u, 1u, 2u, 3u, 4u, 5u, 6u, 7u))
#else
#define LANE_INDEX ((uint16)(0u, 1u, 2u, 3u, 4u, 5u, 6u, 7u, 8u, 9u, 10u, 11u, 12u, 13u, 14u, 15u))
#endif
#else
/* One lane: plain scalars, and OpenCL's own four-wide types. */
#define LANE_CONVERT(t, x) convert_##t(x)
typedef float lfloat;
typedef uint luint;
typedef ulong lulong;
typedef int lmask;
typedef int lint;
typedef float2 LFloat2;
typedef float4 LFloat4;
typedef uint4 LUint4;
#define make_lfloat2(x, y) ((float2)((x), (y)))
#define make_lfloat4(x, y, z, w) ((float4)((x), (y), (z), (w)))
#define make_luint4(x, y, z, w) ((uint4)((x), (y), (z), (w)))
#define select_luint4(a, b, m) ((m) ? (b) : (a))
#define lselect(a, b, m) ((m) ? (b) : (a))
#define lane_any(m) ((m) != 0)
#define lane_all(m) ((m) != 0)
#define LANE_TRUE 1
#define LANE_INDEX 0u
#endif

#endif
