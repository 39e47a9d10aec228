//! The object BVH (`clpt::accel::bvh`): on random, clustered, flat and widely scaled sphere
//! scenes, `Bvh::intersect` finds the same nearest (t, object) as testing every sphere, for 1e5
//! rays per scene; every tree is checked for structure (each bounded object in one leaf, boxes
//! containing what lies below them, every node referenced once, depth within `MAX_DEPTH`);
//! Morton codes of normalised centres resolve a scene spanning ±1e5 where raw ones saturate.

mod common;

use clpt::accel::aabb::Aabb;
use clpt::accel::bvh::{self, Bvh, MAX_DEPTH, morton_code};
use clpt::contract::{BVH_EMPTY, BVH_LEAF};
use common::traversal::bvh_intersect;
use glam::DVec3;
use rand::rngs::SmallRng;
use rand::{RngExt, SeedableRng};
use std::time::Instant;

const RAYS: usize = 100_000;

#[derive(Clone, Copy, Debug)]
struct Ball {
    center: DVec3,
    radius: f64,
}

impl Ball {
    fn aabb(&self) -> Aabb {
        Aabb {
            lo: self.center - self.radius,
            hi: self.center + self.radius,
        }
    }

    /// The first root of |o + t d - c| = r with 0 < t < t_max (d unit). The same t whatever
    /// `t_max`, so the tree and brute force can be compared exactly.
    fn hit(&self, o: DVec3, d: DVec3, t_max: f64) -> Option<f64> {
        let f = o - self.center;
        let b = f.dot(d);
        let disc = b * b - (f.length_squared() - self.radius * self.radius);
        if disc < 0.0 {
            return None;
        }
        let s = disc.sqrt();
        [-b - s, -b + s].into_iter().find(|&t| t > 0.0 && t < t_max)
    }
}

fn random_in(rng: &mut SmallRng, b: &Aabb) -> DVec3 {
    b.lo + (b.hi - b.lo)
        * DVec3::new(
            rng.random::<f64>(),
            rng.random::<f64>(),
            rng.random::<f64>(),
        )
}

fn bounded(b: &Aabb) -> bool {
    !b.is_empty() && b.lo.is_finite() && b.hi.is_finite()
}

/// Checks the tree's structure against the boxes it was built from.
fn check_structure(bvh: &Bvh, boxes: &[Aabb]) {
    let inside: Vec<u32> = (0u32..)
        .zip(boxes)
        .filter(|(_, b)| bounded(b))
        .map(|(i, _)| i)
        .collect();
    let outside: Vec<u32> = (0u32..)
        .zip(boxes)
        .filter(|(_, b)| !bounded(b))
        .map(|(i, _)| i)
        .collect();
    assert_eq!(bvh.unbounded, outside, "unbounded objects");
    let expected_bounds = inside
        .iter()
        .fold(Aabb::EMPTY, |a, &i| a.union(boxes[i as usize]));
    assert_eq!(bvh.bounds, expected_bounds, "bounds");
    let stats = bvh.stats();
    assert_eq!(stats.leaves, inside.len(), "leaves");
    assert_eq!(stats.nodes, bvh.nodes.len());
    match inside.len() {
        0 => {
            assert!(bvh.nodes.is_empty());
            return;
        }
        1 => {
            assert_eq!(bvh.nodes.len(), 1);
            let node = &bvh.nodes[0];
            assert_eq!(node.child, [BVH_LEAF | inside[0], BVH_EMPTY]);
            assert_eq!(node.lo1, [f32::INFINITY; 3]);
            assert_eq!(node.hi1, [f32::NEG_INFINITY; 3]);
        }
        n => assert_eq!(bvh.nodes.len(), n - 1, "a binary tree of {n} leaves"),
    }
    assert!(stats.max_depth <= MAX_DEPTH, "depth {}", stats.max_depth);

    // References: each non-root node once, each bounded object once, nothing else.
    let mut node_refs = vec![0u32; bvh.nodes.len()];
    let mut object_refs = vec![0u32; boxes.len()];
    for (index, node) in bvh.nodes.iter().enumerate() {
        for (k, &c) in node.child.iter().enumerate() {
            if c == BVH_EMPTY {
                assert!(
                    index == 0 && k == 1 && inside.len() == 1,
                    "BVH_EMPTY in node {index}"
                );
            } else if c & BVH_LEAF != 0 {
                let object = (c & !BVH_LEAF) as usize;
                assert!(
                    object < boxes.len() && bounded(&boxes[object]),
                    "leaf {object}"
                );
                object_refs[object] += 1;
            } else {
                assert!((c as usize) < bvh.nodes.len(), "child {c} out of range");
                node_refs[c as usize] += 1;
            }
        }
    }
    assert_eq!(node_refs[0], 0, "the root is referenced");
    assert!(
        node_refs[1..].iter().all(|&r| r == 1),
        "a node not referenced exactly once"
    );
    for (i, b) in boxes.iter().enumerate() {
        assert_eq!(
            object_refs[i],
            u32::from(bounded(b)),
            "object {i} in {} leaves",
            object_refs[i]
        );
    }

    // Boxes: recompute each node's box bottom-up in f64 (reverse pre-order visits children
    // first) and check the stored f32 boxes contain what lies below them.
    let mut preorder = Vec::with_capacity(bvh.nodes.len());
    let mut stack = vec![0usize];
    while let Some(index) = stack.pop() {
        preorder.push(index);
        for &c in &bvh.nodes[index].child {
            if c & BVH_LEAF == 0 {
                stack.push(c as usize);
            }
        }
    }
    assert_eq!(
        preorder.len(),
        bvh.nodes.len(),
        "nodes unreachable from the root"
    );
    let mut exact = vec![Aabb::EMPTY; bvh.nodes.len()];
    for &index in preorder.iter().rev() {
        let node = &bvh.nodes[index];
        for (k, &c) in node.child.iter().enumerate() {
            if c == BVH_EMPTY {
                continue;
            }
            let below = if c & BVH_LEAF != 0 {
                boxes[(c & !BVH_LEAF) as usize]
            } else {
                exact[c as usize]
            };
            assert!(
                bvh::child_box(node, k).contains(&below),
                "node {index} child {k}: {:?} does not contain {below:?}",
                bvh::child_box(node, k)
            );
            exact[index] = exact[index].union(below);
        }
    }
    assert_eq!(exact[0], bvh.bounds);
}

/// What `check_rays` saw.
struct RayCounts {
    hits: usize,
    /// Rays of unlimited length that hit nothing.
    endless_misses: usize,
    /// Mean `hit` calls per ray.
    calls: f64,
}

/// Compares `intersect` with brute force on `RAYS` rays: half in random directions, half aimed
/// at a random ball, from origins spread over `origins`; every 7th ray is cut short.
fn check_rays(balls: &[Ball], bvh: &Bvh, origins: &Aabb, seed: u64) -> RayCounts {
    let mut rng = SmallRng::seed_from_u64(seed);
    let rays: Vec<(DVec3, DVec3, f64)> = (0..RAYS)
        .map(|ray| {
            let o = random_in(&mut rng, origins);
            let d = if ray % 2 == 0 {
                common::random_unit(&mut rng)
            } else {
                let target = balls[rng.random_range(0..balls.len())];
                let aim = random_in(&mut rng, &target.aabb()) - o;
                if aim.length_squared() > 0.0 {
                    aim.normalize()
                } else {
                    common::random_unit(&mut rng)
                }
            };
            let t_max = if ray % 7 == 0 {
                rng.random_range(0.0..4.0)
            } else {
                f64::INFINITY
            };
            (o, d, t_max)
        })
        .collect();
    // Brute force, every ball in turn, spread over the cores (a 100,000-ball scene's takes
    // 10^10 tests).
    let brute = common::on_all_cores(&rays, |&(o, d, t_max)| {
        let mut expected: Option<(f64, u32)> = None;
        for (i, ball) in (0u32..).zip(balls) {
            let limit = expected.map_or(t_max, |(t, _)| t);
            if let Some(t) = ball.hit(o, d, limit) {
                expected = Some((t, i));
            }
        }
        expected
    });
    let (mut hits, mut endless_misses, mut calls) = (0usize, 0usize, 0usize);
    for (ray, (&(o, d, t_max), &expected)) in rays.iter().zip(&brute).enumerate() {
        let got = bvh_intersect(bvh, o, d, t_max, |object, limit| {
            calls += 1;
            assert!(
                (object as usize) < balls.len(),
                "hit called for object {object}"
            );
            balls[object as usize].hit(o, d, limit)
        });
        match (expected, got) {
            (None, None) => endless_misses += usize::from(t_max == f64::INFINITY),
            (Some((te, ie)), Some((tg, ig))) => {
                assert_eq!(te, tg, "ray {ray}: t (objects {ie}, {ig})");
                // Balls hit at exactly the same t: either is the nearest.
                assert!(
                    ie == ig || balls[ig as usize].hit(o, d, f64::INFINITY) == Some(te),
                    "ray {ray}: object {ig}, expected {ie}"
                );
                hits += 1;
            }
            _ => panic!("ray {ray} from {o} along {d}: expected {expected:?}, got {got:?}"),
        }
    }
    RayCounts {
        hits,
        endless_misses,
        calls: calls as f64 / RAYS as f64,
    }
}

/// Builds over the balls, checks structure and rays, and returns the tree.
fn check_scene(name: &str, balls: &[Ball], seed: u64) -> Bvh {
    let boxes: Vec<Aabb> = balls.iter().map(Ball::aabb).collect();
    let start = Instant::now();
    let bvh = Bvh::build(&boxes);
    let build = start.elapsed();
    check_structure(&bvh, &boxes);
    let b = bvh.bounds;
    let margin = (b.hi - b.lo) * 0.1 + 1e-3;
    let origins = Aabb {
        lo: b.lo - margin,
        hi: b.hi + margin,
    };
    let RayCounts { hits, calls, .. } = check_rays(balls, &bvh, &origins, seed);
    let stats = bvh.stats();
    eprintln!(
        "{name}: {} objects, build {build:.2?}, {stats:?}, {hits} hits of {RAYS} rays, \
         {calls:.1} hit calls per ray",
        balls.len()
    );
    assert!(
        hits >= RAYS / 4,
        "{name}: only {hits} rays hit: the test tests little"
    );
    bvh
}

/// `n` balls with centres uniform in [-1, 1]³ and radii about a tenth of their spacing or more.
fn random_balls(n: usize, seed: u64) -> Vec<Ball> {
    let mut rng = SmallRng::seed_from_u64(seed);
    let spacing = 2.0 / (n as f64).cbrt();
    (0..n)
        .map(|_| Ball {
            center: DVec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            ),
            radius: spacing * rng.random_range(0.1..0.6),
        })
        .collect()
}

#[test]
fn random_scenes_match_brute_force() {
    for (seed, n) in [1usize, 2, 3, 17, 1000].into_iter().enumerate() {
        check_scene(
            &format!("random {n}"),
            &random_balls(n, seed as u64),
            100 + seed as u64,
        );
    }
}

#[test]
fn a_hundred_thousand_random_spheres_match_brute_force() {
    let bvh = check_scene("random 1e5", &random_balls(100_000, 7), 107);
    assert!(bvh.stats().max_depth <= 40);
}

#[test]
fn clustered_scenes_match_brute_force() {
    let mut rng = SmallRng::seed_from_u64(11);
    let mut balls = Vec::new();
    // 10 clusters of 100 balls on one centre (equal centroids), radii all different.
    for _ in 0..10 {
        let center = DVec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        for k in 0..100 {
            balls.push(Ball {
                center,
                radius: 0.02 + 0.001 * k as f64 + rng.random_range(0.0..1e-4),
            });
        }
    }
    // 300 balls whose centres differ by 1e-7 of the scene: distinct centroids, equal codes.
    let center = DVec3::new(0.3, -0.2, 0.1);
    for _ in 0..300 {
        balls.push(Ball {
            center: center + common::random_unit(&mut rng) * 1e-7,
            radius: rng.random_range(0.01..0.05),
        });
    }
    check_scene("clustered", &balls, 111);

    // Exact duplicates: nearest hits tie, and either object is right.
    let twins: Vec<Ball> = (0..64)
        .map(|i| Ball {
            center: DVec3::new((i / 8) as f64, (i % 8) as f64, 0.0),
            radius: 0.4,
        })
        .flat_map(|b| [b, b])
        .collect();
    check_scene("duplicates", &twins, 112);
}

#[test]
fn flat_scenes_match_brute_force() {
    let mut rng = SmallRng::seed_from_u64(21);
    let plane: Vec<Ball> = (0..1000)
        .map(|_| Ball {
            center: DVec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                0.0,
            ),
            radius: rng.random_range(0.005..0.05),
        })
        .collect();
    check_scene("flat z = 0", &plane, 121);
    let line: Vec<Ball> = (0..1000)
        .map(|_| Ball {
            center: DVec3::new(0.0, rng.random_range(-1.0..1.0), 2.0),
            radius: rng.random_range(0.0005..0.005),
        })
        .collect();
    check_scene("line x = 0, z = 2", &line, 122);
}

#[test]
fn smallpt_walls_among_small_spheres_match_brute_force() {
    // smallpt's six walls, spheres of radius 1e5, around 500 small balls inside the room.
    let wall = |x, y, z| Ball {
        center: DVec3::new(x, y, z),
        radius: 1e5,
    };
    let mut balls = vec![
        wall(1e5 + 1.0, 40.8, 81.6),
        wall(-1e5 + 99.0, 40.8, 81.6),
        wall(50.0, 40.8, 1e5),
        wall(50.0, 40.8, -1e5 + 170.0),
        wall(50.0, 1e5, 81.6),
        wall(50.0, -1e5 + 81.6, 81.6),
    ];
    let mut rng = SmallRng::seed_from_u64(31);
    for _ in 0..500 {
        balls.push(Ball {
            center: DVec3::new(
                rng.random_range(5.0..95.0),
                rng.random_range(5.0..75.0),
                rng.random_range(5.0..165.0),
            ),
            radius: rng.random_range(0.1..3.0),
        });
    }
    let boxes: Vec<Aabb> = balls.iter().map(Ball::aabb).collect();
    let bvh = Bvh::build(&boxes);
    check_structure(&bvh, &boxes);
    // Rays from inside the room, where the renderer's rays are: each one hits something.
    let room = Aabb {
        lo: DVec3::new(2.0, 1.0, 1.0),
        hi: DVec3::new(98.0, 80.0, 169.0),
    };
    let rays = check_rays(&balls, &bvh, &room, 131);
    eprintln!(
        "smallpt walls: {:?}, {} hits, {:.1} hit calls per ray",
        bvh.stats(),
        rays.hits,
        rays.calls
    );
    assert_eq!(rays.endless_misses, 0, "a ray left the closed room");
}

#[test]
fn depth_stays_bounded_when_codes_are_equal() {
    // 1e5 identical boxes: one Morton code, split in the middle: ⌈log2 1e5⌉ = 17 levels.
    let same = vec![
        Aabb {
            lo: DVec3::splat(-1.0),
            hi: DVec3::splat(1.0),
        };
        100_000
    ];
    let bvh = Bvh::build(&same);
    check_structure(&bvh, &same);
    assert_eq!(bvh.stats().max_depth, 17);

    // Centres at 2^-k on each axis: a chain of splits down all 30 code bits, then runs of the
    // code 0 (everything below 2^-10) halved: the worst case the depth bound allows for.
    let chain: Vec<Aabb> = (0..100_000)
        .map(|i| {
            let c = DVec3::new(
                0.5f64.powi(i % 61),
                0.5f64.powi((i / 61) % 61),
                0.5f64.powi(i % 13),
            );
            Aabb {
                lo: c,
                hi: c * 1.01,
            }
        })
        .collect();
    let bvh = Bvh::build(&chain);
    check_structure(&bvh, &chain);
    let depth = bvh.stats().max_depth;
    eprintln!("chain: depth {depth}");
    assert!(depth <= MAX_DEPTH);
}

#[test]
fn normalised_codes_resolve_a_wide_scene() {
    // A 32³ grid of centres spanning [-1e5, 1e5]: the grid's own box is the centroid box.
    let coord = |i: u32| -1e5 + 2e5 * f64::from(i) / 31.0;
    let centres: Vec<DVec3> = (0..32 * 32 * 32)
        .map(|i| DVec3::new(coord(i % 32), coord(i / 32 % 32), coord(i / 1024)))
        .collect();
    let centroids = Aabb::from_points(centres.iter().copied());
    let distinct = |codes: Vec<u32>| {
        let mut codes = codes;
        codes.sort_unstable();
        codes.dedup();
        codes.len()
    };
    let normalised: Vec<u32> = centres
        .iter()
        .map(|&c| morton_code(bvh::normalised(c, &centroids)))
        .collect();
    assert_eq!(distinct(normalised), centres.len());
    // The original coded raw coordinates: each clamps to 0 or to the top cell, 8 codes in all.
    let raw: Vec<u32> = centres.iter().map(|&c| morton_code(c)).collect();
    assert_eq!(distinct(raw), 8);

    // Normalisation maps the centroid box onto [0, 1]³, and a flat axis to 0.
    assert_eq!(bvh::normalised(centroids.lo, &centroids), DVec3::ZERO);
    assert_eq!(bvh::normalised(centroids.hi, &centroids), DVec3::ONE);
    let flat = Aabb {
        lo: DVec3::new(-1.0, 5.0, 0.0),
        hi: DVec3::new(1.0, 5.0, 4.0),
    };
    assert_eq!(
        bvh::normalised(DVec3::new(0.0, 5.0, 1.0), &flat),
        DVec3::new(0.5, 0.0, 0.25)
    );
}

#[test]
fn empty_input_and_one_object() {
    let empty = Bvh::build(&[]);
    assert!(empty.nodes.is_empty() && empty.unbounded.is_empty());
    assert_eq!(empty.bounds, Aabb::EMPTY);
    assert_eq!(empty.stats().max_depth, 0);
    assert_eq!(
        bvh_intersect(&empty, DVec3::ZERO, DVec3::X, f64::INFINITY, |_, _| Some(
            1.0
        )),
        None
    );

    let ball = Ball {
        center: DVec3::new(3.0, 0.0, 0.0),
        radius: 1.0,
    };
    let bvh = check_scene("one", &[ball], 201);
    let stats = bvh.stats();
    assert_eq!((stats.nodes, stats.leaves, stats.max_depth), (1, 1, 1));
    assert_eq!(stats.sah_cost, 2.0);
    // A ray missing the ball: the empty slot's inverted box must not be entered either.
    let missed = bvh_intersect(&bvh, DVec3::ZERO, -DVec3::X, f64::INFINITY, |object, _| {
        panic!("hit called for object {object:#x}")
    });
    assert_eq!(missed, None);
    let got = bvh_intersect(&bvh, DVec3::ZERO, DVec3::X, f64::INFINITY, |_, t| {
        ball.hit(DVec3::ZERO, DVec3::X, t)
    });
    assert_eq!(got, Some((2.0, 0)));
}

#[test]
fn unbounded_objects_stay_outside_the_tree() {
    let unit = |x: f64| Aabb {
        lo: DVec3::new(x, 0.0, 0.0),
        hi: DVec3::new(x + 1.0, 1.0, 1.0),
    };
    let infinite = Aabb {
        lo: DVec3::new(f64::NEG_INFINITY, -1.0, -1.0),
        hi: DVec3::new(f64::INFINITY, 1.0, 1.0),
    };
    let nan = Aabb {
        lo: DVec3::new(0.0, f64::NAN, 0.0),
        hi: DVec3::ONE,
    };
    let boxes = [infinite, unit(0.0), Aabb::EMPTY, unit(2.0), nan, unit(4.0)];
    let bvh = Bvh::build(&boxes);
    check_structure(&bvh, &boxes);
    assert_eq!(bvh.unbounded, [0, 2, 4]);
    // Only the bounded objects are offered, the nearest first.
    let mut offered = Vec::new();
    let got = bvh_intersect(
        &bvh,
        DVec3::new(-1.0, 0.5, 0.5),
        DVec3::X,
        f64::INFINITY,
        |object, _| {
            offered.push(object);
            Some(f64::from(object))
        },
    );
    assert_eq!(got, Some((1.0, 1)));
    assert_eq!(offered, [1]);

    // One bounded object among unbounded ones; none at all.
    let one = [infinite, unit(0.0)];
    check_structure(&Bvh::build(&one), &one);
    let none = [infinite, Aabb::EMPTY, nan];
    let bvh = Bvh::build(&none);
    check_structure(&bvh, &none);
    assert_eq!(
        bvh_intersect(&bvh, DVec3::ZERO, DVec3::X, f64::INFINITY, |_, _| Some(1.0)),
        None
    );
}

#[test]
fn builds_a_million_boxes() {
    for n in [100_000usize, 1_000_000] {
        let boxes: Vec<Aabb> = random_balls(n, 41).iter().map(Ball::aabb).collect();
        let start = Instant::now();
        let bvh = Bvh::build(&boxes);
        let build = start.elapsed();
        check_structure(&bvh, &boxes);
        eprintln!("build of {n} random boxes: {build:.2?}, {:?}", bvh.stats());
    }
}
