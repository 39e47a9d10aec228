//! Generates the project's own texture maps into `assets/`:
//!
//! ```sh
//! cargo run --release --example make_assets
//! ```
//!
//! clpt makes its own assets: the original project's textures (`../shared/seed/texture/*.ppm`)
//! are test data of unknown origin and never enter the repository. Everything here is procedural
//! and deterministic (an integer hash, no random number generator and no clock), so running the
//! example again rewrites the same files byte for byte.
//!
//! - `bricks_color.png` (512x512 RGB): a running-bond brick wall, 4 bricks across and 8 courses
//!   down, each brick its own red, orange or brown, light grey mortar, a little noise.
//! - `bricks_height.png` (512x512 grey): its height map for `bump`: bricks high, mortar low, a
//!   soft bevel of a few pixels at the brick edges, slight bumps on the faces.
//! - `checker.png` (256x256 RGB): an 8x8 checker, off-white and dark teal.
//! - `planet.png` (1024x512 RGB): an equirectangular planet (longitude across, latitude down,
//!   top row the north pole): oceans, continents from fractal noise on the sphere, polar caps.
//! - `type_tiles.png` (256x256 RGB): a material-type map, 4x4 tiles of pure red (diffuse), green
//!   (mirror) and blue (glass), with a diffuse joint around each.
//! - `glow_emission.png` (256x256 RGB): an emission map: black, with thin glowing warm rings and
//!   dots.
//! - `uv_grid.png` (512x512 RGB): the orientation chart of `scenes/uv_orientation.txt`: red
//!   grows with u, green with v, a white disk at u = v = 0.
//! - `trefoil.obj`: a trefoil knot tube of 24,576 triangles (`tests/common/procedural.rs`), the
//!   mesh of `scenes/meshes.txt`.
//!
//! Every map tiles seamlessly (the planet wraps in longitude). Texel values are used as they are
//! (value / 255, no sRGB decoding), as in the original.

#[allow(dead_code)]
#[path = "../tests/common/procedural.rs"]
mod procedural;

use glam::Vec3;
use image::codecs::png::{CompressionType, FilterType, PngEncoder};
use image::{ExtendedColorType, ImageEncoder};
use std::f32::consts::{PI, TAU};
use std::path::{Path, PathBuf};

/// SplitMix64's finaliser: a good 64-bit mixing function.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A hash of a seed and up to three integer coordinates.
fn hash(seed: u64, a: i64, b: i64, c: i64) -> u64 {
    mix(mix(mix(mix(seed) ^ a as u64) ^ b as u64) ^ c as u64)
}

/// A hash as a number in [0, 1).
fn unit(seed: u64, a: i64, b: i64, c: i64) -> f32 {
    (hash(seed, a, b, c) >> 40) as f32 / (1u64 << 24) as f32
}

fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Quintic fade for value noise (C2 at the lattice points).
fn fade(t: f32) -> f32 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

fn lerp(a: f32, b: f32, t: f32) -> f32 {
    a + (b - a) * t
}

/// 2D value noise in [0, 1) with lattice period `period` in both axes, so it tiles.
fn noise2(seed: u64, x: f32, y: f32, period: i64) -> f32 {
    let (x0, y0) = (x.floor(), y.floor());
    let (tx, ty) = (fade(x - x0), fade(y - y0));
    let (i, j) = (x0 as i64, y0 as i64);
    let v = |di: i64, dj: i64| {
        unit(
            seed,
            (i + di).rem_euclid(period),
            (j + dj).rem_euclid(period),
            0,
        )
    };
    lerp(lerp(v(0, 0), v(1, 0), tx), lerp(v(0, 1), v(1, 1), tx), ty)
}

/// Tiling fractal value noise over a square image of side `size` pixels: `octaves` octaves,
/// the first with `cells` lattice cells across the image. Result in about [0, 1].
fn fbm2(seed: u64, px: f32, py: f32, size: f32, cells: i64, octaves: u32) -> f32 {
    let (mut sum, mut norm, mut amp, mut cells) = (0.0, 0.0, 1.0, cells);
    for o in 0..octaves {
        let s = cells as f32 / size;
        sum += amp * noise2(seed * 64 + o as u64, px * s, py * s, cells);
        norm += amp;
        amp *= 0.5;
        cells *= 2;
    }
    sum / norm
}

/// 3D value noise in [0, 1).
fn noise3(seed: u64, p: Vec3) -> f32 {
    let f = p.floor();
    let t = p - f;
    let (tx, ty, tz) = (fade(t.x), fade(t.y), fade(t.z));
    let (i, j, k) = (f.x as i64, f.y as i64, f.z as i64);
    let v = |di: i64, dj: i64, dk: i64| unit(seed, i + di, j + dj, k + dk);
    let plane = |dk: i64| {
        lerp(
            lerp(v(0, 0, dk), v(1, 0, dk), tx),
            lerp(v(0, 1, dk), v(1, 1, dk), tx),
            ty,
        )
    };
    lerp(plane(0), plane(1), tz)
}

/// Fractal 3D value noise in about [0, 1]. Sampled on the unit sphere, it has no seam in
/// longitude and no pinch at the poles.
fn fbm3(seed: u64, p: Vec3, octaves: u32) -> f32 {
    let (mut sum, mut norm, mut amp, mut q) = (0.0, 0.0, 1.0, p);
    for o in 0..octaves {
        sum += amp * noise3(seed * 64 + o as u64, q);
        norm += amp;
        amp *= 0.5;
        // Double the frequency and shift, so the octaves' lattices do not line up.
        q = q * 2.0 + Vec3::new(17.31, -9.77, 5.13);
    }
    sum / norm
}

fn to_u8(v: f32) -> u8 {
    (v.clamp(0.0, 1.0) * 255.0).round() as u8
}

fn rgb(c: Vec3) -> [u8; 3] {
    [to_u8(c.x), to_u8(c.y), to_u8(c.z)]
}

fn lerp3(a: Vec3, b: Vec3, t: f32) -> Vec3 {
    a + (b - a) * t.clamp(0.0, 1.0)
}

/// A colour from 0–255 components.
fn c255(r: u8, g: u8, b: u8) -> Vec3 {
    Vec3::new(r as f32, g as f32, b as f32) / 255.0
}

/// Writes an 8-bit PNG with fixed encoder settings (so the bytes depend only on the pixels).
fn write_png(path: &Path, width: u32, height: u32, color: ExtendedColorType, data: &[u8]) {
    let file = std::fs::File::create(path)
        .unwrap_or_else(|e| panic!("cannot create {}: {e}", path.display()));
    let encoder = PngEncoder::new_with_quality(
        std::io::BufWriter::new(file),
        CompressionType::Best,
        FilterType::Adaptive,
    );
    encoder
        .write_image(data, width, height, color)
        .unwrap_or_else(|e| panic!("cannot write {}: {e}", path.display()));
}

/// Fills an RGB image from a function of (x, y), y = 0 the top row.
fn rgb_image(width: u32, height: u32, f: impl Fn(u32, u32) -> [u8; 3]) -> Vec<u8> {
    let mut data = Vec::with_capacity((width * height * 3) as usize);
    for y in 0..height {
        for x in 0..width {
            data.extend_from_slice(&f(x, y));
        }
    }
    data
}

// ---------------------------------------------------------------------------------------------
// Bricks

const BRICK_SIZE: u32 = 512;
const BRICK_W: f32 = 128.0; // 4 bricks across
const BRICK_H: f32 = 64.0; // 8 courses down (even, so the half-brick offset tiles vertically)
const MORTAR: f32 = 4.0; // half the mortar joint, in pixels
const BEVEL: f32 = 5.0; // width of the rounded brick edge, in pixels

/// Where pixel (x, y) lies in the brick layout: the brick's id (course, column) and the
/// distance in pixels from the pixel centre to the nearest edge of the brick's cell.
fn brick_cell(x: u32, y: u32) -> ((i64, i64), f32) {
    let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
    let course = (py / BRICK_H).floor();
    // Running bond: every other course is shifted by half a brick.
    let shift = if course as i64 % 2 == 1 {
        BRICK_W * 0.5
    } else {
        0.0
    };
    let sx = px + shift;
    let column = (sx / BRICK_W).floor();
    let (lx, ly) = (sx - column * BRICK_W, py - course * BRICK_H);
    let edge = lx.min(BRICK_W - lx).min(ly).min(BRICK_H - ly);
    let columns = (BRICK_SIZE as f32 / BRICK_W) as i64;
    ((course as i64, (column as i64).rem_euclid(columns)), edge)
}

/// How far into the brick (0 in the mortar, 1 on the flat face), with a smooth bevel.
fn brick_profile(edge: f32) -> f32 {
    smoothstep(MORTAR, MORTAR + BEVEL, edge)
}

fn bricks_color() -> Vec<u8> {
    let size = BRICK_SIZE as f32;
    let palette = [
        c255(150, 52, 38), // brick red
        c255(172, 74, 42), // orange red
        c255(128, 60, 42), // brown
        c255(182, 96, 58), // light orange
        c255(110, 42, 34), // dark red
        c255(150, 84, 60), // tan brown
    ];
    let mortar = c255(196, 192, 184);
    rgb_image(BRICK_SIZE, BRICK_SIZE, |x, y| {
        let ((course, column), edge) = brick_cell(x, y);
        let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
        let grain = (unit(11, x as i64, y as i64, 0) - 0.5) * 0.06;
        let face = brick_profile(edge);
        // Per brick: a palette colour, a brightness, a slight shift towards the next colour.
        let k = hash(1, course, column, 0);
        let base = palette[(k % palette.len() as u64) as usize];
        let other = palette[((k >> 8) % palette.len() as u64) as usize];
        let brick = lerp3(base, other, unit(2, course, column, 0) * 0.4)
            * (0.85 + 0.25 * unit(3, course, column, 0));
        // Blotches on the face (tiling noise, 16 and 32 cells across) and darker worn edges.
        let blotch = fbm2(20, px, py, size, 16, 4);
        let brick = brick * (0.8 + 0.35 * blotch) * lerp(0.7, 1.0, face);
        let sand = fbm2(30, px, py, size, 64, 2);
        let mortar = mortar * (0.88 + 0.18 * sand);
        rgb(lerp3(mortar, brick, face) * (1.0 + grain))
    })
}

fn bricks_height() -> Vec<u8> {
    let size = BRICK_SIZE as f32;
    let mut data = Vec::with_capacity((BRICK_SIZE * BRICK_SIZE) as usize);
    for y in 0..BRICK_SIZE {
        for x in 0..BRICK_SIZE {
            let (_, edge) = brick_cell(x, y);
            let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
            let face = brick_profile(edge);
            // Smooth bumps on the faces (a few pixels across) and rough mortar.
            let bumps = fbm2(40, px, py, size, 64, 3) - 0.5;
            let rough = fbm2(50, px, py, size, 128, 2) - 0.5;
            let h = lerp(0.16 + 0.06 * rough, 0.86 + 0.06 * bumps, face);
            data.push(to_u8(h));
        }
    }
    data
}

// ---------------------------------------------------------------------------------------------
// Checker

fn checker() -> Vec<u8> {
    let light = [236, 230, 214];
    let dark = [22, 88, 96];
    rgb_image(256, 256, |x, y| {
        if (x / 32 + y / 32) % 2 == 0 {
            light
        } else {
            dark
        }
    })
}

// ---------------------------------------------------------------------------------------------
// Planet

fn planet() -> Vec<u8> {
    let (width, height) = (1024u32, 512u32);
    let deep = c255(8, 28, 78);
    let shallow = c255(30, 96, 150);
    let coast = c255(188, 172, 120);
    let lowland = c255(58, 112, 44);
    let forest = c255(30, 78, 34);
    let dry = c255(156, 132, 78);
    let highland = c255(112, 92, 62);
    let rock = c255(140, 132, 124);
    let ice = c255(236, 242, 248);
    rgb_image(width, height, |x, y| {
        // Longitude as the renderer's u = atan2(n.x, n.z) / 2π + ½ (u = ½ faces +z), latitude
        // linear down the rows (equirectangular, like the original's earth map; the renderer's
        // v = n.y / 2 + ½ is linear in sin(latitude), so on a ball the caps, drawn from about
        // 77° here, reach down to about 60°). Noise is sampled at the point n of the sphere, so
        // there is no seam at u = 0 / 1.
        let lon = (x as f32 + 0.5) / width as f32 * TAU - PI;
        let lat = PI * 0.5 - (y as f32 + 0.5) / height as f32 * PI;
        let n = Vec3::new(lat.cos() * lon.sin(), lat.sin(), lat.cos() * lon.cos());
        // Warp the domain a little for less blobby coasts.
        let warp = Vec3::new(
            fbm3(100, n * 2.0, 3),
            fbm3(101, n * 2.0, 3),
            fbm3(102, n * 2.0, 3),
        ) - Vec3::splat(0.5);
        let e = fbm3(110, n * 1.6 + warp * 0.9, 8);
        let moisture = fbm3(120, n * 2.5, 5);
        let sea = 0.52;
        // 0 at the equator, 1 at the poles, with a ragged edge.
        let polar = lat.abs() / (PI * 0.5) + 0.35 * (fbm3(130, n * 5.0, 5) - 0.5);
        let colour = if e < sea {
            let depth = ((sea - e) / 0.18).clamp(0.0, 1.0);
            lerp3(shallow, deep, depth.sqrt())
        } else {
            let h = ((e - sea) / 0.3).clamp(0.0, 1.0);
            // Greener where it is wet, dry and sandy where it is not, more so near the tropics.
            let tropics = 1.0 - smoothstep(0.1, 0.4, polar);
            let dryness = smoothstep(0.5, 0.62, 1.0 - moisture + 0.08 * tropics);
            let green = lerp3(lowland, forest, smoothstep(0.5, 0.7, moisture));
            let ground = lerp3(green, dry, dryness);
            let ground = lerp3(coast, ground, smoothstep(0.0, 0.06, h));
            let ground = lerp3(ground, highland, smoothstep(0.3, 0.55, h));
            let ground = lerp3(ground, rock, smoothstep(0.55, 0.8, h));
            // Snow on high peaks and, lower down, towards the poles.
            let snow = smoothstep(0.88, 1.0, h + 0.6 * smoothstep(0.55, 0.85, polar));
            lerp3(ground, ice, snow)
        };
        let cap = smoothstep(0.84, 0.87, polar);
        let grain = 1.0 + (unit(140, x as i64, y as i64, 0) - 0.5) * 0.03;
        rgb(lerp3(colour, ice, cap) * grain)
    })
}

// ---------------------------------------------------------------------------------------------
// Material-type map

fn type_tiles() -> Vec<u8> {
    const R: [u8; 3] = [255, 0, 0]; // diffuse
    const G: [u8; 3] = [0, 255, 0]; // mirror
    const B: [u8; 3] = [0, 0, 255]; // glass
    // Mirrors on a sparse checker, two glass tiles between them, diffuse elsewhere.
    let tiles = [
        [G, R, G, R], //
        [R, B, R, R],
        [G, R, G, R],
        [R, R, R, B],
    ];
    rgb_image(256, 256, |x, y| {
        let (i, j) = ((y / 64) as usize, (x / 64) as usize);
        let (lx, ly) = (x % 64, y % 64);
        // A diffuse joint 3 texels wide around every tile, like grout.
        let border = lx < 3 || ly < 3 || lx >= 61 || ly >= 61;
        if border { R } else { tiles[i][j] }
    })
}

// ---------------------------------------------------------------------------------------------
// Emission map

fn glow_emission() -> Vec<u8> {
    const SIZE: u32 = 256;
    let half = SIZE as f32 / 2.0;
    // Rings about the centre: radius and colour, warm white inside to red outside.
    let rings = [
        (22.0, c255(255, 236, 190)),
        (50.0, c255(255, 196, 110)),
        (78.0, c255(255, 150, 60)),
        (106.0, c255(240, 90, 40)),
    ];
    let dot = c255(255, 210, 140);
    // Offset from the pixel centre to a point, on the torus (so the map tiles).
    let wrap = |d: f32| d - SIZE as f32 * (d / SIZE as f32).round();
    let glow = |d: f32, core: f32, halo: f32| {
        (-(d / core).powi(2)).exp() + 0.3 * (-(d / halo).powi(2)).exp()
    };
    rgb_image(SIZE, SIZE, |x, y| {
        let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
        let (dx, dy) = (wrap(px - half), wrap(py - half));
        let r = (dx * dx + dy * dy).sqrt();
        let mut c = Vec3::ZERO;
        for (radius, colour) in rings {
            c += colour * glow(r - radius, 1.3, 4.0);
        }
        // A dot at the tile corner (the four corners meet when tiled) and at the middle of
        // each edge, between the outer ring and the next tile's.
        for (ox, oy) in [(0.0, 0.0), (half, 0.0), (0.0, half)] {
            let (ex, ey) = (wrap(px - ox), wrap(py - oy));
            let d = (ex * ex + ey * ey).sqrt();
            c += dot * glow(d, 2.5, 6.0);
        }
        rgb(c)
    })
}

// ---------------------------------------------------------------------------------------------

/// The orientation chart: red grows with u (to the right), green with v (upwards; v = 1 is the
/// top row), dark lines every 1/8, and a white disk at u = v = 0 (the bottom-left corner).
fn uv_grid() -> Vec<u8> {
    let size = 512u32;
    rgb_image(size, size, |x, row| {
        let u = (x as f32 + 0.5) / size as f32;
        let v = 1.0 - (row as f32 + 0.5) / size as f32;
        let line = |t: f32| {
            let f = (t * 8.0).fract();
            f.min(1.0 - f) * (size as f32 / 8.0) < 1.5
        };
        if (u * u + v * v).sqrt() < 0.06 {
            return [255, 255, 255];
        }
        if line(u) || line(v) {
            return [20, 20, 20];
        }
        [to_u8(u), to_u8(v), 60]
    })
}

fn main() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets");
    std::fs::create_dir_all(&dir).expect("cannot create assets/");
    use ExtendedColorType::{L8, Rgb8};
    let files: [(&str, u32, u32, ExtendedColorType, Vec<u8>); 7] = [
        ("bricks_color.png", 512, 512, Rgb8, bricks_color()),
        ("bricks_height.png", 512, 512, L8, bricks_height()),
        ("checker.png", 256, 256, Rgb8, checker()),
        ("planet.png", 1024, 512, Rgb8, planet()),
        ("type_tiles.png", 256, 256, Rgb8, type_tiles()),
        ("glow_emission.png", 256, 256, Rgb8, glow_emission()),
        ("uv_grid.png", 512, 512, Rgb8, uv_grid()),
    ];
    for (name, width, height, color, data) in files {
        let path = dir.join(name);
        write_png(&path, width, height, color, &data);
        let bytes = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
        println!("{} ({width}x{height}, {bytes} bytes)", path.display());
    }
    // The mesh of scenes/meshes.txt: a trefoil knot tube, 24,576 triangles, normalised like
    // the original's meshes (centred, largest extent [-1, 1]).
    let mut knot = procedural::torus_knot(2, 3, 0.35, 512, 24);
    let scale = 1.0 / 3.35; // the knot reaches 2 + 1 + 0.35 from its centre
    for p in &mut knot.positions {
        *p = p.map(|c| c * scale);
    }
    let path = dir.join("trefoil.obj");
    procedural::write_obj(
        &knot,
        &path,
        "trefoil knot tube, generated by examples/make_assets.rs (tests/common/procedural.rs)",
    )
    .expect("cannot write trefoil.obj");
    println!("{} ({} triangles)", path.display(), knot.triangles.len());
}
