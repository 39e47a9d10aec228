//! Texture maps: decoding of PPM (P3, P6; 8 and 16 bits; header comments) and PNG (grey, RGB,
//! RGBA; 8 and 16 bits) fixtures made here; malformed, truncated, empty and oversized files;
//! the type-map rule and its ties; bump gradients; path resolution. Device probes against f64:
//! bilinear and nearest lookups (texel borders, u or v exactly 0 or 1), plane and sphere
//! texture coordinates and directions (poles included), the bump formula. A render of an
//! emission-mapped plane against an f64 quadrature of the same picture, and the original's
//! case0_texture.txt rendered small without NaN or Inf.

mod common;

use clpt::contract::{self, FILTER_BILINEAR, FILTER_NEAREST};
use clpt::device::kernel::NamedArgs;
use clpt::device::program::KernelSources;
use clpt::device::upload::SceneBuffers;
use clpt::pack::PackedScene;
use clpt::render::{RenderOptions, Renderer, TextureFilter};
use clpt::scene::Scene;
use clpt::scene::parse::parse_scene;
use clpt::scene::texture::{self, RgbImage};
use glam::DVec3;
use ocl::prm::{Float2, Float4, Uint2};
use rand::rngs::SmallRng;
use rand::{RngExt, SeedableRng};
use std::path::{Path, PathBuf};

fn temp_dir(test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("clpt-texture-{}-{test}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn decode(path: &Path) -> clpt::Result<RgbImage> {
    texture::decode(path, texture::DEFAULT_MAX_PIXELS)
}

const PIXELS: [[u8; 3]; 4] = [[255, 0, 0], [0, 255, 0], [0, 0, 255], [10, 20, 30]];

#[test]
fn ppm_p3_and_p6_at_8_and_16_bits_decode() {
    let dir = temp_dir("ppm");
    let p3 = "P3\n# a comment\n2 2 # another\n255\n255 0 0  0 255 0\n0 0 255  10 20 30\n";
    let mut p6 = b"P6\n# comment\n2 2\n255\n".to_vec();
    p6.extend(PIXELS.iter().flatten());
    // 16 bits: 257 k scales exactly to k.
    let wide = |v: u8| (v as u16 * 257).to_be_bytes();
    let mut p6_16 = b"P6\n2 2\n65535\n".to_vec();
    p6_16.extend(PIXELS.iter().flatten().flat_map(|&v| wide(v)));
    let p3_16 = format!(
        "P3\n2 2\n65535\n{}\n",
        PIXELS
            .iter()
            .flatten()
            .map(|&v| (v as u32 * 257).to_string())
            .collect::<Vec<_>>()
            .join(" ")
    );
    for (name, bytes) in [
        ("p3.ppm", p3.as_bytes().to_vec()),
        ("p6.ppm", p6),
        ("p6_16.ppm", p6_16),
        ("p3_16.ppm", p3_16.into_bytes()),
    ] {
        let path = dir.join(name);
        std::fs::write(&path, bytes).unwrap();
        let image = decode(&path).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!((image.width, image.height), (2, 2), "{name}");
        assert_eq!(image.rgb, PIXELS.to_vec(), "{name}");
    }
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn png_grey_rgb_rgba_at_8_and_16_bits_decode() {
    let dir = temp_dir("png");
    let rgb8 = image::RgbImage::from_fn(2, 2, |x, y| image::Rgb(PIXELS[(y * 2 + x) as usize]));
    let cases: Vec<(&str, image::DynamicImage, Vec<[u8; 3]>)> = vec![
        ("rgb8.png", rgb8.clone().into(), PIXELS.to_vec()),
        (
            "rgba8.png",
            image::DynamicImage::ImageRgb8(rgb8.clone())
                .to_rgba8()
                .into(),
            PIXELS.to_vec(),
        ),
        (
            "rgb16.png",
            image::DynamicImage::ImageRgb16(image::ImageBuffer::from_fn(2, 2, |x, y| {
                image::Rgb(PIXELS[(y * 2 + x) as usize].map(|v| v as u16 * 257))
            })),
            PIXELS.to_vec(),
        ),
        (
            "grey8.png",
            image::DynamicImage::ImageLuma8(image::ImageBuffer::from_fn(2, 2, |x, y| {
                image::Luma([(x * 100 + y * 50) as u8])
            })),
            vec![[0; 3], [100; 3], [50; 3], [150; 3]],
        ),
        (
            "grey16.png",
            image::DynamicImage::ImageLuma16(image::ImageBuffer::from_fn(2, 2, |x, y| {
                image::Luma([((x * 100 + y * 50) * 257) as u16])
            })),
            vec![[0; 3], [100; 3], [50; 3], [150; 3]],
        ),
    ];
    for (name, img, want) in cases {
        let path = dir.join(name);
        img.save(&path).unwrap();
        let got = decode(&path).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(got.rgb, want, "{name}");
    }
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn bad_images_are_errors_never_panics() {
    let dir = temp_dir("bad");
    let mut p6 = b"P6\n4 4\n255\n".to_vec();
    p6.extend([7u8; 48]);
    let png_path = dir.join("ok.png");
    image::RgbImage::from_pixel(5, 3, image::Rgb([1, 2, 3]))
        .save(&png_path)
        .unwrap();
    let png = std::fs::read(&png_path).unwrap();
    for (name, bytes, fragment) in [
        ("truncated.ppm", p6[..p6.len() - 5].to_vec(), "cut short"),
        ("header.ppm", b"P6\nabc 4\n255\n".to_vec(), ""),
        ("empty.ppm", b"P6\n0 0\n255\n".to_vec(), ""),
        ("zero.ppm", b"P3\n0 3\n255\n".to_vec(), ""),
        ("text.ppm", b"hello, not an image".to_vec(), ""),
        ("nothing.png", Vec::new(), ""),
        ("truncated.png", png[..png.len() / 2].to_vec(), ""),
    ] {
        let path = dir.join(name);
        std::fs::write(&path, &bytes).unwrap();
        let err = decode(&path).expect_err(name).to_string();
        assert!(
            err.contains(name) && err.contains(fragment),
            "{name}: {err}"
        );
    }
    // Every truncation of valid files: an image or an error, never a panic.
    for bytes in [&p6, &png] {
        for len in 0..bytes.len() {
            let path = dir.join("cut");
            std::fs::write(&path, &bytes[..len]).unwrap();
            let _ = decode(&path);
        }
    }
    let big = dir.join("big.png");
    image::RgbImage::new(100, 50).save(&big).unwrap();
    let err = texture::decode(&big, 4999).unwrap_err().to_string();
    assert!(err.contains("5000 pixels") && err.contains("4999"), "{err}");
    assert!(texture::decode(&big, 5000).is_ok());
    std::fs::remove_dir_all(dir).ok();
}

/// A header claiming a huge image in a tiny file, with the pixel limit raised: refused for
/// being too short before anything is allocated (a 69-byte PPM claiming 100000x100000 pixels
/// aborted the process allocating 30 GB). So are files over the size limit, and directories.
#[test]
fn headers_claiming_more_than_the_file_holds_are_refused_before_allocating() {
    let dir = temp_dir("claims");
    let mut ppm = b"P6\n100000 100000\n255\n".to_vec();
    ppm.resize(69, 0);
    let path = dir.join("huge.ppm");
    std::fs::write(&path, &ppm).unwrap();
    let err = decode(&path).unwrap_err().to_string();
    assert!(err.contains("over the limit of 67108864"), "{err}");
    let err = texture::decode(&path, u64::MAX).unwrap_err().to_string();
    assert!(
        err.contains("the file is 69 bytes, too short for the 100000x100000 image")
            && err.contains("at least 30000000000 bytes"),
        "{err}"
    );
    // A PNG: its rows deflate at most 1032 to 1, of 1-bit samples at the smallest.
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    let chunk = |png: &mut Vec<u8>, kind: &[u8], data: &[u8]| {
        png.extend((data.len() as u32).to_be_bytes());
        let body = [kind, data].concat();
        png.extend(&body);
        png.extend(crc32(&body).to_be_bytes());
    };
    let ihdr = [
        &60000u32.to_be_bytes()[..],
        &60000u32.to_be_bytes(),
        &[16, 6, 0, 0, 0],
    ]
    .concat();
    chunk(&mut png, b"IHDR", &ihdr);
    chunk(&mut png, b"IDAT", &[0; 1000]);
    chunk(&mut png, b"IEND", &[]);
    std::fs::write(dir.join("huge.png"), &png).unwrap();
    let err = texture::decode(&dir.join("huge.png"), u64::MAX)
        .unwrap_err()
        .to_string();
    assert!(err.contains("too short for the 60000x60000 image"), "{err}");
    // The size limit follows the pixel limit: 32 bytes a pixel and 64 MiB.
    let sparse = dir.join("sparse.ppm");
    let file = std::fs::File::create(&sparse).unwrap();
    file.set_len(texture::max_file_bytes(16) + 1).unwrap();
    let err = texture::decode(&sparse, 16).unwrap_err().to_string();
    assert!(
        err.contains(&format!(
            "larger than the limit of {} bytes",
            (64 << 20) + 512
        )) && err.contains("--max-texture-pixels"),
        "{err}"
    );
    let err = decode(&dir).unwrap_err().to_string();
    assert!(err.contains("this is a directory, not a file"), "{err}");
    std::fs::remove_dir_all(dir).ok();
}

/// CRC-32 (ISO 3309, as PNG chunks use), bit by bit.
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in bytes {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 == 1 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

#[test]
fn type_map_rule_and_ties() {
    let (d, m, g) = (
        contract::MATERIAL_DIFFUSE,
        contract::MATERIAL_SPECULAR,
        contract::MATERIAL_REFRACTIVE,
    );
    for (texel, want) in [
        ([255, 0, 0], d),
        ([0, 255, 0], m),
        ([0, 0, 255], g),
        ([200, 100, 50], d),
        ([1, 2, 3], g),
        ([0, 0, 0], d),    // no maximum: diffuse, the default type
        ([90, 90, 90], d), // three-way tie
        ([9, 9, 5], d),    // R = G: the earlier, diffuse
        ([9, 5, 9], d),    // R = B
        ([5, 9, 9], m),    // G = B: mirror
    ] {
        assert_eq!(texture::material_type_of(texel), want, "{texel:?}");
    }
}

#[test]
fn bump_gradients_are_central_differences_wrapping() {
    // Red channel, rows from the top: gradients along u (right) and v (up).
    let reds = [[0u8, 51, 102, 255], [10, 20, 30, 40], [255, 0, 255, 0]];
    let image = RgbImage {
        width: 4,
        height: 3,
        rgb: reds.iter().flatten().map(|&r| [r, 7, 9]).collect(),
    };
    let q = |g: f64| (g * 127.0).round() as i8;
    for row in 0..3usize {
        for x in 0..4usize {
            let r = |dx: isize, drow: isize| {
                reds[(row as isize + drow).rem_euclid(3) as usize]
                    [(x as isize + dx).rem_euclid(4) as usize] as f64
                    / 255.0
            };
            let want = [q(r(1, 0) - r(-1, 0)), q(r(0, -1) - r(0, 1))];
            assert_eq!(
                texture::bump_gradient(&image, x as u32, row as u32),
                want,
                "({x}, {row})"
            );
        }
    }
}

#[test]
fn texture_paths_resolve_in_order_and_list_what_was_tried() {
    let dir = temp_dir("resolve");
    let scenes = dir.join("scenes");
    std::fs::create_dir_all(scenes.join("texture")).unwrap();
    std::fs::create_dir_all(dir.join("texture")).unwrap();
    std::fs::write(dir.join("texture/a.ppm"), "x").unwrap();
    std::fs::write(scenes.join("texture/b.ppm"), "x").unwrap();
    std::fs::write(dir.join("texture/b.ppm"), "x").unwrap();
    let at = clpt::error::Location {
        file: "s.txt".into(),
        line: 3,
        column: 9,
    };
    let found = |name: &str| clpt::scene::resolve("texture", Path::new(name), Some(&scenes), &at);
    // The parent's file when the scene folder has none; the scene folder's first.
    assert_eq!(found("texture/a.ppm").unwrap(), dir.join("texture/a.ppm"));
    assert_eq!(
        found("texture/b.ppm").unwrap(),
        scenes.join("texture/b.ppm")
    );
    // A directory of the name is named as such, where no file is found.
    std::fs::create_dir_all(scenes.join("texture/dir.ppm")).unwrap();
    let err = found("texture/dir.ppm").unwrap_err().to_string();
    assert!(
        err.starts_with("s.txt:3:9: texture file `texture/dir.ppm` is a directory (")
            && err.contains(&scenes.join("texture/dir.ppm").display().to_string()),
        "{err}"
    );
    let err = found("texture/missing.ppm").unwrap_err().to_string();
    assert!(
        err.starts_with("s.txt:3:9: texture file `texture/missing.ppm` not found"),
        "{err}"
    );
    for place in [
        scenes.join("texture/missing.ppm"),
        dir.join("texture/missing.ppm"),
    ] {
        assert!(
            err.contains(&place.display().to_string()),
            "{err} lacks {}",
            place.display()
        );
    }
    std::fs::remove_dir_all(dir).ok();
}

/// A scene in `dir` using the given maps on a plane (material 0) and a sphere (material 1).
fn mapped_scene(dir: &Path, material: &str, plane_extra: &str) -> Scene {
    let text = format!(
        "PerspectiveCamera {{ center 0 0 10 direction 0 0 -1 angle 30 width 32 height 24 }}\n\
         Materials {{ numMaterials 2 {material} {material} }}\n\
         Group {{ numObjects 2 MaterialIndex 0 Plane {{ normal 0 0 1 offset 0 range 1000 {plane_extra} }}\n\
         MaterialIndex 1 Sphere {{ center 0 0 -50 radius 3 }} }}\n"
    );
    let path = dir.join("scene.txt");
    std::fs::write(&path, text).unwrap();
    Scene::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// f64 reference of a lookup, from the decoded image: `value(x, y_from_bottom)` per texel.
fn reference_lookup(
    w: u32,
    h: u32,
    value: &dyn Fn(u32, u32) -> [f64; 3],
    uv: [f64; 2],
    nearest: bool,
) -> [f64; 3] {
    let frac = |x: f64| x - x.floor();
    let (fx, fy) = (frac(uv[0]) * w as f64, frac(uv[1]) * h as f64);
    let wrap = |i: i64, n: u32| i.rem_euclid(n as i64) as u32;
    if nearest {
        return value(wrap(fx.floor() as i64, w), wrap(fy.floor() as i64, h));
    }
    let (x, y) = (fx - 0.5, fy - 0.5);
    let (x0, y0) = (x.floor(), y.floor());
    let (tx, ty) = (x - x0, y - y0);
    let at = |dx: i64, dy: i64| value(wrap(x0 as i64 + dx, w), wrap(y0 as i64 + dy, h));
    let lerp = |a: [f64; 3], b: [f64; 3], t: f64| [0, 1, 2].map(|c| a[c] + (b[c] - a[c]) * t);
    lerp(
        lerp(at(0, 0), at(1, 0), tx),
        lerp(at(0, 1), at(1, 1), tx),
        ty,
    )
}

#[test]
fn lookups_match_f64_at_random_points_and_texel_borders() {
    let dir = temp_dir("lookup");
    let mut rng = SmallRng::seed_from_u64(31);
    // 8x4 colour map (powers of two: texel borders are exact in f32), 5x3 height map.
    let (w, h) = (8u32, 4u32);
    let colors: Vec<[u8; 3]> = (0..w * h)
        .map(|_| [rng.random(), rng.random(), rng.random()])
        .collect();
    image::RgbImage::from_fn(w, h, |x, row| image::Rgb(colors[(row * w + x) as usize]))
        .save(dir.join("color.png"))
        .unwrap();
    let types: Vec<[u8; 3]> = (0..w * h)
        .map(|_| [rng.random(), rng.random(), rng.random()])
        .collect();
    image::RgbImage::from_fn(w, h, |x, row| image::Rgb(types[(row * w + x) as usize]))
        .save(dir.join("type.png"))
        .unwrap();
    let heights: Vec<u8> = (0..15).map(|_| rng.random()).collect();
    image::GrayImage::from_fn(5, 3, |x, row| {
        image::Luma([heights[(row * 5 + x) as usize]])
    })
    .save(dir.join("height.png"))
    .unwrap();
    let scene = mapped_scene(
        &dir,
        "Material { texture { color color.png type type.png bump height.png } }",
        "centerp 0 0 0 dirU 0.1 0 0 dirV 0 0.1 0",
    );
    let packed = PackedScene::new(&scene, u64::MAX).unwrap();
    let [color_map, _, type_map, bump_map] = packed.textures.material_maps[0];
    // Texel values with y counted from the bottom row, as the kernels count.
    let color_at =
        |x: u32, y: u32| colors[((h - 1 - y) * w + x) as usize].map(|c| c as f64 / 255.0);
    let type_at = |x: u32, y: u32| {
        [
            texture::material_type_of(types[((h - 1 - y) * w + x) as usize]) as f64,
            0.0,
            0.0,
        ]
    };
    let bump_at = |x: u32, y: u32| {
        let r = |dx: i64, drow: i64| {
            let row = (2 - y as i64 + drow).rem_euclid(3);
            heights[(row * 5 + (x as i64 + dx).rem_euclid(5)) as usize] as f64 / 255.0
        };
        let q = |g: f64| (g * 127.0).round() / 127.0;
        [q(r(1, 0) - r(-1, 0)), q(r(0, -1) - r(0, 1)), 0.0]
    };
    let mut uvs: Vec<[f32; 2]> = (0..3000)
        .map(|_| [rng.random_range(-2.0..3.0), rng.random_range(-2.0..3.0)])
        .collect();
    for i in 0..=w {
        for j in 0..=h {
            uvs.push([i as f32 / w as f32, j as f32 / h as f32]); // texel borders, 0 and 1
        }
    }
    let maps = [
        (
            color_map,
            &color_at as &dyn Fn(u32, u32) -> [f64; 3],
            w,
            h,
            1e-5,
        ),
        (type_map, &type_at, w, h, 0.0),
        (bump_map, &bump_at, 5, 3, 1e-5),
    ];
    let device = common::device();
    let params = packed.params(0, 1, 1, 0);
    let buffers = SceneBuffers::new(&device, &packed, &params).unwrap();
    let program = common::probes(&device);
    for (map, value, mw, mh, tol) in maps {
        for filter in [FILTER_BILINEAR, FILTER_NEAREST] {
            let index: Vec<Uint2> = uvs.iter().map(|_| Uint2::new(map, filter)).collect();
            let uv: Vec<Float2> = uvs.iter().map(|p| Float2::new(p[0], p[1])).collect();
            let (ib, ub) = (
                common::buffer(&device, &index),
                common::buffer(&device, &uv),
            );
            let out = common::output::<Float4>(&device, uvs.len());
            let kernel = NamedArgs::new(&program, "probe_texture", &device.queue)
                .buffer("maps", &buffers.maps)
                .buffer("texels", &buffers.texels)
                .buffer("index_filter", &ib)
                .buffer("uv", &ub)
                .buffer("out", &out)
                .build()
                .unwrap();
            common::run(&kernel, uvs.len());
            let nearest = filter == FILTER_NEAREST || map == type_map;
            for (p, got) in uvs.iter().zip(common::read(&out)) {
                let want = reference_lookup(mw, mh, value, [p[0] as f64, p[1] as f64], nearest);
                for c in 0..3 {
                    assert!(
                        (got[c] as f64 - want[c]).abs() <= tol + 1e-6,
                        "map {map} filter {filter} uv {p:?} channel {c}: {} vs {}",
                        got[c],
                        want[c]
                    );
                }
            }
        }
    }
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn plane_and_sphere_mapping_match_f64() {
    let device = common::device();
    let mut rng = SmallRng::seed_from_u64(32);
    let dir_u = DVec3::new(0.05, 0.0, 0.02);
    let dir_v = DVec3::new(0.0, 0.25, 0.0);
    let centerp = DVec3::new(3.0, -2.0, 0.0);
    let plane = contract::Plane {
        normal: [0.0, 0.0, 1.0],
        offset: 0.0,
        range: 1000.0,
        centerp: centerp.as_vec3().to_array(),
        dir_u: dir_u.as_vec3().to_array(),
        dir_v: dir_v.as_vec3().to_array(),
        ..Default::default()
    };
    let center = DVec3::new(1.0, 2.0, -40.0);
    let radius = 7.0;
    let sphere = contract::Sphere {
        center: center.as_vec3().to_array(),
        radius: 7.0,
        ..Default::default()
    };
    let f = |v: DVec3| v.as_vec3().to_array();
    let ray = |o: DVec3, d: DVec3| {
        let (o, d) = (f(o), f(d.normalize()));
        [o[0], o[1], o[2], d[0], d[1], d[2], 0.0, 0.0, 1.0]
    };
    // Plane: random points, and points where u or v is an exact integer (wraps to 0).
    let mut plane_rays = Vec::new();
    for i in 0..2000 {
        let mut target = DVec3::new(
            rng.random_range(-100.0..100.0),
            rng.random_range(-100.0..100.0),
            0.0,
        );
        if i % 4 == 0 {
            target.y = centerp.y + (rng.random_range(-20..20) as f64) / 0.25; // v integer
        }
        plane_rays.push(ray(
            DVec3::new(0.0, 0.0, 50.0),
            target - DVec3::new(0.0, 0.0, 50.0),
        ));
    }
    // Sphere: random points on the front half, and the two poles hit straight on.
    let mut sphere_rays = Vec::new();
    for _ in 0..2000 {
        let n = common::random_unit(&mut rng);
        let n = if n.z < 0.0 {
            DVec3::new(n.x, n.y, -n.z)
        } else {
            n
        };
        let p = center + n * radius;
        let o = p + n * 20.0;
        sphere_rays.push(ray(o, p - o));
    }
    sphere_rays.push(ray(center + DVec3::Y * 30.0, -DVec3::Y));
    sphere_rays.push(ray(center - DVec3::Y * 30.0, DVec3::Y));
    for (scene, rays) in [
        (
            common::packed(vec![], vec![plane], vec![Default::default()]),
            plane_rays,
        ),
        (
            common::packed(vec![sphere], vec![], vec![Default::default()]),
            sphere_rays,
        ),
    ] {
        let out = common::probe_scene_rays(&device, &scene, "probe_mapping", &rays, 8);
        let hits = common::probe_hits(&device, &scene, &rays);
        for ((r, got), hit) in rays.iter().zip(out.chunks_exact(8)).zip(&hits) {
            assert!(hit[1] != clpt::contract::OBJECT_NONE as f32, "ray missed");
            let p = DVec3::new(hit[3] as f64, hit[4] as f64, hit[5] as f64);
            let (uv, dpdu, dpdv, pole) = if scene.planes.is_empty() {
                let n = (p - center).normalize();
                let rho = (n.x * n.x + n.z * n.z).sqrt();
                let uv = [
                    n.x.atan2(n.z) / std::f64::consts::TAU + 0.5,
                    n.y * 0.5 + 0.5,
                ];
                if rho < 1e-6 {
                    let north = if n.y > 0.0 { -1.0 } else { 1.0 };
                    (uv, DVec3::X, DVec3::new(0.0, 0.0, north), true)
                } else {
                    let dpdu = DVec3::new(n.z, 0.0, -n.x) / rho;
                    let dpdv = DVec3::new(-n.y * n.x / rho, rho, -n.y * n.z / rho);
                    (uv, dpdu, dpdv, false)
                }
            } else {
                let rel = p - centerp;
                let frac = |x: f64| x - x.floor();
                (
                    [frac(rel.dot(dir_u)), frac(rel.dot(dir_v))],
                    dir_u.normalize(),
                    dir_v.normalize(),
                    false,
                )
            };
            for k in 0..2 {
                let d = (got[k] as f64 - uv[k]).abs();
                let d = d.min(1.0 - d); // 0 and 1 are the same point of a tile
                // At a pole u is the longitude of a point that has none: any value will do.
                if !(pole && k == 0) {
                    assert!(
                        d < 2e-5,
                        "uv[{k}] {} vs {} at {p} (ray {r:?})",
                        got[k],
                        uv[k]
                    );
                }
                assert!(
                    (0.0..1.0).contains(&(got[k] as f64)) || scene.planes.is_empty(),
                    "uv out of [0, 1): {}",
                    got[k]
                );
            }
            let gu = DVec3::new(got[2] as f64, got[3] as f64, got[4] as f64);
            let gv = DVec3::new(got[5] as f64, got[6] as f64, got[7] as f64);
            assert!((gu - dpdu).length() < 1e-4, "dpdu {gu} vs {dpdu} at {p}");
            assert!((gv - dpdv).length() < 1e-4, "dpdv {gv} vs {dpdv} at {p}");
        }
    }
}

#[test]
fn bump_formula_matches_f64() {
    let device = common::device();
    let mut rng = SmallRng::seed_from_u64(33);
    let count = 5000;
    let mut frames = Vec::new();
    let mut grads = Vec::new();
    let mut want = Vec::new();
    for i in 0..count {
        let n = common::random_unit(&mut rng);
        let (t, b) = n.any_orthonormal_pair();
        let g: [f64; 2] = match i % 5 {
            0 => [1.0, -1.0], // the extremes of the gradients' range
            1 => [0.0, 0.0],
            _ => [rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)],
        };
        let nu = (1.0 - g[0].abs()) * n + t * g[0];
        want.push(((1.0 - g[1].abs()) * nu + b * g[1]).normalize());
        frames.extend([n, t, b].iter().flat_map(|v| v.as_vec3().to_array()));
        grads.push(Float2::new(g[0] as f32, g[1] as f32));
    }
    let (fb, gb) = (
        common::buffer(&device, &frames),
        common::buffer(&device, &grads),
    );
    let out = common::output::<f32>(&device, count * 3);
    let program = common::probes(&device);
    let kernel = NamedArgs::new(&program, "probe_bump", &device.queue)
        .buffer("frames", &fb)
        .buffer("g", &gb)
        .buffer("out", &out)
        .build()
        .unwrap();
    common::run(&kernel, count);
    for (got, want) in common::read(&out).chunks_exact(3).zip(want) {
        let got = DVec3::new(got[0] as f64, got[1] as f64, got[2] as f64);
        assert!((got - want).length() < 1e-5, "{got} vs {want}");
    }
}

/// The mean of the picture of an emission-mapped plane seen head-on, by quadrature in f64 over
/// each pixel's 2x2 sub-pixels and their tent filters (12x12 points each).
fn quadrature_mean(
    scene: &Scene,
    value: &dyn Fn([f64; 2]) -> [f64; 3],
    dir_u: f64,
    dir_v: f64,
) -> [f64; 3] {
    // In the scene's coordinates (the device's camera sits at their origin).
    let cam = &clpt::scene::camera::CameraBasis::new(&scene.camera).unwrap();
    let k = 24;
    let mut sum = [0.0; 3];
    let mut n = 0.0;
    for py in 0..cam.height {
        for px in 0..cam.width {
            for i in 0..k {
                for j in 0..k {
                    let u = [(i as f64 + 0.5) / k as f64, (j as f64 + 0.5) / k as f64];
                    let d = common::reference::camera_direction(cam, px, py, u).normalize();
                    let t = -cam.origin.z / d.z;
                    let p = cam.origin + t * d;
                    let v = value([p.x * dir_u, p.y * dir_v]);
                    for c in 0..3 {
                        sum[c] += v[c];
                    }
                    n += 1.0;
                }
            }
        }
    }
    sum.map(|s| s / n)
}

#[test]
fn rendered_emission_map_matches_f64_quadrature() {
    let dir = temp_dir("emission");
    let mut rng = SmallRng::seed_from_u64(34);
    let (w, h) = (4u32, 3u32);
    let texels: Vec<[u8; 3]> = (0..w * h)
        .map(|_| [rng.random(), rng.random(), rng.random()])
        .collect();
    image::RgbImage::from_fn(w, h, |x, row| image::Rgb(texels[(row * w + x) as usize]))
        .save(dir.join("glow.png"))
        .unwrap();
    let (dir_u, dir_v) = (0.37, 0.29);
    let scene = mapped_scene(
        &dir,
        "Material { color 0 0 0 texture { emission glow.png } }",
        &format!("centerp 0 0 0 dirU {dir_u} 0 0 dirV 0 {dir_v} 0"),
    );
    let value_at =
        |x: u32, y: u32| texels[((h - 1 - y) * w + x) as usize].map(|c| c as f64 / 255.0);
    for (filter, nearest) in [
        (TextureFilter::Bilinear, false),
        (TextureFilter::Nearest, true),
    ] {
        let options = RenderOptions {
            spp: Some(64),
            seed: 9,
            texture_filter: filter,
            ..Default::default()
        };
        let device = common::device();
        let film = Renderer::new(&device, &scene, &KernelSources::Embedded, options)
            .unwrap()
            .render(&mut |_| {})
            .unwrap()
            .0;
        let want = quadrature_mean(
            &scene,
            &|uv| reference_lookup(w, h, &value_at, uv, nearest),
            dir_u,
            dir_v,
        );
        let pixels = (film.width * film.height) as f64;
        for (c, want) in want.into_iter().enumerate() {
            let mut mean = 0.0;
            let mut var = 0.0;
            for y in 0..film.height {
                for x in 0..film.width {
                    mean += film.mean(x, y)[c] / pixels;
                    var += film.variance_of_mean(x, y)[c] / (pixels * pixels);
                }
            }
            let se = var.sqrt().max(1e-9);
            let z = (mean - want) / se;
            assert!(
                z.abs() < 5.0,
                "{filter:?} channel {c}: image mean {mean:.5}, f64 {want:.5} (z {z:.2})"
            );
        }
    }
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn case0_texture_renders_small_without_nan_or_inf() {
    let Some(seed) = common::seed_dir("case0_texture_renders_small_without_nan_or_inf") else {
        return;
    };
    let mut scene = Scene::load(&seed.join("testcases/case0_texture.txt")).unwrap();
    scene.camera.width = 64;
    scene.camera.height = 36;
    let device = common::device();
    let options = RenderOptions {
        spp: Some(8),
        ..Default::default()
    };
    let mut renderer = Renderer::new(&device, &scene, &KernelSources::Embedded, options).unwrap();
    assert_eq!(
        renderer.packed.textures.maps.len(),
        9,
        "case0 uses nine maps"
    );
    let film = renderer.render(&mut |_| {}).unwrap().0;
    let bad = film.sum.iter().flatten().filter(|v| !v.is_finite()).count();
    assert_eq!(bad, 0, "{bad} NaN or Inf values in case0");
    let lit = film.sum.iter().filter(|s| s[0] + s[1] + s[2] > 0.0).count();
    assert!(
        lit > film.sum.len() / 2,
        "case0 mostly black: {lit} lit pixels"
    );
}

#[test]
fn a_mapped_plane_needs_its_axes() {
    let dir = temp_dir("axes");
    image::RgbImage::new(2, 2).save(dir.join("c.png")).unwrap();
    let text = "PerspectiveCamera { center 0 0 10 direction 0 0 -1 angle 30 width 8 height 8 }\n\
                Materials { numMaterials 1 Material { texture { color c.png } } }\n\
                Group { numObjects 1 Plane { normal 0 0 1 offset 0 range 10 } }\n";
    std::fs::write(dir.join("s.txt"), text).unwrap();
    let scene = Scene::load(&dir.join("s.txt")).unwrap();
    let err = PackedScene::new(&scene, u64::MAX).unwrap_err().to_string();
    assert!(err.contains("s.txt:3:22") && err.contains("dirU"), "{err}");
    let _ = parse_scene(text, "s.txt").unwrap();
    // A kind without texture coordinates refuses the maps; a sphere takes them.
    let revolved = text.replace(
        "Plane { normal 0 0 1 offset 0 range 10 }",
        "RevSurface { profile BezierCurve { controls [ 1 0 0 ] [ 2 1 0 ] [ 1 2 0 ] [ 2 3 0 ] } }",
    );
    std::fs::write(dir.join("r.txt"), &revolved).unwrap();
    let scene = Scene::load(&dir.join("r.txt")).unwrap();
    let err = PackedScene::new(&scene, u64::MAX).unwrap_err().to_string();
    assert!(
        err.contains("r.txt:3:22") && err.contains("no texture coordinates"),
        "{err}"
    );
    let sphere = text.replace(
        "Plane { normal 0 0 1 offset 0 range 10 }",
        "Sphere { center 0 0 0 radius 1 }",
    );
    std::fs::write(dir.join("b.txt"), &sphere).unwrap();
    let scene = Scene::load(&dir.join("b.txt")).unwrap();
    PackedScene::new(&scene, u64::MAX).unwrap();
    std::fs::remove_dir_all(dir).ok();
}
