/* rng.h: counter-based random numbers (Philox 4x32-10; Salmon et al., "Parallel random numbers:
 * as easy as 1, 2, 3", SC 2011).
 *
 * Reads: nothing. Writes: nothing. Why: every random number is a pure function of
 * (seed, pixel, sample, dimension), so any path can be replayed alone and no generator state
 * lives in memory. The original seeded a per-pixel generator and drew visible patterns; a
 * counter-based generator has no per-pixel state to correlate.
 *
 * Counter = (pixel, sample, dimension block, 0), key = the 64-bit seed. One block gives four
 * 32-bit words; `dimension` counts blocks along the path. tests/rng.rs checks the known-answer
 * vectors of Random123 and the uniformity of what the kernels draw.
 */
#ifndef CLPT_RNG_H
#define CLPT_RNG_H

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
        const uint hi0 = mul_hi(PHILOX_M0, ctr.x);
        const uint lo0 = PHILOX_M0 * ctr.x;
        const uint hi1 = mul_hi(PHILOX_M1, ctr.z);
        const uint lo1 = PHILOX_M1 * ctr.z;
        ctr = (uint4)(hi1 ^ ctr.y ^ key.x, lo1, hi0 ^ ctr.w ^ key.y, lo0);
    }
    return ctr;
}

/* The stream of one path: (seed, pixel, sample) fixed, `dimension` advancing. */
typedef struct Rng {
    uint2 key;
    uint pixel;
    uint sample;
    uint dimension;
} Rng;

inline Rng rng_for_path(uint seed_lo, uint seed_hi, uint pixel, uint sample) {
    Rng rng;
    rng.key = (uint2)(seed_lo, seed_hi);
    rng.pixel = pixel;
    rng.sample = sample;
    rng.dimension = 0u;
    return rng;
}

/* The top 24 bits of a word as a float in [0, 1): every value is exact, 1 is never reached. */
inline float rng_to_unit(uint bits) {
    return (float)(bits >> 8) * 0x1.0p-24f;
}

/* Four uniform numbers in [0, 1) from the next dimension block. */
inline float4 rng_next4(Rng* rng) {
    const uint4 bits =
        philox4x32_10((uint4)(rng->pixel, rng->sample, rng->dimension, 0u), rng->key);
    rng->dimension += 1u;
    return (float4)(rng_to_unit(bits.x), rng_to_unit(bits.y), rng_to_unit(bits.z),
                    rng_to_unit(bits.w));
}

#endif
