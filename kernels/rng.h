/* rng.h: the random numbers of a path: a padded, shuffled, Owen-scrambled Sobol sequence per
 * pixel, seeded by a counter-based generator (Philox 4x32-10; Salmon et al., "Parallel random
 * numbers: as easy as 1, 2, 3", SC 2011).
 *
 * Reads: nothing. Writes: nothing. Why: every random number is a pure function of
 * (seed, pixel, sample, dimension), so any path can be replayed alone, any split of the sample
 * range traces the same paths, and no generator state lives in memory.
 *
 * The numbers come in blocks of four (`dimension` counts blocks along the path: the camera's,
 * then one per bounce for the BSDF and roulette). Light samples draw from blocks of their own,
 * one per vertex (rng_light4), so that light sampling on and off trace the very same paths
 * and differ only in what they add along them: the strategy trial (render/strategy.rs)
 * compares the two on the same paths, and reads their ratio of variances with half the noise
 * it had when a light sample shifted every later bounce's numbers (PoCL, the original's case0,
 * case1 and case3 at 96x54, 24 seeds: its spread 0.11 to 0.12, now 0.05 to 0.06; BENCHMARKS.md).
 * Block b < SOBOL_BLOCKS of sample s in pixel p is point j of a four-dimensional Sobol
 * sequence (sobol.h) whose index is shuffled and whose coordinates are Owen-scrambled with
 * seeds that Philox draws from (seed, p, b, half): Burley's "shuffled scrambled Sobol" with
 * padding (JCGT 2020), pbrt-v4's PaddedSobolSampler. Later blocks are Philox numbers of
 * (pixel, s, b) (the counter-based generator alone); the first vertex's light block is a
 * Sobol block too (b = 2^31, which no path's BSDF blocks reach), later vertices' Philox numbers
 * of (pixel, s, vertex, 1).
 * Each number is uniform on [0, 1) and the blocks of one sample independent, so every estimate
 * stays unbiased; within a block a pixel's samples fill the four dimensions evenly, which
 * lowers the error of the camera's and the first bounces' integrals (measured in
 * BENCHMARKS.md, "Quasi-random samples").
 *
 * The error estimate (pathtracer.cl, render/strategy.rs) compares the samples of even and odd
 * groups of four, so those halves are two independent sequences: sample s belongs to half
 * h = (s >> 2) & 1, is point j = (s >> 3) * 4 + (s & 3) of its half, and the scrambling seeds
 * depend on h. The difference of the halves then measures the error of the whole without bias,
 * where halves of one sequence would be negatively correlated and overstate it.
 *
 * tests/rng.rs checks Philox's known answers (Random123), the Sobol table, the net property,
 * uniformity and the independence of pixels, seeds, halves and blocks, the light's included.
 */
#ifndef CLPT_RNG_H
#define CLPT_RNG_H

#include "sobol.h"

#define PHILOX_M0 0xD2511F53u
#define PHILOX_M1 0xCD9E8D57u
#define PHILOX_W0 0x9E3779B9u
#define PHILOX_W1 0xBB67AE85u

inline uint4 philox4x32_10(uint4 ctr, uint2 key) {
    for (int round = 0; round < 10; ++round) {
        if (round > 0) {
            key.x += PHILOX_W0;
            key.y += PHILOX_W1;
        }
        /* Both halves of each product from one 64-bit multiply: PoCL 3.1's mul_hi builds the
         * high word from 16-bit pieces (a fifth of a path's time in smallpt went to this
         * file); NVIDIA's compiler makes the same single wide multiply of either form. */
        const ulong p0 = (ulong)PHILOX_M0 * ctr.x;
        const ulong p1 = (ulong)PHILOX_M1 * ctr.z;
        const uint hi0 = (uint)(p0 >> 32), lo0 = (uint)p0;
        const uint hi1 = (uint)(p1 >> 32), lo1 = (uint)p1;
        ctr = (uint4)(hi1 ^ ctr.y ^ key.x, lo1, hi0 ^ ctr.w ^ key.y, lo0);
    }
    return ctr;
}

/* The numbers of one path: (seed, pixel, sample) fixed, `dimension` advancing. The quasi-random
 * blocks are drawn together when the path starts (rng_for_path) and handed out in order: one
 * copy of the Sobol code in a rolled loop, not one per call site inside the path loop. */
typedef struct Rng {
    uint2 key;
    uint pixel;
    uint sample;
    uint dimension;
    uint4 quasi0, quasi1, quasi2; /* blocks dimension .. SOBOL_BLOCKS - 1, next first */
} Rng;

/* The top 24 bits of each word as a float in [0, 1): every value is exact, 1 is never reached. */
inline float4 rng_to_unit4(uint4 bits) {
    return convert_float4(bits >> 8u) * 0x1.0p-24f;
}

/* Blocks 0 .. SOBOL_BLOCKS - 1 are quasi-random: the camera's and the first two bounces' BSDF
 * blocks (and, apart, the first vertex's light block, rng_light4). Later ones are plain Philox
 * numbers of (pixel, sample, block): on PoCL, 3 quasi-random blocks gave the error of 6 or of
 * all (the variance lies in the pixel footprint and the first bounce) at less cost, 2 left 1.7
 * times the error in a room with light sampling. Rng holds exactly this many (quasi0 ..
 * quasi2). */
#define SOBOL_BLOCKS 3u

/* Quasi-random block `block` of sample `sample` in pixel `pixel`: Philox of the counter
 * (pixel, block, half, ~0) under the seed gives the shuffle and scrambling seeds, the sample
 * the point index. */
inline uint4 rng_quasi_block(uint2 key, uint pixel, uint sample, uint block) {
    const uint half_index = (sample >> 2) & 1u;
    const uint point = ((sample >> 3) << 2) | (sample & 3u);
    const uint4 seeds = philox4x32_10((uint4)(pixel, block, half_index, 0xffffffffu), key);
    /* A fifth seed for the fourth coordinate, from the other four (Weyl step, mixing). */
    const uint seed_w = (seeds.x ^ seeds.w) * 0x9E3779B9u + seeds.y;
    return scrambled_sobol4(point, seeds.x, (uint4)(seeds.y, seeds.z, seeds.w, seed_w));
}

inline Rng rng_for_path(uint seed_lo, uint seed_hi, uint pixel, uint sample) {
    Rng rng;
    rng.key = (uint2)(seed_lo, seed_hi);
    rng.pixel = pixel;
    rng.sample = sample;
    rng.dimension = 0u;
    rng.quasi1 = rng.quasi0 = (uint4)(0u);
    /* Last block first, each pushed in front of the others: a rolled loop (see sobol4_reversed
     * for why the code is kept small). */
#pragma unroll 1
    for (uint b = SOBOL_BLOCKS; b-- > 0u;) {
        rng.quasi2 = rng.quasi1;
        rng.quasi1 = rng.quasi0;
        rng.quasi0 = rng_quasi_block(rng.key, pixel, sample, b);
    }
    return rng;
}

/* Four uniform numbers in [0, 1) from the next dimension block. */
inline float4 rng_next4(Rng* rng) {
    const uint block = rng->dimension++;
    uint4 bits;
    if (block < SOBOL_BLOCKS) {
        bits = rng->quasi0;
        rng->quasi0 = rng->quasi1;
        rng->quasi1 = rng->quasi2;
    } else {
        bits = philox4x32_10((uint4)(rng->pixel, rng->sample, block, 0u), rng->key);
    }
    return rng_to_unit4(bits);
}

/* Four uniform numbers for the light sample at vertex `vertex` (0 the first) of the path, from
 * blocks apart from the BSDF's (see the top of this file for why): quasi-random at the first
 * vertex, where light sampling spends most of its samples, Philox numbers later. */
inline float4 rng_light4(const Rng* r, uint vertex) {
    return rng_to_unit4(vertex ? philox4x32_10((uint4)(r->pixel, r->sample, vertex, 1u), r->key)
                               : rng_quasi_block(r->key, r->pixel, r->sample, 0x80000000u));
}

#endif
