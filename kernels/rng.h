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

#include "lanes.h"
#include "sobol.h"

#define PHILOX_M0 0xD2511F53u
#define PHILOX_M1 0xCD9E8D57u
#define PHILOX_W0 0x9E3779B9u
#define PHILOX_W1 0xBB67AE85u

inline LUint4 philox4x32_10(LUint4 ctr, uint2 key) {
    for (int round = 0; round < 10; ++round) {
        if (round > 0) {
            key.x += PHILOX_W0;
            key.y += PHILOX_W1;
        }
        /* Both halves of each product from one 64-bit multiply: PoCL 3.1's mul_hi builds the
         * high word from 16-bit pieces (a fifth of a path's time in smallpt went to this
         * file); NVIDIA's compiler makes the same single wide multiply of either form. */
        const lulong p0 = (ulong)PHILOX_M0 * LANE_CONVERT(ulong, ctr.x);
        const lulong p1 = (ulong)PHILOX_M1 * LANE_CONVERT(ulong, ctr.z);
        const luint hi0 = LANE_CONVERT(uint, p0 >> 32), lo0 = LANE_CONVERT(uint, p0);
        const luint hi1 = LANE_CONVERT(uint, p1 >> 32), lo1 = LANE_CONVERT(uint, p1);
        ctr = make_luint4(hi1 ^ ctr.y ^ key.x, lo1, hi0 ^ ctr.w ^ key.y, lo0);
    }
    return ctr;
}

/* The numbers of one path: (seed, pixel, sample) fixed, `dimension` advancing. The quasi-random
 * blocks are drawn together when the path starts (rng_for_path) and handed out in order: one
 * copy of the Sobol code in a rolled loop, not one per call site inside the path loop. With
 * lanes (lanes.h), each lane holds a sample of its own pixel, and lanes restart apart
 * (rng_restart), so each has its own sample and dimension. */
typedef struct Rng {
    uint2 key;
    luint pixel;
    luint sample;
    luint dimension;
    LUint4 quasi0, quasi1, quasi2; /* blocks dimension .. SOBOL_BLOCKS - 1, next first */
} Rng;

/* The top 24 bits of each word as a float in [0, 1): every value is exact, 1 is never reached. */
inline lfloat rng_to_unit(luint bits) {
    return LANE_CONVERT(float, bits >> 8u) * 0x1.0p-24f;
}

inline LFloat4 rng_to_unit4(LUint4 bits) {
    return make_lfloat4(rng_to_unit(bits.x), rng_to_unit(bits.y), rng_to_unit(bits.z),
                        rng_to_unit(bits.w));
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
inline LUint4 rng_quasi_block(uint2 key, luint pixel, luint sample, uint block) {
    const luint half_index = (sample >> 2) & 1u;
    const luint point = ((sample >> 3) << 2) | (sample & 3u);
    const LUint4 counter = make_luint4((luint)(pixel), (luint)(block), half_index, (luint)(~0u));
    const LUint4 seeds = philox4x32_10(counter, key);
    /* A fifth seed for the fourth coordinate, from the other four (Weyl step, mixing). */
    const luint seed_w = (seeds.x ^ seeds.w) * 0x9E3779B9u + seeds.y;
    return scrambled_sobol4(point, seeds.x, make_luint4(seeds.y, seeds.z, seeds.w, seed_w));
}

/* Lanes m of rng start sample `sample` (every lane at width 1, where m is true): its
 * quasi-random blocks drawn, its dimension 0. */
inline void rng_restart(Rng* rng, lmask m, luint sample) {
    rng->sample = select(rng->sample, sample, m);
    rng->dimension = select(rng->dimension, (luint)(0u), m);
    /* Last block first, each pushed in front of the others: a rolled loop (see sobol4_reversed
     * for why the code is kept small). */
#pragma unroll 1
    for (uint b = SOBOL_BLOCKS; b-- > 0u;) {
        rng->quasi2 = select_luint4(rng->quasi2, rng->quasi1, m);
        rng->quasi1 = select_luint4(rng->quasi1, rng->quasi0, m);
        const LUint4 block = rng_quasi_block(rng->key, rng->pixel, sample, b);
        rng->quasi0 = select_luint4(rng->quasi0, block, m);
    }
}

inline Rng rng_for_path(uint seed_lo, uint seed_hi, luint pixel, luint sample) {
    Rng rng;
    rng.key = (uint2)(seed_lo, seed_hi);
    rng.pixel = pixel;
    const luint zero = rng.sample = rng.dimension = (luint)(0u); /* then every lane restarts */
    rng.quasi2 = rng.quasi1 = rng.quasi0 = make_luint4(zero, zero, zero, zero);
    rng_restart(&rng, LANE_TRUE, sample);
    return rng;
}

/* Four uniform numbers in [0, 1) from each lane's next dimension block. */
inline LFloat4 rng_next4(Rng* rng) {
    const luint block = rng->dimension;
    rng->dimension += 1u;
    const lmask quasi = block < SOBOL_BLOCKS;
    LUint4 bits = rng->quasi0;
    if (lane_any(quasi)) {
        rng->quasi0 = select_luint4(rng->quasi0, rng->quasi1, quasi);
        rng->quasi1 = select_luint4(rng->quasi1, rng->quasi2, quasi);
    }
    if (!lane_all(quasi)) {
        const LUint4 plain = philox4x32_10(
            make_luint4((luint)(rng->pixel), rng->sample, block, (luint)(0u)), rng->key);
        bits = select_luint4(plain, bits, quasi);
    }
    return rng_to_unit4(bits);
}

/* Four uniform numbers for the light sample at vertex `vertex` (0 the first) of each lane's
 * path, from blocks apart from the BSDF's (see the top of this file for why): quasi-random at
 * the first vertex, where light sampling spends most of its samples, Philox numbers later. */
inline LFloat4 rng_light4(const Rng* r, luint vertex) {
    const lmask first = vertex == 0u;
    LUint4 bits = r->quasi0; /* any value: each lane takes one of the two below */
    if (lane_any(first)) {
        bits = rng_quasi_block(r->key, r->pixel, r->sample, 0x80000000u);
    }
    if (!lane_all(first)) {
        const LUint4 plain = philox4x32_10(
            make_luint4((luint)(r->pixel), r->sample, vertex, (luint)(1u)), r->key);
        bits = select_luint4(plain, bits, first);
    }
    return rng_to_unit4(bits);
}

#endif
