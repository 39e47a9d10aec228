/* sobol.h: the first four dimensions of the Sobol sequence, and Owen scrambling by hash.
 *
 * Reads: nothing. Writes: nothing. Why: a randomized quasi-Monte Carlo point set spreads a
 * pixel's samples evenly over each block of four random dimensions (the camera's, and each
 * bounce's), so the estimate of every smooth part of the integrand converges faster than with
 * independent numbers while each point stays uniformly distributed (unbiased). rng.h builds the
 * per-path stream from these pieces; tests/rng.rs checks the table against the recurrence and
 * the net property of what the kernels draw.
 *
 * The generator matrices of dimensions 1 to 4: dimension 1 is van der Corput's radical
 * inverse, dimensions 2 to 4 follow from the primitive polynomials and initial direction
 * numbers of Joe and Kuo ("Constructing Sobol sequences with better two-dimensional
 * projections", SIAM J. Sci. Comput. 30, 2008; new-joe-kuo-6.21201: s = 1, 2, 3; a = 0, 1, 1;
 * m = (1), (1, 3), (1, 3, 1)) by the Bratley-Fox recurrence. Dimensions 1 and 2 form a
 * (0, 2)-sequence: every 2^m consecutive aligned points put one point in each elementary box
 * of area 2^-m. The table is kept bit-reversed (SOBOL_MATRIX_REVERSED[p] = the column of index
 * bit 31 - p, its bits reversed), because scrambling works on reversed bits: an index that
 * comes reversed out of the shuffle gives the reversed point, and the scramble of each
 * coordinate starts from it, so a block costs five bit reversals instead of ten.
 *
 * Scrambling: Owen's nested uniform scrambling in base 2 (each digit flipped by a
 * random function of the digits above it), approximated by the Laine-Karras hash on the
 * bit-reversed value as in Burley, "Practical Hash-based Owen Scrambling", JCGT 9(4), 2020.
 * Applied to a coordinate it keeps the net property and makes the point uniform on [0, 1);
 * applied to an index it shuffles the sequence, mapping each aligned block of 2^m indices onto
 * another (so padded blocks of dimensions are decorrelated without losing their nets).
 */
#ifndef CLPT_SOBOL_H
#define CLPT_SOBOL_H

#include "lanes.h"

__constant uint4 SOBOL_MATRIX_REVERSED[32] = {
    (uint4)(0x80000000u, 0xffffffffu, 0xaaaa00a3u, 0xc900a00au),
    (uint4)(0x40000000u, 0x55555555u, 0x77770071u, 0x45004004u),
    (uint4)(0x20000000u, 0x33333333u, 0x3939003au, 0x2e003003u),
    (uint4)(0x10000000u, 0x11111111u, 0x16160017u, 0x1f001001u),
    (uint4)(0x08000000u, 0x0f0f0f0fu, 0x09a30009u, 0x0a000b6du),
    (uint4)(0x04000000u, 0x05050505u, 0x06710006u, 0x0400079eu),
    (uint4)(0x02000000u, 0x03030303u, 0x033a0003u, 0x030002a7u),
    (uint4)(0x01000000u, 0x01010101u, 0x01170001u, 0x0100011au),
    (uint4)(0x00800000u, 0x00ff00ffu, 0x00a3aaaau, 0x00b6dba4u),
    (uint4)(0x00400000u, 0x00550055u, 0x00717777u, 0x0079e7dbu),
    (uint4)(0x00200000u, 0x00330033u, 0x003a3939u, 0x002a7289u),
    (uint4)(0x00100000u, 0x00110011u, 0x00171616u, 0x0011a105u),
    (uint4)(0x00080000u, 0x000f000fu, 0x000909a3u, 0x000c9baeu),
    (uint4)(0x00040000u, 0x00050005u, 0x00060671u, 0x000457dfu),
    (uint4)(0x00020000u, 0x00030003u, 0x0003033au, 0x0002e28au),
    (uint4)(0x00010000u, 0x00010001u, 0x00010117u, 0x0001f104u),
    (uint4)(0x00008000u, 0x0000ffffu, 0x0000aa09u, 0x0000a0c3u),
    (uint4)(0x00004000u, 0x00005555u, 0x00007706u, 0x00004041u),
    (uint4)(0x00002000u, 0x00003333u, 0x00003903u, 0x0000302du),
    (uint4)(0x00001000u, 0x00001111u, 0x00001601u, 0x0000101eu),
    (uint4)(0x00000800u, 0x00000f0fu, 0x000009aau, 0x00000b67u),
    (uint4)(0x00000400u, 0x00000505u, 0x00000677u, 0x0000079au),
    (uint4)(0x00000200u, 0x00000303u, 0x00000339u, 0x000002a4u),
    (uint4)(0x00000100u, 0x00000101u, 0x00000116u, 0x0000011bu),
    (uint4)(0x00000080u, 0x000000ffu, 0x000000a3u, 0x000000c9u),
    (uint4)(0x00000040u, 0x00000055u, 0x00000071u, 0x00000045u),
    (uint4)(0x00000020u, 0x00000033u, 0x0000003au, 0x0000002eu),
    (uint4)(0x00000010u, 0x00000011u, 0x00000017u, 0x0000001fu),
    (uint4)(0x00000008u, 0x0000000fu, 0x00000009u, 0x0000000au),
    (uint4)(0x00000004u, 0x00000005u, 0x00000006u, 0x00000004u),
    (uint4)(0x00000002u, 0x00000003u, 0x00000003u, 0x00000003u),
    (uint4)(0x00000001u, 0x00000001u, 0x00000001u, 0x00000001u)};

inline luint reverse_bits32(luint x) {
    x = (x << 16) | (x >> 16);
    x = ((x & 0x00ff00ffu) << 8) | ((x >> 8) & 0x00ff00ffu);
    x = ((x & 0x0f0f0f0fu) << 4) | ((x >> 4) & 0x0f0f0f0fu);
    x = ((x & 0x33333333u) << 2) | ((x >> 2) & 0x33333333u);
    return ((x & 0x55555555u) << 1) | ((x >> 1) & 0x55555555u);
}

/* Burley (2020), section 3: the Laine-Karras permutation, where each output bit depends only on
 * the input bits below it; on reversed bits, each digit depends on the digits above it. */
inline luint laine_karras(luint x, luint seed) {
    x += seed;
    x ^= x * 0x6c50b47cu;
    x ^= x * 0xb82f1e52u;
    x ^= x * 0xc7afe638u;
    x ^= x * 0x8d22f6e6u;
    return x;
}

/* The Sobol point whose index has the bits of `index_reversed` reversed, its coordinates
 * reversed too. A fixed 32 steps without branches, so work-items stay together, and kept a
 * loop: unrolled, its 32 x 4 constants made the path loop's code 900 instructions longer, and
 * that code size, not the arithmetic, is what cost time on the H200 (BENCHMARKS.md, "What the
 * quasi-random numbers cost"). */
inline LUint4 sobol4_reversed(luint index_reversed) {
    LUint4 x = make_luint4((luint)(0u), (luint)(0u), (luint)(0u), (luint)(0u));
#pragma unroll 1
    for (uint p = 0u; p < 32u; ++p) {
        const luint bit = 0u - ((index_reversed >> p) & 1u);
        const uint4 c = SOBOL_MATRIX_REVERSED[p];
        x = make_luint4(x.x ^ (c.x & bit), x.y ^ (c.y & bit), x.z ^ (c.z & bit), x.w ^ (c.w & bit));
    }
    return x;
}

/* Point j of the sequence shuffled by `shuffle`, each coordinate Owen-scrambled by its seed. */
inline LUint4 scrambled_sobol4(luint j, luint shuffle, LUint4 seeds) {
    const LUint4 x = sobol4_reversed(laine_karras(reverse_bits32(j), shuffle));
    return make_luint4(reverse_bits32(laine_karras(x.x, seeds.x)),
                       reverse_bits32(laine_karras(x.y, seeds.y)),
                       reverse_bits32(laine_karras(x.z, seeds.z)),
                       reverse_bits32(laine_karras(x.w, seeds.w)));
}

#endif
