/* trial.cl: the strategy trial's statistics (render/strategy.rs, `choose`), on the device.
 *
 * Reads: the film's `sum` and `sum_odd` on a round's trial rows, after each candidate rendered
 * them or a part of its samples on them (trial_keep), then every candidate's kept rows at once.
 * Writes: per candidate its rows' sums into `kept` (trial_keep), and per chunk of TRIAL_CHUNK
 * kept pixels and candidate two sums (trial_totals, trial_terms), which the host adds up in
 * f64, chunk by chunk in order.
 *
 * Why on the device: a trial read back to the host cost a fast scene 2 to 3 ms a candidate
 * (its rows, 4 MiB of sums, and the host's pass over them) where the candidate rendered in 1
 * ms on the H200: case2's render takes 0.14 s, and 5% of it is 7 ms for the whole trial. Here
 * only a few kilobytes come back. A program of its own (render/trial.rs builds it beside the
 * render's), as it reads no scene.
 *
 * Precision: a work-item adds TRIAL_CHUNK / TRIAL_GROUP pixels in order and the group adds its
 * items as a tree, so a chunk's float sums carry a relative error of about 22 roundings
 * (sequential 16, tree 6) whatever the image size; tests/trial.rs holds them against the host's
 * f64 formulas (tests/common/trial.rs) on random and adversarial films.
 */
/* TRIAL_GROUP (the work-items of a group of trial_totals and trial_terms, a power of two) and
 * TRIAL_CHUNK (the pixels a group sums) come from the host's build options (render/trial.rs),
 * which sizes the launches and the partial sums by them. */

/* Adds a round's trial pixels of the film's two sums to candidate `slot`'s place in `kept`
 * (its sums, then its odd groups' sums, `columns * row_count` pixels each, zeroed when the
 * round began): of film rows row_start + r * row_step for r < row_count, the columns
 * col_start + x * col_step for x < columns (render/mod.rs, `Rows`). Added, not copied: a CPU's
 * candidate renders its samples in parts, the film cleared between them
 * (render/mod.rs, `trial_round`), and its sums are the parts' sums. With `clear`, it then
 * zeroes those pixels of the film's five sums, which is all the clearing the next candidate or
 * part needs where the round renders only them: clearing the whole film cost PoCL 7 ms at
 * 1280x720, twenty times a round, more than the candidates' renders. One work-item a pixel. */
__kernel void trial_keep(__global float4* sum, __global float4* sum_odd,
                         __global float4* sum_lo, __global float4* sum_sq,
                         __global float4* sum_odd_lo, uint width, uint row_start,
                         uint row_step, uint row_count, uint slot, uint col_start,
                         uint col_step, uint columns, uint clear, __global float4* kept) {
    const uint x = get_global_id(0), r = get_global_id(1);
    if (x >= columns || r >= row_count) return;
    const uint pixels = columns * row_count;
    const uint from = (row_start + r * row_step) * width + col_start + x * col_step;
    const uint to = r * columns + x;
    kept[2u * slot * pixels + to] += sum[from];
    kept[(2u * slot + 1u) * pixels + to] += sum_odd[from];
    if (clear) {
        const float4 zero = (float4)(0.0f);
        sum[from] = zero;
        sum_odd[from] = zero;
        sum_lo[from] = zero;
        sum_sq[from] = zero;
        sum_odd_lo[from] = zero;
    }
}

/* n times the variance of the mean of n samples, from the sum of the n samples and that of
 * the odd groups of four (n / 2 of them): the halves are independent and alike, each half's
 * mean has variance s^2 / (n/2), so their difference squared has expectation 4 s^2 / n. */
static inline float3 trial_stratified_variance(float3 sum, float3 sum_odd, float n) {
    const float3 difference = (sum - 2.0f * sum_odd) / (0.5f * n);
    return difference * difference * (0.25f * n);
}

/* The sum of every work-item's `v` over its group (TRIAL_GROUP items), for every item. */
static float2 trial_group_sum(float2 v, __local float2* scratch) {
    const uint l = get_local_id(0);
    scratch[l] = v;
    barrier(CLK_LOCAL_MEM_FENCE);
    for (uint stride = TRIAL_GROUP / 2u; stride > 0u; stride >>= 1) {
        if (l < stride) scratch[l] += scratch[l + stride];
        barrier(CLK_LOCAL_MEM_FENCE);
    }
    const float2 total = scratch[0];
    barrier(CLK_LOCAL_MEM_FENCE); /* before the next call writes scratch again */
    return total;
}

/* Candidate k's two figures at kept pixel p (of `pixels` a candidate, `films` candidates; its
 * film of n samples a pixel in slot k): for trial_totals the pixel's mean summed over
 * channels and that mean's variance (the stratified variance of the sum over n); for
 * trial_terms (`terms`) its relative variance of one sample, the channels' mean of the
 * stratified variance over the common denominator d^2 + eps (d the films' sums weighted by
 * `weights`: render/strategy.rs, `denominator_weights`), and that
 * squared. */
static inline float2 trial_pixel(__global const float4* kept, uint pixels, uint films, uint k,
                                 uint p, float n, bool terms, __global const float* weights,
                                 float eps) {
    const float3 s = kept[2u * k * pixels + p].xyz;
    const float3 o = kept[(2u * k + 1u) * pixels + p].xyz;
    if (!terms) {
        /* The variance of the channels' sum from the sum's own halves: a path's channels move
         * together, so their variances do not add up to it (they read it 1.7 to 2.2 times low
         * in standard error on case2, where the candidates' means then spread that much more
         * than the trial expected). */
        const float total = s.x + s.y + s.z, total_odd = o.x + o.y + o.z;
        const float var = trial_stratified_variance((float3)(total), (float3)(total_odd), n).x;
        return (float2)(total, var) / n;
    }
    float3 d = (float3)(0.0f);
    for (uint j = 0u; j < films; ++j) d += weights[j] * kept[2u * j * pixels + p].xyz;
    const float3 rel = trial_stratified_variance(s, o, n) / (d * d + eps);
    const float term = (rel.x + rel.y + rel.z) / 3.0f;
    return (float2)(term, term * term);
}

/* Per chunk of TRIAL_CHUNK kept pixels (this group's) and candidate k: out[chunk * films + k]
 * = the sums over the chunk's pixels of trial_pixel's two figures. */
static void trial_reduce(__global const float4* kept, uint pixels, uint films, uint samples,
                         bool terms, __global const float* weights, float eps,
                         __global float2* out, __local float2* scratch) {
    const uint chunk = get_group_id(0), l = get_local_id(0);
    const uint first = chunk * TRIAL_CHUNK;
    const uint end = min(first + TRIAL_CHUNK, pixels);
    const float n = (float)samples;
    for (uint k = 0u; k < films; ++k) {
        float2 acc = (float2)(0.0f);
        for (uint p = first + l; p < end; p += TRIAL_GROUP)
            acc += trial_pixel(kept, pixels, films, k, p, n, terms, weights, eps);
        const float2 total = trial_group_sum(acc, scratch);
        if (l == 0u) out[chunk * films + k] = total;
    }
}

/* Each candidate's image sums, chunk by chunk: (pixel means, their variances). */
__kernel __attribute__((reqd_work_group_size(TRIAL_GROUP, 1, 1))) void trial_totals(
    __global const float4* kept, uint pixels, uint films, uint samples, __global float2* out) {
    __local float2 scratch[TRIAL_GROUP];
    trial_reduce(kept, pixels, films, samples, false, (__global const float*)0, 0.0f, out,
                 scratch);
}

/* Each candidate's relative variances, chunk by chunk: (their sum, the sum of their squares),
 * of films of `samples` samples a pixel. */
__kernel __attribute__((reqd_work_group_size(TRIAL_GROUP, 1, 1))) void trial_terms(
    __global const float4* kept, uint pixels, uint films, uint samples,
    __global const float* weights, float eps, __global float2* out) {
    __local float2 scratch[TRIAL_GROUP];
    trial_reduce(kept, pixels, films, samples, true, weights, eps, out, scratch);
}
