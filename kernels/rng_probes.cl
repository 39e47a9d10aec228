/* rng_probes.cl: the random numbers' probes (tests/rng.rs), at any lane width.
 *
 * Reads: the inputs each probe names. Writes: one output record per sample (per work-item at
 * width 1). Why: the numbers are checked against known answers, the Sobol recurrence and
 * statistics at width 1 (-D CLPT_LANES absent), and the program built at each wider width
 * (lanes.h) must draw exactly those numbers in each of its lanes: this small program builds
 * fast at every width, where the probes of everything (probes.cl) would not.
 */
#include "rng.h"

/* Block k of a path's numbers: its k-th BSDF-side block (rng_next4, the camera's first), or
 * with `light` the light sample's at vertex k (rng_light4). */
inline LFloat4 probe_rng_block(Rng* rng, uint light, luint k) {
    return light ? rng_light4(rng, k) : rng_next4(rng);
}

#if !CLPT_WIDE
#define lane_float(v, lane) (v)
#endif

/* Stores lane `lane` of v as out[i]. */
inline void probe_store_lane(LFloat4 v, uint lane, __global float4* out, uint i) {
    out[i] = (float4)(lane_float(v.x, lane), lane_float(v.y, lane), lane_float(v.z, lane),
                      lane_float(v.w, lane));
}

#if !CLPT_WIDE
/* Philox 4x32-10 on given counters and keys (known-answer tests). */
__kernel void probe_philox(__global const uint4* ctr, __global const uint2* key,
                           __global uint4* out) {
    const uint i = get_global_id(0);
    out[i] = philox4x32_10(ctr[i], key[i]);
}

/* The unscrambled Sobol point `index`, from sobol.h's table and loop (only tests need it). */
inline uint4 sobol4(uint index) {
    const uint4 x = sobol4_reversed(reverse_bits32(index));
    return (uint4)(reverse_bits32(x.x), reverse_bits32(x.y), reverse_bits32(x.z),
                   reverse_bits32(x.w));
}

/* The unscrambled Sobol points of the given indices (sobol.h). */
__kernel void probe_sobol(__global const uint* index, __global uint4* out) {
    const uint i = get_global_id(0);
    out[i] = sobol4(index[i]);
}

/* `dims` blocks of the stream of (seed, pixel = work-item, sample). */
__kernel void probe_rng_stream(uint seed_lo, uint seed_hi, uint sample, uint light, uint dims,
                               __global float4* out) {
    const uint pixel = get_global_id(0);
    Rng rng = rng_for_path(seed_lo, seed_hi, pixel, sample);
    for (uint k = 0u; k < dims; ++k) {
        out[pixel * dims + k] = probe_rng_block(&rng, light, k);
    }
}
#endif

/* `dims` blocks of each sample sample_start + s of one pixel, s = work-item * CLPT_LANES +
 * lane, to out[s * dims ...]. Lane l starts its sample at step l % 4 (restarting from another
 * sample's stream), as lanes restart apart in a render, so that a wide program's lanes are
 * checked while they stand at different dimensions: each lane's numbers must still be those
 * of its sample alone. */
__kernel void probe_rng_samples(uint seed_lo, uint seed_hi, uint pixel, uint sample_start,
                                uint light, uint dims, __global float4* out) {
    const uint item = get_global_id(0);
    const luint lane = LANE_INDEX;
    const luint sample = sample_start + item * CLPT_LANES + lane;
    const luint start = lane % 4u;
    Rng rng = rng_for_path(seed_lo, seed_hi, pixel, sample + 1000u);
    for (uint step = 0u; step < dims + 3u; ++step) {
        rng_restart(&rng, start == step, sample);
        const luint k = step - start; /* the block each lane draws (wraps before its start) */
        const LFloat4 v = probe_rng_block(&rng, light, k);
        for (uint l = 0u; l < CLPT_LANES; ++l) {
            const uint kl = step - l % 4u;
            if (step >= l % 4u && kl < dims) {
                probe_store_lane(v, l, out, (item * CLPT_LANES + l) * dims + kl);
            }
        }
    }
}
