/* texture.h: texture map lookups and bump normals (port of the texture part of material.cuh).
 *
 * Reads: the TextureMap table and the texel bytes (one buffer for all maps of the scene, each
 * map in its own format: MAP_RGB8, MAP_TYPE8, MAP_BUMP8; see types.h). Writes: nothing.
 * Why: the original replaced a material's colour, emission and type per texel and bent its
 * normal by a bump map; texel values are used as they are (value / 255, no sRGB decoding), so
 * its scenes look the same. Coordinates wrap, so tiles meet without seams; lookups are bilinear
 * by default or nearest (the original's), type maps always nearest.
 */
#ifndef CLPT_TEXTURE_H
#define CLPT_TEXTURE_H

#include "types.h"
#include "vecmath.h"

inline uint wrap_texel(int i, uint n) {
    const int r = i % (int)n;
    return (uint)(r < 0 ? r + (int)n : r);
}

/* Texel (x, y) of a map, y counted from the bottom row (v = 0), as a float4: RGB8 gives
 * (r, g, b, 0) / 255, TYPE8 (type, 0, 0, 0), BUMP8 (du, dv, 0, 0) in [-1, 1]. */
inline float4 texel_value(__global const uchar* texels, TextureMap map, uint x, uint y) {
    const uint texel = (map.height - 1u - y) * map.width + x;
    if (map.format == MAP_RGB8) {
        const uint i = map.offset + 3u * texel;
        return (float4)(texels[i], texels[i + 1u], texels[i + 2u], 0.0f) * (1.0f / 255.0f);
    }
    if (map.format == MAP_BUMP8) {
        const uint i = map.offset + 2u * texel;
        return (float4)(as_char(texels[i]), as_char(texels[i + 1u]), 0.0f, 0.0f) *
               (1.0f / 127.0f);
    }
    return (float4)((float)texels[map.offset + texel], 0.0f, 0.0f, 0.0f);
}

/* The map's value at (u, v), both wrapped into [0, 1). Nearest: the texel the point falls in,
 * x = floor(u w), y = floor(v h) as the original. Bilinear: the four texels around the point,
 * texel centres at ((x + 1/2) / w, (y + 1/2) / h). */
inline float4 texture_lookup(__global const TextureMap* maps, __global const uchar* texels,
                             uint index, float2 uv, uint filter) {
    const TextureMap map = maps[index];
    const float fx = frac_unit(uv.x) * (float)map.width;
    const float fy = frac_unit(uv.y) * (float)map.height;
    if (filter == FILTER_NEAREST || map.format == MAP_TYPE8) {
        return texel_value(texels, map, wrap_texel((int)floor(fx), map.width),
                           wrap_texel((int)floor(fy), map.height));
    }
    const float x = fx - 0.5f;
    const float y = fy - 0.5f;
    const float x0f = floor(x);
    const float y0f = floor(y);
    const float tx = x - x0f;
    const float ty = y - y0f;
    const uint x0 = wrap_texel((int)x0f, map.width);
    const uint x1 = wrap_texel((int)x0f + 1, map.width);
    const uint y0 = wrap_texel((int)y0f, map.height);
    const uint y1 = wrap_texel((int)y0f + 1, map.height);
    const float4 bottom = mix(texel_value(texels, map, x0, y0), texel_value(texels, map, x1, y0), tx);
    const float4 top = mix(texel_value(texels, map, x0, y1), texel_value(texels, map, x1, y1), tx);
    return mix(bottom, top, ty);
}

/* The original's bump formula (report section 2.4), gradients g = (du, dv) in [-1, 1]:
 * n_u = (1 - |du|) n + dpdu du, n_uv = (1 - |dv|) n_u + dpdv dv, normalised. */
inline float3 bump_normal(float3 n, float3 dpdu, float3 dpdv, float2 g) {
    const float3 nu = (1.0f - fabs(g.x)) * n + dpdu * g.x;
    return normalize((1.0f - fabs(g.y)) * nu + dpdv * g.y);
}

#endif
