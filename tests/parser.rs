//! The scene-file parser against the original's own scenes, a table of malformed scenes, and
//! truncated or mangled input.

mod common;

use clpt::error::ParseError;
use clpt::scene::parse::parse_scene;
use clpt::scene::{MaterialKind, Scene};
use clpt::shapes::{PlaneShape, Shape, SphereShape};
use glam::DVec3;
use std::path::{Path, PathBuf};

fn read_testcase(seed: &Path, name: &str) -> String {
    let path = seed.join("testcases").join(name);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// A scene's warnings as (line, column, message).
fn warnings_of(scene: &Scene) -> Vec<(usize, usize, &str)> {
    scene
        .warnings
        .iter()
        .map(|w| (w.location.line, w.location.column, w.message.as_str()))
        .collect()
}

fn parse_testcase(seed: &Path, name: &str) -> Scene {
    parse_scene(&read_testcase(seed, name), name).unwrap_or_else(|e| panic!("{e}"))
}

fn v(x: f64, y: f64, z: f64) -> DVec3 {
    DVec3::new(x, y, z)
}

fn normals(scene: &Scene) -> Vec<DVec3> {
    scene
        .objects
        .iter()
        .filter_map(|o| match o.shape {
            Shape::Plane(PlaneShape { normal, .. }) => Some(normal),
            _ => None,
        })
        .collect()
}

fn material_indices(scene: &Scene) -> Vec<usize> {
    scene.objects.iter().map(|o| o.material).collect()
}

#[test]
fn originals_of_spheres_and_planes_parse() {
    let Some(seed) = common::seed_dir("originals_of_spheres_and_planes_parse") else {
        return;
    };
    for (name, materials, objects) in [
        ("case0_texture.txt", 18, 11),
        ("case2_softshadows_colorbleeding.txt", 12, 6),
        ("case4_planets.txt", 13, 2),
        ("case5_light_balls.txt", 13, 2),
        ("debug_texture.txt", 1, 1),
        ("default.txt", 10, 8),
        ("planets.txt", 5, 6),
    ] {
        let scene = parse_testcase(&seed, name);
        assert_eq!(scene.source, name);
        assert_eq!(scene.materials.len(), materials, "{name}");
        assert_eq!(scene.objects.len(), objects, "{name}");
        if !name.starts_with("case2") {
            assert_eq!(scene.warnings, [], "{name}");
        }
    }
}

#[test]
fn case2_loads_with_its_two_slips_as_warnings() {
    let Some(seed) = common::seed_dir("case2_loads_with_its_two_slips_as_warnings") else {
        return;
    };
    let scene = parse_testcase(&seed, "case2_softshadows_colorbleeding.txt");
    let cam = &scene.camera;
    assert_eq!((cam.width, cam.height), (1024, 768));
    assert_eq!(
        (cam.center, cam.direction),
        (v(0.0, 60.0, 500.0), v(0.0, 0.0, -1.0))
    );
    assert_eq!((cam.angle_deg, cam.flength, cam.aperture), (30.0, 0.0, 4.0));

    assert_eq!(scene.materials.len(), 12);
    let light = &scene.materials[0];
    assert_eq!(
        (light.emission, light.color),
        (v(0.42, 0.41, 0.4), DVec3::ZERO)
    );
    assert_eq!((light.location.line, light.location.column), (15, 5));
    assert_eq!(scene.materials[5].kind, MaterialKind::Specular);
    assert_eq!(scene.materials[6].kind, MaterialKind::Refractive);
    let textured = &scene.materials[7];
    assert_eq!(
        textured.textures.color.as_deref(),
        Some(Path::new("texture/planet4.ppm"))
    );
    assert_eq!(
        (textured.color, textured.kind),
        (DVec3::ONE, MaterialKind::Diffuse)
    );
    assert_eq!(
        scene.materials[11].textures.kind,
        Some(PathBuf::from("texture/laughingman_spec.ppm"))
    );

    assert_eq!(scene.objects.len(), 6);
    assert_eq!(material_indices(&scene), [0, 0, 3, 3, 3, 3]);
    assert_eq!(
        normals(&scene),
        [
            v(0.0, -1.0, 0.0),
            v(0.0, 0.0, -1.0),
            v(-1.0, 0.0, 0.0),
            v(1.0, 0.0, 0.0),
            v(0.0, 0.0, 1.0),
            v(0.0, 1.0, 0.0),
        ]
    );
    assert_eq!(
        scene.objects[2].shape,
        Shape::Plane(PlaneShape {
            normal: v(-1.0, 0.0, 0.0),
            offset: -100.0,
            range: 1000.0,
            centerp: v(100.0, 0.0, -100.0),
            dir_u: v(0.0, 0.0, 0.01),
            dir_v: v(0.0, 0.01, 0.0),
        })
    );
    assert_eq!(
        (
            scene.objects[2].location.line,
            scene.objects[2].location.column
        ),
        (72, 5)
    );

    let warnings = warnings_of(&scene);
    assert_eq!(
        warnings,
        [
            (
                59,
                16,
                "`numObjects` declares 9 objects, but the group lists 6"
            ),
            (104, 5, "`MaterialIndex` without a number is ignored"),
        ]
    );
    assert_eq!(
        scene.warnings[1].to_string(),
        "case2_softshadows_colorbleeding.txt:104:5: warning: \
         `MaterialIndex` without a number is ignored"
    );
}

#[test]
fn case0_objects_and_textures() {
    let Some(seed) = common::seed_dir("case0_objects_and_textures") else {
        return;
    };
    let scene = parse_testcase(&seed, "case0_texture.txt");
    assert_eq!((scene.camera.width, scene.camera.height), (2560, 1440));
    assert_eq!(
        material_indices(&scene),
        [0, 0, 5, 6, 7, 11, 13, 13, 14, 16, 17]
    );
    let spheres: Vec<(DVec3, f64)> = scene
        .objects
        .iter()
        .filter_map(|o| match o.shape {
            Shape::Sphere(SphereShape { center, radius }) => Some((center, radius)),
            _ => None,
        })
        .collect();
    assert_eq!(
        spheres,
        [
            (v(40.0, 12.0, 80.0), 12.0),
            (v(-40.0, 12.0, 80.0), 12.0),
            (v(-40.0, 80.0, 150.0), 32.0),
            (v(24.0, 77.0, 180.0), 8.0),
            (v(50.0, 77.0, 150.0), 22.0),
        ]
    );
    let earth = &scene.materials[17].textures;
    assert_eq!(earth.color, Some(PathBuf::from("texture/earthmap1k.ppm")));
    assert_eq!(earth.bump, Some(PathBuf::from("texture/earthbump1k.ppm")));
    assert_eq!((earth.emission.as_ref(), earth.kind.as_ref()), (None, None));
    assert_eq!(
        scene.materials[12].textures.emission,
        Some(PathBuf::from("texture/planet4.ppm"))
    );
    assert_eq!(scene.materials[0].emission, v(0.5, 0.5, 0.5));
    assert_eq!(scene.materials[0].color, DVec3::ONE);
}

#[test]
fn default_scene_materials() {
    let Some(seed) = common::seed_dir("default_scene_materials") else {
        return;
    };
    let scene = parse_testcase(&seed, "default.txt");
    let kinds: Vec<MaterialKind> = scene.materials.iter().map(|m| m.kind).collect();
    use MaterialKind::*;
    assert_eq!(
        kinds,
        [
            Diffuse, Diffuse, Diffuse, Diffuse, Diffuse, Specular, Refractive, Diffuse, Diffuse,
            Diffuse
        ]
    );
    assert_eq!(scene.materials[0].emission, v(12.0, 12.0, 12.0));
    assert_eq!(scene.materials[4].color, DVec3::ZERO);
    assert!(scene.materials[..7].iter().all(|m| m.textures.is_empty()));
    let window = &scene.materials[9].textures;
    assert_eq!(window.color, Some(PathBuf::from("texture/window2.ppm")));
    assert_eq!(window.kind, Some(PathBuf::from("texture/window2_type.ppm")));
    assert_eq!(material_indices(&scene), [0, 3, 3, 3, 3, 6, 8, 9]);
    assert_eq!(
        scene.objects[0].shape,
        Shape::Sphere(SphereShape {
            center: v(230.0, 180.0, 120.0),
            radius: 100.0
        })
    );
}

#[test]
fn originals_with_meshes_and_curves_parse() {
    let Some(seed) = common::seed_dir("originals_with_meshes_and_curves_parse") else {
        return;
    };
    for (name, meshes, curves) in [
        ("case1_dof_mesh.txt", 3, 0),
        ("debug_scenepareser.txt", 1, 0),
        ("case3_wineglass.txt", 0, 1),
        ("default-0.txt", 0, 1),
        ("default-bak.txt", 0, 1),
        ("scene08_core.txt", 0, 1),
    ] {
        let scene = parse_testcase(&seed, name);
        let count = |f: fn(&Shape) -> bool| scene.objects.iter().filter(|o| f(&o.shape)).count();
        assert_eq!(
            count(|s| matches!(s, Shape::Mesh(_))),
            meshes,
            "{name}: meshes"
        );
        assert_eq!(
            count(|s| matches!(s, Shape::RevSurface(_))),
            curves,
            "{name}: curves"
        );
        assert!(
            scene.objects.iter().all(
                |o| !matches!(o.shape, Shape::Mesh(_) | Shape::RevSurface(_))
                    || o.transform.is_some()
            ),
            "{name}: transforms"
        );
    }
}

/// Three one-line blocks: the camera's fields start at column 21, the materials' at 13 and the
/// group's at 9.
fn scene(camera: &str, materials: &str, group: &str) -> String {
    format!("PerspectiveCamera {{ {camera} }}\nMaterials {{ {materials} }}\nGroup {{ {group} }}\n")
}

const CAMERA: &str = "center 0 0 0 direction 0 0 -1 angle 30 width 4 height 3";
const MATERIALS: &str = "numMaterials 2 Material { } Material { type spec }";
const GROUP: &str = "numObjects 1 Sphere { center 0 0 0 radius 1 }";

fn with_camera(camera: &str) -> String {
    scene(camera, MATERIALS, GROUP)
}

fn with_materials(materials: &str) -> String {
    scene(CAMERA, materials, GROUP)
}

fn with_group(group: &str) -> String {
    scene(CAMERA, MATERIALS, group)
}

#[test]
fn the_table_scenes_are_valid_when_unchanged() {
    let scene = parse_scene(&scene(CAMERA, MATERIALS, GROUP), "t").unwrap();
    assert_eq!(scene.warnings, []);
    assert_eq!(scene.objects.len(), 1);
}

#[test]
fn malformed_scenes_fail_where_the_mistake_is() {
    let valid = scene(CAMERA, MATERIALS, GROUP);
    let cases: Vec<(&str, String, usize, usize, &str)> = vec![
        (
            "unknown top-level word",
            format!("Camera {{ }}\n{valid}"),
            1,
            1,
            "expected `PerspectiveCamera`, `Materials` or `Group`, found `Camera`",
        ),
        (
            "unknown camera field",
            with_camera("center 0 0 0 fov 30 direction 0 0 -1 angle 30 width 4 height 3"),
            1,
            34,
            "`aperture` or `}` in `PerspectiveCamera`, found `fov`",
        ),
        (
            "missing number",
            with_camera("center 0 0 0 direction 0 0 -1 angle width 4 height 3"),
            1,
            57,
            "expected a number for `angle`, found `width`",
        ),
        (
            "malformed number",
            with_group("numObjects 1 Sphere { center 0 0 0 radius 1.2.3 }"),
            3,
            51,
            "expected a number for `radius`, found `1.2.3`",
        ),
        (
            "word for a number",
            with_group("numObjects 1 Sphere { center 0 0 0 radius abc }"),
            3,
            51,
            "expected a number for `radius`, found `abc`",
        ),
        (
            "NaN",
            with_group("numObjects 1 Sphere { center 0 0 0 radius NaN }"),
            3,
            51,
            "expected a finite number for `radius`, found `NaN`",
        ),
        (
            "infinity in a vector",
            with_group("numObjects 1 Sphere { center 0 inf 0 radius 1 }"),
            3,
            40,
            "expected a finite number for `center`",
        ),
        (
            "overflow to infinity",
            with_group("numObjects 1 Plane { normal 0 1 0 offset 1e999 range 1 }"),
            3,
            50,
            "finite number for `offset`, found `1e999`",
        ),
        (
            "material index out of range",
            with_group("numObjects 1 MaterialIndex 2 Sphere { center 0 0 0 radius 1 }"),
            3,
            36,
            "expected a material index from 0 to 1, found `2`",
        ),
        (
            "negative material index",
            with_group("numObjects 1 MaterialIndex -1 Sphere { center 0 0 0 radius 1 }"),
            3,
            36,
            "expected a non-negative integer for `MaterialIndex`, found `-1`",
        ),
        (
            "fractional material index",
            with_group("numObjects 1 MaterialIndex 1.5 Sphere { center 0 0 0 radius 1 }"),
            3,
            36,
            "expected an integer for `MaterialIndex`, found `1.5`",
        ),
        (
            "material index checked after a late Materials block",
            format!(
                "PerspectiveCamera {{ {CAMERA} }}\n\
                 Group {{ numObjects 1 MaterialIndex 5 Sphere {{ center 0 0 0 radius 1 }} }}\n\
                 Materials {{ numMaterials 1 Material {{ }} }}\n"
            ),
            2,
            36,
            "from 0 to 0, found `5`",
        ),
        (
            "objects but no materials",
            with_materials("numMaterials 0"),
            3,
            22,
            "expected `Materials` to define material 0 used by this object, found 0 materials",
        ),
        (
            "wrong material type",
            with_materials("numMaterials 2 Material { } Material { type glass }"),
            2,
            57,
            "expected `diff`, `spec` or `refr` for `type`, found `glass`",
        ),
        (
            "duplicate field",
            with_group("numObjects 1 Sphere { center 0 0 0 radius 1 radius 2 }"),
            3,
            53,
            "expected `radius` only once, found it again (first at 3:44)",
        ),
        (
            "duplicate camera field",
            with_camera(&format!("{CAMERA} angle 40")),
            1,
            77,
            "expected `angle` only once, found it again (first at 1:51)",
        ),
        (
            "missing sphere radius",
            with_group("numObjects 1 Sphere { center 0 0 0 }"),
            3,
            44,
            "expected `radius` in `Sphere` opened at 3:22, found `}`",
        ),
        (
            "missing camera width",
            with_camera("center 0 0 0 direction 0 0 -1 angle 30 height 3"),
            1,
            69,
            "expected `width` in `PerspectiveCamera` opened at 1:1, found `}`",
        ),
        (
            "missing plane range",
            with_group("numObjects 1 Plane { normal 0 1 0 offset 0 }"),
            3,
            52,
            "expected `range` in `Plane` opened at 3:22",
        ),
        (
            "unclosed block at end of file",
            format!(
                "PerspectiveCamera {{ {CAMERA} }}\nMaterials {{ {MATERIALS} }}\n\
                 Group {{ numObjects 1 Sphere {{ center 0 0 0 radius 1 }}\n"
            ),
            3,
            54,
            "expected `}` to close `Group` opened at 3:1, found end of file",
        ),
        (
            "end of file inside a value",
            format!(
                "PerspectiveCamera {{ {CAMERA} }}\nMaterials {{ {MATERIALS} }}\n\
                 Group {{ numObjects 1 Sphere {{ center 0 0"
            ),
            3,
            41,
            "expected a number for `center`, which takes three, \
             found end of file inside `Sphere` opened at 3:22",
        ),
        (
            "end of file after a keyword",
            format!("PerspectiveCamera {{ {CAMERA} }}\nMaterials"),
            2,
            10,
            "expected `{` after `Materials`, found end of file",
        ),
        (
            "empty file",
            String::new(),
            1,
            1,
            "expected `PerspectiveCamera`, `Materials` and `Group` blocks, found end of file",
        ),
        (
            "only a comment",
            "  # nothing here\n".to_string(),
            1,
            1,
            "`Group` blocks, found end of file",
        ),
        (
            "missing Group",
            format!("PerspectiveCamera {{ {CAMERA} }}\nMaterials {{ {MATERIALS} }}\n"),
            2,
            65,
            "expected a `Group` block, found end of file",
        ),
        (
            "stray closing brace",
            format!("{valid}}}\n"),
            4,
            1,
            "expected `PerspectiveCamera`, `Materials` or `Group`, found `}`",
        ),
        (
            "vector with two numbers",
            with_group("numObjects 1 Sphere { center 0 0 radius 1 }"),
            3,
            42,
            "expected a number for `center`, which takes three, found `radius`",
        ),
        (
            "width 0",
            with_camera("center 0 0 0 direction 0 0 -1 angle 30 width 0 height 3"),
            1,
            66,
            "expected `width` between 1 and 65536, found `0`",
        ),
        (
            "height too large",
            with_camera("center 0 0 0 direction 0 0 -1 angle 30 width 4 height 70000"),
            1,
            75,
            "expected `height` between 1 and 65536, found `70000`",
        ),
        (
            "fractional width",
            with_camera("center 0 0 0 direction 0 0 -1 angle 30 width 4.5 height 3"),
            1,
            66,
            "expected an integer for `width`, found `4.5`",
        ),
        (
            "angle 200",
            with_camera("center 0 0 0 direction 0 0 -1 angle 200 width 4 height 3"),
            1,
            57,
            "expected `angle` greater than 0 and less than 180, found `200`",
        ),
        (
            "zero direction",
            with_camera("center 0 0 0 direction 0 0 0 angle 30 width 4 height 3"),
            1,
            44,
            "expected a nonzero vector for `direction`, found the zero vector",
        ),
        (
            "negative flength",
            with_camera(&format!("{CAMERA} flength -1")),
            1,
            85,
            "expected `flength` of at least 0, found `-1`",
        ),
        (
            "radius -1",
            with_group("numObjects 1 Sphere { center 0 0 0 radius -1 }"),
            3,
            51,
            "expected `radius` greater than 0, found `-1`",
        ),
        (
            "zero plane normal",
            with_group("numObjects 1 Plane { normal 0 0 0 offset 0 range 1 }"),
            3,
            37,
            "expected a nonzero vector for `normal`",
        ),
        (
            "plane range 0",
            with_group("numObjects 1 Plane { normal 0 1 0 offset 0 range 0 }"),
            3,
            58,
            "expected `range` greater than 0, found `0`",
        ),
        (
            "unknown texture key",
            with_materials("numMaterials 2 Material { } Material { texture { normal a.ppm } }"),
            2,
            62,
            "`bump` or `}` in `texture`, found `normal`",
        ),
        (
            "texture key without a path",
            with_materials("numMaterials 2 Material { } Material { texture { color } }"),
            2,
            68,
            "expected a file path for `color`, found `}`",
        ),
        (
            "duplicate texture key",
            with_materials(
                "numMaterials 2 Material { } Material { texture { color a.ppm color b.ppm } }",
            ),
            2,
            74,
            "expected `color` only once, found it again (first at 2:62)",
        ),
        (
            "unknown material field",
            with_materials("numMaterials 2 Material { } Material { shine 3 }"),
            2,
            52,
            "`texture` or `}` in `Material`, found `shine`",
        ),
        (
            "missing numMaterials",
            with_materials("Material { }"),
            2,
            13,
            "expected `numMaterials`, found `Material`",
        ),
        (
            "negative numObjects",
            with_group("numObjects -1 Sphere { center 0 0 0 radius 1 }"),
            3,
            20,
            "expected a non-negative integer for `numObjects`, found `-1`",
        ),
        (
            "unknown object",
            with_group("numObjects 1 Cube { }"),
            3,
            22,
            "expected `MaterialIndex`, `Sphere`, `Plane`, `Mesh`, `TriangleMesh`, `RevSurface`, \
             `Transform` or `}` in `Group`, found `Cube`",
        ),
        (
            "object without its brace",
            with_group("numObjects 1 Sphere center 0 0 0 radius 1"),
            3,
            29,
            "expected `{` after `Sphere`, found `center`",
        ),
        (
            "second camera block",
            format!("{valid}PerspectiveCamera {{ }}\n"),
            4,
            1,
            "expected `PerspectiveCamera` only once, found it again (first at 1:1)",
        ),
        (
            "Transform without an object",
            with_group("numObjects 1 Transform { }"),
            3,
            22,
            "`Transform` without an object",
        ),
        (
            "RevSurface without a profile",
            with_group("numObjects 1 RevSurface { }"),
            3,
            35,
            "expected `profile` in `RevSurface` opened at 3:22, found `}`",
        ),
        (
            "profile out of the xy-plane",
            with_group(
                "numObjects 1 RevSurface { profile BezierCurve { controls [ 0 0 0 ] [ 1 1 0.5 ] } }",
            ),
            3,
            82,
            "control point 2 of the profile has z = 0.5",
        ),
        (
            "unknown curve kind",
            with_group("numObjects 1 RevSurface { profile NurbsCurve { } }"),
            3,
            43,
            "expected `BezierCurve` or `BsplineCurve`, found `NurbsCurve`",
        ),
        (
            "TriangleMesh without its file",
            with_group("numObjects 1 TriangleMesh { }"),
            3,
            37,
            "expected `obj_file` in `TriangleMesh` opened at 3:22, found `}`",
        ),
        (
            "Matrix4f with 15 numbers",
            with_group(
                "numObjects 1 Transform { Matrix4f { 1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 } Sphere { center 0 0 0 radius 1 } }",
            ),
            3,
            75,
            "expected a number for `Matrix4f`, found `}`",
        ),
    ];
    assert!(cases.len() >= 20);
    let mut failures = Vec::new();
    for (name, text, line, column, fragment) in &cases {
        match parse_scene(text, "bad.txt") {
            Ok(_) => failures.push(format!("{name}: parsed, expected an error")),
            Err(ParseError { location, message }) => {
                if (location.line, location.column) != (*line, *column)
                    || !message.contains(fragment)
                    || location.file != "bad.txt"
                {
                    failures.push(format!(
                        "{name}: got {location}: {message}\n  want {line}:{column}: ...{fragment}..."
                    ));
                }
            }
        }
    }
    assert!(failures.is_empty(), "\n{}", failures.join("\n"));
}

#[test]
fn errors_display_as_file_line_column_message() {
    let err = parse_scene(&with_camera("center 0 0 0"), "scenes/x.txt").unwrap_err();
    assert_eq!(
        err.to_string(),
        "scenes/x.txt:1:34: expected `direction` in `PerspectiveCamera` opened at 1:1, found `}`"
    );
}

/// Exercises every field, optional parts, comments and the bare `MaterialIndex` slip.
const RICH: &str = "\
# A scene with every field.
Group {
    numObjects 4
    Sphere { radius 2 center 1 2 3 }   # material 0 by default
    MaterialIndex 2
    Plane { offset -1 normal 0 2 0 range 10 dirV 0 0 1 dirU 1 0 0 centerp 0 -1 0 }
    MaterialIndex
    Plane { normal 1 0 0 range 5 offset 3 }
}
Materials {
    numMaterials 4
    Material { type refr color 0.5 0.5 0.5 emission 1 1 1 }
    Material { texture { bump b.ppm type t.ppm emission e.ppm color c.ppm } }
    Material { type spec }
}
PerspectiveCamera {
    aperture 0.5 flength 100 height 9 width 16 angle 45 direction 0 0 -2 center 0 1 2
}
";

#[test]
fn blocks_and_fields_in_any_order_with_comments() {
    let scene = parse_scene(RICH, "rich.txt").unwrap();
    let cam = &scene.camera;
    assert_eq!((cam.width, cam.height, cam.angle_deg), (16, 9, 45.0));
    assert_eq!((cam.flength, cam.aperture), (100.0, 0.5));
    assert_eq!(cam.direction, v(0.0, 0.0, -2.0));
    assert_eq!(material_indices(&scene), [0, 2, 2]);
    assert_eq!(
        scene.objects[1].shape,
        Shape::Plane(PlaneShape {
            normal: v(0.0, 2.0, 0.0),
            offset: -1.0,
            range: 10.0,
            centerp: v(0.0, -1.0, 0.0),
            dir_u: v(1.0, 0.0, 0.0),
            dir_v: v(0.0, 0.0, 1.0),
        })
    );
    assert_eq!(
        scene.objects[2].shape,
        Shape::Plane(PlaneShape {
            normal: v(1.0, 0.0, 0.0),
            offset: 3.0,
            range: 5.0,
            centerp: DVec3::ZERO,
            dir_u: DVec3::ZERO,
            dir_v: DVec3::ZERO,
        })
    );
    let m = &scene.materials;
    assert_eq!(
        (m[0].kind, m[0].color, m[0].emission),
        (MaterialKind::Refractive, v(0.5, 0.5, 0.5), DVec3::ONE)
    );
    assert_eq!(m[1].textures.bump, Some(PathBuf::from("b.ppm")));
    assert_eq!(m[1].textures.kind, Some(PathBuf::from("t.ppm")));
    assert_eq!(m[1].textures.emission, Some(PathBuf::from("e.ppm")));
    assert_eq!(m[1].textures.color, Some(PathBuf::from("c.ppm")));
    assert_eq!((m[2].location.line, m[2].location.column), (14, 5));

    let warnings = warnings_of(&scene);
    assert_eq!(
        warnings,
        [
            (
                3,
                16,
                "`numObjects` declares 4 objects, but the group lists 3"
            ),
            (7, 5, "`MaterialIndex` without a number is ignored"),
            (
                11,
                18,
                "`numMaterials` declares 4 materials, but 3 `Material` blocks follow"
            ),
        ]
    );
}

#[test]
fn glued_brackets_read_like_spaced_ones() {
    let glued = "PerspectiveCamera{center 0 0 0 direction 0 0 -1 angle 30 width 4 height 3}\
                 Materials{numMaterials 1 Material{texture{color a.ppm}}}\
                 Group{numObjects 2 Sphere{center 0 0 0 radius 1}Plane{normal 0 1 0 offset 0 range 1}}";
    let spaced = "PerspectiveCamera { center 0 0 0 direction 0 0 -1 angle 30 width 4 height 3 }\n\
                  Materials { numMaterials 1 Material { texture { color a.ppm } } }\n\
                  Group { numObjects 2 Sphere { center 0 0 0 radius 1 } Plane { normal 0 1 0 offset 0 range 1 } }";
    let (glued, spaced) = (
        parse_scene(glued, "g").unwrap(),
        parse_scene(spaced, "s").unwrap(),
    );
    assert_eq!(glued.camera, spaced.camera);
    let shapes = |s: &Scene| {
        s.objects
            .iter()
            .map(|o| o.shape.clone())
            .collect::<Vec<_>>()
    };
    assert_eq!(shapes(&glued), shapes(&spaced));
    assert_eq!(glued.materials[0].textures, spaced.materials[0].textures);
    assert_eq!(
        glued.materials[0].textures.color,
        Some(PathBuf::from("a.ppm"))
    );
    assert_eq!(
        (
            glued.objects[1].location.line,
            glued.objects[1].location.column
        ),
        (1, 179)
    );
}

#[test]
fn a_comment_can_follow_a_word_directly() {
    let text = with_group("numObjects 1 Sphere { center 0 0 0 radius 1#2 }\n }");
    let scene = parse_scene(&text, "c").unwrap();
    assert_eq!(
        scene.objects[0].shape,
        Shape::Sphere(SphereShape {
            center: DVec3::ZERO,
            radius: 1.0
        })
    );
}

/// Byte ranges of the whitespace-separated words of `text`.
fn word_spans(text: &str) -> Vec<(usize, usize)> {
    let mut spans = Vec::new();
    let mut start = None;
    for (i, c) in text.char_indices().chain([(text.len(), ' ')]) {
        match (start, c.is_whitespace()) {
            (None, false) => start = Some(i),
            (Some(s), true) => {
                spans.push((s, i));
                start = None;
            }
            _ => {}
        }
    }
    spans
}

/// A parse that must not panic, and whose error, if any, points inside the text or just after.
fn parse_quietly(text: &str) {
    if let Err(err) = parse_scene(text, "cut.txt") {
        let lines = text.split('\n').count();
        assert!(
            err.location.line >= 1 && err.location.line <= lines && err.location.column >= 1,
            "{err} for {text:?}"
        );
    }
}

#[test]
fn every_truncation_and_token_deletion_is_handled() {
    let mut texts = vec![RICH.to_string(), scene(CAMERA, MATERIALS, GROUP)];
    if let Some(seed) = common::seed_dir("every_truncation_and_token_deletion_is_handled") {
        texts.push(read_testcase(&seed, "case2_softshadows_colorbleeding.txt"));
    }
    for text in &texts {
        for (cut, _) in text.char_indices() {
            parse_quietly(&text[..cut]);
        }
        for (start, end) in word_spans(text) {
            parse_quietly(&format!("{}{}", &text[..start], &text[end..]));
        }
    }
}

#[test]
fn mangled_tokens_are_handled() {
    let replacements = [
        "",
        "{",
        "}",
        "[",
        "]",
        "#",
        "-1",
        "0",
        "1e400",
        "nan",
        "-0",
        "18446744073709551616",
        "Sphere",
        "Plane",
        "Transform",
        "MaterialIndex",
        "Group",
        "Materials",
        "Material",
        "PerspectiveCamera",
        "texture",
        "é",
        "\u{feff}",
        "\r\n",
    ];
    let spans = word_spans(RICH);
    // A fixed linear congruential sequence keeps the test reproducible without dependencies.
    let mut state: u64 = 0x5eed;
    let mut pick = |n: usize| {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 33) as usize % n
    };
    for _ in 0..3000 {
        let mut text = RICH.to_string();
        for _ in 0..3 {
            let (start, end) = spans[pick(spans.len())];
            if let (Some(_), Some(_)) = (text.get(..start), text.get(end..)) {
                text.replace_range(start..end, replacements[pick(replacements.len())]);
            }
        }
        parse_quietly(&text);
    }
}

/// Every scene shipped in scenes/ loads and packs: its textures decode, its meshes load and get
/// their kd-trees, its light list builds.
#[test]
fn every_shipped_scene_loads_and_packs() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut count = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "txt") {
            let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            clpt::pack::PackedScene::new(&scene, u64::MAX)
                .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            count += 1;
        }
    }
    assert!(count >= 8, "{count} scenes in {}", dir.display());
}

/// A colour above 1 would make energy (a closed room of colour 2 gave NaN pixels): it is
/// clamped into [0, 1] with a warning at its `color`, and an ordinary colour passes silently.
#[test]
fn colours_outside_zero_to_one_are_clamped_with_a_warning() {
    let text = "PerspectiveCamera { center 0 0 0 direction 0 0 -1 angle 30 width 4 height 3 }\n\
                Materials { numMaterials 3\n\
                Material { color 100 0.5 -0.25 }\n\
                Material { color 1 1 1 }\n\
                Material { emission 50 50 50 color 2 2 2 } }\n\
                Group { numObjects 1 Sphere { center 0 0 -5 radius 1 } }";
    let scene = parse_scene(text, "gain").unwrap();
    let m = &scene.materials;
    assert_eq!(m[0].color, DVec3::new(1.0, 0.5, 0.0));
    assert_eq!(m[1].color, DVec3::ONE);
    assert_eq!(m[2].color, DVec3::ONE);
    assert_eq!(m[2].emission, DVec3::splat(50.0));
    let warnings = warnings_of(&scene);
    assert_eq!(
        warnings,
        [
            (
                3,
                12,
                "`color 100 0.5 -0.25` is outside [0, 1] (a surface cannot reflect more light \
                 than it receives, nor less than none): clamped to 1 0.5 0"
            ),
            (
                5,
                30,
                "`color 2 2 2` is outside [0, 1] (a surface cannot reflect more light than it \
                 receives, nor less than none): clamped to 1 1 1"
            ),
        ]
    );
}

/// The 1-based line and column (in characters) of the first `needle` in `text`.
fn position_of(text: &str, needle: &str) -> (usize, usize) {
    let at = text
        .find(needle)
        .unwrap_or_else(|| panic!("{needle:?} not in {text:?}"));
    let before = &text[..at];
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    (
        before.matches('\n').count() + 1,
        before[line_start..].chars().count() + 1,
    )
}

/// Parses each (name, scene, where, fragment) and expects an error at the first `where` in the
/// scene whose message holds `fragment`.
fn expect_errors(cases: &[(&str, String, &str, &str)]) {
    let mut failures = Vec::new();
    for (name, text, place, fragment) in cases {
        let (line, column) = position_of(text, place);
        match parse_scene(text, "bad.txt") {
            Ok(_) => failures.push(format!("{name}: parsed, expected an error")),
            Err(ParseError { location, message }) => {
                if (location.line, location.column) != (line, column) || !message.contains(fragment)
                {
                    failures.push(format!(
                        "{name}: got {location}: {message}\n  want {line}:{column}: ...{fragment}..."
                    ));
                }
            }
        }
    }
    assert!(failures.is_empty(), "\n{}", failures.join("\n"));
}

const F32_RANGE: &str = "within f32's range (0, or a magnitude from 1e-45 to 3.4028235e38, as \
                         the device computes in f32)";

/// A number finite in f64 but not in f32 (1e39), or nonzero in f64 but 0 in f32 (1e-50), is an
/// error at the number naming its field and f32's range, wherever it becomes an f32 on the
/// device (a sphere of radius 1e39 was accepted, and one `UniformScale 1e39` blacked out the
/// image).
#[test]
fn numbers_beyond_f32_fail_where_they_are() {
    let sphere = |fields: &str| with_group(&format!("numObjects 1 Sphere {{ {fields} }}"));
    let in_transform = |ops: &str| {
        with_group(&format!(
            "numObjects 1 Transform {{ {ops} Sphere {{ center 0 0 0 radius 1 }} }}"
        ))
    };
    let material =
        |fields: &str| with_materials(&format!("numMaterials 1 Material {{ {fields} }}"));
    let camera = |extra: &str| with_camera(&format!("{CAMERA} {extra}"));
    let plane = |fields: &str| with_group(&format!("numObjects 1 Plane {{ {fields} }}"));
    let curve = |points: &str| {
        with_group(&format!(
            "numObjects 1 RevSurface {{ profile BezierCurve {{ controls {points} }} }}"
        ))
    };
    let f32_error = |field: &str| format!("expected `{field}` {F32_RANGE}, found ");
    let cases: Vec<(&str, String, &str, String)> = vec![
        (
            "radius",
            sphere("center 0 0 0 radius 1e39"),
            "1e39",
            f32_error("radius"),
        ),
        (
            "tiny radius",
            sphere("center 0 0 0 radius 1e-50"),
            "1e-50",
            f32_error("radius"),
        ),
        (
            "centre",
            sphere("center 0 -1e39 0 radius 1"),
            "-1e39",
            f32_error("center"),
        ),
        (
            "emission",
            material("emission 1 1 1e39"),
            "1e39",
            f32_error("emission"),
        ),
        (
            "colour",
            material("color 1e39 0 0"),
            "1e39",
            f32_error("color"),
        ),
        (
            "scale",
            in_transform("Scale 1 1e39 1"),
            "1e39",
            f32_error("Scale"),
        ),
        (
            "uniform scale",
            in_transform("UniformScale 1e39"),
            "1e39",
            f32_error("UniformScale"),
        ),
        (
            "translation",
            in_transform("Translate 0 0 4e38"),
            "4e38",
            f32_error("Translate"),
        ),
        (
            "rotation",
            in_transform("YRotate 1e39"),
            "1e39",
            f32_error("YRotate"),
        ),
        (
            "matrix entry",
            in_transform("Matrix4f { 1e39 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1 }"),
            "1e39",
            f32_error("Matrix4f"),
        ),
        (
            "camera centre",
            with_camera(&CAMERA.replace("center 0 0 0", "center 1e39 0 0")),
            "1e39",
            f32_error("center"),
        ),
        (
            "focal length",
            camera("flength 1e39"),
            "1e39",
            f32_error("flength"),
        ),
        (
            "aperture",
            camera("aperture 1e-60"),
            "1e-60",
            f32_error("aperture"),
        ),
        (
            "plane range",
            plane("normal 0 1 0 offset 0 range 1e39"),
            "1e39",
            f32_error("range"),
        ),
        (
            "plane centre",
            plane("normal 0 1 0 offset 0 range 1 centerp 0 1e39 0"),
            "1e39",
            f32_error("centerp"),
        ),
        (
            "plane dirU",
            plane("normal 0 1 0 offset 0 range 1 dirU 1e39 0 0"),
            "1e39",
            f32_error("dirU"),
        ),
        (
            "control point",
            curve("[ 0 0 0 ] [ 1e39 1 0 ]"),
            "1e39",
            f32_error("controls"),
        ),
        (
            "plane distance",
            plane("normal 0 1 0 offset 1e39 range 1"),
            "1e39",
            "expected `offset` divided by the length of `normal` (the plane's distance from the \
             origin) of at most 3.4028235e38 in magnitude, as the device holds it as an f32, \
             found 1e39 over a normal of length 1.0"
                .into(),
        ),
        (
            "plane distance over a short normal",
            plane("normal 0 1e-30 0 offset 1e10 range 1"),
            "1e10",
            "found 10000000000.0 over a normal of length 1e-30".into(),
        ),
    ];
    let cases: Vec<(&str, String, &str, &str)> = cases
        .iter()
        .map(|(name, text, place, fragment)| (*name, text.clone(), *place, fragment.as_str()))
        .collect();
    expect_errors(&cases);
}

/// Each op may fit f32 while their product does not: the composed matrix of an object, and its
/// inverse, are checked once at the object (two `UniformScale 1e20` gave an entry of 1e40).
#[test]
fn composed_transforms_beyond_f32_fail_at_the_object() {
    let sphere = "Sphere { center 0 0 0 radius 1 }";
    let cases = [
        (
            "product of two scales",
            format!("UniformScale 1e20 UniformScale 1e20 {sphere}"),
            "expected this object's `Transform` matrix and its inverse to have entries of at most \
             3.4028235e38 in magnitude, as the device holds them as f32s, found 1e40 in its matrix",
        ),
        (
            "nested transforms",
            format!("UniformScale 1e20 Transform {{ UniformScale 1e20 {sphere} }}"),
            "found 1e40 in its matrix",
        ),
        (
            "inverse",
            format!("UniformScale 1e-20 Transform {{ UniformScale 1e-20 {sphere} }}"),
            "in its inverse",
        ),
    ];
    let cases: Vec<(&str, String, &str, &str)> = cases
        .iter()
        .map(|(name, ops, fragment)| {
            let text = with_group(&format!("numObjects 1 Transform {{ {ops} }}"));
            (*name, text, "Transform", *fragment)
        })
        .collect();
    expect_errors(&cases);
    // Products in range load, and so do entries that are mere rounding, 0 in f32 (a rotation's
    // 6e-17 under a scale of 1e-30).
    for ops in [
        "UniformScale 1e20 UniformScale 1e-20",
        "UniformScale 1e-30 XRotate 90",
    ] {
        let fine = with_group(&format!("numObjects 1 Transform {{ {ops} {sphere} }}"));
        assert!(parse_scene(&fine, "fine").is_ok(), "{ops}");
    }
}

/// A transform is singular by its axes' own lengths, not by its largest entry: scales of any
/// size on any axis, and far translations, load (they were "singular"); collapsed or nearly
/// aligned axes do not.
#[test]
fn singular_transforms_are_judged_by_their_own_axes() {
    let sphere = "Sphere { center 0 0 0 radius 1 }";
    for ops in [
        "UniformScale 1e-4",
        "Scale 1 1e20 1",
        "Scale 1e-6 1 1e6",
        "Translate 1e5 0 0 UniformScale 1e-3",
        "Translate 0 1e4 0",
        "UniformScale 1e30 UniformScale 1e-35",
    ] {
        let text = with_group(&format!("numObjects 1 Transform {{ {ops} {sphere} }}"));
        if let Err(e) = parse_scene(&text, "fine") {
            panic!("{ops}: {e}");
        }
    }
    for ops in [
        "Scale 1 0 1",
        // Columns (1, 0, 0), (1, 1e-8, 0), (0, 0, 1): two axes all but aligned.
        "Matrix4f { 1 0 0 0 1 1e-8 0 0 0 0 1 0 0 0 0 1 }",
        "Matrix4f { 1 2 3 0 2 4 6 0 0 0 1 0 0 0 0 1 }",
    ] {
        let text = with_group(&format!("numObjects 1 Transform {{ {ops} {sphere} }}"));
        let err = parse_scene(&text, "t.txt").unwrap_err().to_string();
        assert!(err.contains("singular or nearly so"), "{ops}: {err}");
    }
}

/// A `Matrix4f` whose bottom row (numbers 4, 8, 12 and 16, read column by column) is not
/// 0 0 0 1 is an error at the first number that breaks it; its projective row was dropped.
#[test]
fn a_projective_matrix4f_is_an_error() {
    let matrix = |numbers: &str| {
        with_group(&format!(
            "numObjects 1 Transform {{ Matrix4f {{ {numbers} }} \
             Sphere {{ center 0 0 0 radius 1 }} }}"
        ))
    };
    expect_errors(&[
        (
            "perspective row",
            matrix("1 0 0 0  0 1 0 0  0 0 1 0.5  0 0 0 1"),
            "0.5",
            "expected `0` as number 12 of `Matrix4f`, found `0.5`: read column by column, its \
             bottom row must be 0 0 0 1",
        ),
        (
            "weight",
            matrix("1 0 0 0  0 1 0 0  0 0 1 0  5 6 7 2"),
            "2 }",
            "expected `1` as number 16 of `Matrix4f`, found `2`",
        ),
    ]);
    // An affine matrix with a translation loads.
    let text = matrix("1 0 0 0  0 2 0 0  0 0 1 0  5 6 7 1");
    let scene = parse_scene(&text, "affine").unwrap();
    let m = scene.objects[0].transform.unwrap();
    assert_eq!(m.w_axis.to_array(), [5.0, 6.0, 7.0, 1.0]);
    assert_eq!(m.y_axis.to_array(), [0.0, 2.0, 0.0, 0.0]);
}

/// Plane normals of any length (components of 1e-300 to 1e300, or mixed) pack as the same
/// unit normal and distance as their unit-length form; before, a normal `1e-200 0 0` had
/// length 0 and packed as NaN. The zero normal stays an error.
#[test]
fn plane_normals_of_any_length_pack_as_their_unit_normal() {
    let packed_plane = |normal: [f64; 3], offset: f64| {
        let [x, y, z] = normal;
        let text = with_group(&format!(
            "numObjects 1 Plane {{ normal {x:e} {y:e} {z:e} offset {offset:e} range 10 }}"
        ));
        let scene = parse_scene(&text, "plane").unwrap_or_else(|e| panic!("{e}"));
        let packed =
            clpt::pack::PackedScene::new(&scene, u64::MAX).unwrap_or_else(|e| panic!("{e}"));
        (packed.planes[0].normal, packed.planes[0].offset)
    };
    for unit in [[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.6, 0.0, 0.8]] {
        let want = packed_plane(unit, -3.0);
        for length in [1e-300, 1e-200, 1e-30, 1e30, 1e200, 1e300] {
            let (normal, offset) = packed_plane(unit.map(|c| c * length), -3.0 * length);
            assert!(
                normal
                    .iter()
                    .zip(want.0)
                    .all(|(a, b)| (a - b).abs() <= 1e-6)
                    && (offset - want.1).abs() <= 3e-6,
                "normal {unit:?} x {length:e}: {normal:?} {offset}, want {want:?}"
            );
        }
    }
    // Mixed: components 60 orders of magnitude apart.
    let (normal, offset) = packed_plane([1e30, 1e-30, 0.0], 5e30);
    assert_eq!((normal, offset), ([1.0, 0.0, 0.0], 5.0));
    let (normal, offset) = packed_plane([3e-320, 4e-320, 0.0], 5e-320);
    assert!(
        (normal[0] - 0.6).abs() < 1e-2
            && (normal[1] - 0.8).abs() < 1e-2
            && (offset - 1.0).abs() < 1e-2,
        "subnormal normal: {normal:?} {offset}"
    );
    let zero = with_group("numObjects 1 Plane { normal 0 0 0 offset 0 range 1 }");
    let err = parse_scene(&zero, "zero").unwrap_err();
    assert!(
        err.message
            .contains("expected a nonzero vector for `normal`"),
        "{err}"
    );
}

/// Negative emission would subtract light: clamped to 0 with a warning at its field, as
/// colours outside [0, 1] are.
#[test]
fn negative_emission_is_clamped_with_a_warning() {
    let text = with_materials(
        "numMaterials 2 Material { emission -1 2 -0.5 } Material { emission 3 3 3 }",
    );
    let scene = parse_scene(&text, "neg").unwrap();
    assert_eq!(scene.materials[0].emission, DVec3::new(0.0, 2.0, 0.0));
    assert_eq!(scene.materials[1].emission, DVec3::splat(3.0));
    let (line, column) = position_of(&text, "emission -1");
    assert_eq!(
        warnings_of(&scene),
        [(
            line,
            column,
            "`emission -1 2 -0.5` is negative (a surface cannot emit less than no light): \
             clamped to 0 2 0"
        )]
    );
}

/// The camera's direction is checked where it is written: zero, too small to normalise is no
/// longer "zero", and parallel to the x axis (smallpt's basis cannot frame it) was an error
/// with no place.
#[test]
fn camera_direction_errors_name_their_place() {
    let camera = |direction: &str| {
        with_camera(&format!(
            "center 0 0 0 direction {direction} angle 30 width 4 height 3"
        ))
    };
    expect_errors(&[
        (
            "parallel to x",
            camera("-2 0 0"),
            "-2 0 0",
            "camera direction is parallel to the x axis",
        ),
        (
            "zero",
            camera("0 0 0"),
            "0 0 0 angle",
            "expected a nonzero vector for `direction`, found the zero vector",
        ),
    ]);
    // A direction of any length frames the same picture.
    for direction in ["0 -1e-320 -1e-320", "0 -1e300 -1e300", "0 -1 -1"] {
        let scene = parse_scene(&camera(direction), "tiny").unwrap_or_else(|e| panic!("{e}"));
        let basis = clpt::scene::camera::CameraBasis::new(&scene.camera).unwrap();
        let h = std::f64::consts::FRAC_1_SQRT_2;
        assert!(
            (basis.forward - DVec3::new(0.0, -h, -h)).length() < 1e-15,
            "{direction}: {:?}",
            basis.forward
        );
    }
}

/// A bad token is quoted with invisible and control characters escaped and at most 60
/// characters shown: a zero-width space was printed raw (`​0.75`), and a long token whole.
#[test]
fn bad_tokens_are_quoted_escaped_and_short() {
    let radius = |token: &str| {
        with_group(&format!(
            "numObjects 1 Sphere {{ center 0 0 0 radius {token} }}"
        ))
    };
    let err = |text: &str| parse_scene(text, "bad.txt").unwrap_err().to_string();
    assert!(
        err(&radius("\u{200b}0.75"))
            .ends_with("expected a number for `radius`, found `\\u{200b}0.75`"),
        "{}",
        err(&radius("\u{200b}0.75"))
    );
    let nuls = "\0".repeat(1 << 20);
    let message = err(&radius(&nuls));
    assert!(
        message.ends_with(&format!("found `{}…`", "\\0".repeat(30))),
        "{message:.200}"
    );
    let long = "9".repeat(1 << 20) + "x";
    let message = err(&with_camera(&format!("{CAMERA} flength {long}")));
    assert!(message.len() < 200, "{message:.300}");
    assert!(
        message.contains(&format!("found `{}…`", "9".repeat(60))),
        "{message}"
    );
    // Control characters in a word, and a right-to-left override in a keyword's place.
    let message = err("Perspective\u{7}Camera\u{202e} { }");
    assert!(
        message.contains("found `Perspective\\u{7}Camera\\u{202e}`"),
        "{message}"
    );
}

/// Bytes that are not UTF-8 are an error at their line and column, naming them (a Latin-1
/// `é` in a comment gave "stream did not contain valid UTF-8" with no place).
#[test]
fn invalid_utf8_names_line_column_and_byte() {
    use clpt::scene::parse::parse_scene_bytes;
    let mut bytes = scene(CAMERA, MATERIALS, GROUP).into_bytes();
    bytes.extend(b"# caf\xe9 au lait\n");
    let err = parse_scene_bytes(&bytes, "latin1.txt").unwrap_err();
    assert_eq!(
        err.to_string(),
        "latin1.txt:4:6: expected UTF-8 text, found the byte 0xE9: not UTF-8 (is the file \
         Latin-1 or Windows-1252? save it as UTF-8)"
    );
    // Columns count characters, as everywhere: `é` (UTF-8) and a tab are one each.
    let err = parse_scene_bytes(b"\xef\xbb\xbf\xc3\xa9\tx\x80", "f").unwrap_err();
    assert_eq!((err.location.line, err.location.column), (1, 4), "{err}");
    let err = parse_scene_bytes(b"x \xc3\xa9 \xff\xfe", "f").unwrap_err();
    assert_eq!((err.location.line, err.location.column), (1, 5), "{err}");
    assert!(err.message.contains("the byte 0xFF"), "{err}");
    // A character cut off by the end of the file.
    let err = parse_scene_bytes(b"Group \xe2\x80", "f").unwrap_err();
    assert!(
        err.message.ends_with(
            "found the bytes 0xE2 0x80: an unfinished UTF-8 character at the end of the file"
        ),
        "{err}"
    );
    assert_eq!((err.location.line, err.location.column), (1, 7));
}

/// Nesting deeper than `MAX_NESTING` is an error at the block that goes too deep, on a thread
/// with the default stack (10,000 nested `Transform` blocks overflowed the stack and aborted).
#[test]
fn nesting_beyond_the_limit_is_an_error_not_a_stack_overflow() {
    use clpt::scene::parse::MAX_NESTING;
    let nested = |transforms: usize| {
        format!(
            "{}{}Sphere {{ center 0 0 0 radius 1 }}{} }}\n",
            scene(CAMERA, MATERIALS, "numObjects 1")
                .trim_end()
                .trim_end_matches('}'),
            "Transform { ".repeat(transforms),
            " }".repeat(transforms)
        )
    };
    let parse = |text: String| {
        std::thread::spawn(move || parse_scene(&text, "deep.txt").map(|s| s.objects.len()))
            .join()
            .expect("the parse thread ended without a result")
    };
    // `Group`, the transforms and the sphere: the deepest that loads has MAX_NESTING - 2.
    assert_eq!(parse(nested(MAX_NESTING - 2)), Ok(1));
    // The first block beyond MAX_NESTING: the sphere, or the next transform.
    for (transforms, word) in [(MAX_NESTING - 1, "Sphere"), (10_000, "Transform")] {
        let text = nested(transforms);
        let err = parse(text.clone()).unwrap_err();
        let (line, first) = position_of(&text, "Transform");
        let column = first + "Transform { ".len() * (MAX_NESTING - 1);
        assert_eq!(
            (err.location.line, err.location.column),
            (line, column),
            "{err}"
        );
        assert_eq!(
            err.message,
            format!(
                "expected blocks nested at most {MAX_NESTING} deep, found `{word}` {} deep",
                MAX_NESTING + 1
            )
        );
    }
}

/// Declared counts are only compared with what the block lists, never used to reserve memory:
/// four billion objects and materials load as the one each that is there, with warnings.
#[test]
fn declared_counts_do_not_allocate() {
    let text = scene(
        CAMERA,
        "numMaterials 4000000000 Material { }",
        "numObjects 4000000000 Sphere { center 0 0 0 radius 1 }",
    );
    let scene = parse_scene(&text, "counts").unwrap();
    assert_eq!((scene.materials.len(), scene.objects.len()), (1, 1));
    assert_eq!(scene.warnings.len(), 2);
    let err = parse_scene(
        &with_group("numObjects 99999999999999999999 Sphere { center 0 0 0 radius 1 }"),
        "t",
    )
    .unwrap_err();
    assert!(
        err.message.contains(
            "expected an integer of at most 9223372036854775807 in magnitude for `numObjects`"
        ),
        "{err}"
    );
}
