//! The 16-wide BVH (src/geometry/bvh.rs): watertight hits on closed meshes, rays with -0.0
//! direction components, and agreement with brute force, the same bits whichever SIMD extension
//! tests its nodes; the small-scene scan
//! (src/geometry/small_scene.rs): the very bits of brute force.

use glam::Vec3A;
use nlos_rs::geometry::{
    Prim,
    bvh::{Accel, NO_PLANE, intersect_brute},
    small_scene::{ALL_PACKS, MAX_TRIANGLES, Packs, Query, SmallScene},
};
use nlos_rs::sampling::{Sampler, square_to_uniform_sphere};

/// Every pack of the scan, along `o + t d`, `t ∈ (tmin, tmax)`.
fn every_pack(o: Vec3A, d: Vec3A, tmin: f32, tmax: f32) -> Query {
    Query {
        o,
        d,
        tmin,
        tmax,
        packs: Packs::Only(ALL_PACKS),
    }
}

/// Skip no plane.
const NONE: [u32; 2] = [NO_PLANE; 2];

/// The BVH over `prims`, each its own shape.
fn build(prims: &[Prim]) -> Accel {
    let shapes: Vec<u32> = (0..prims.len() as u32).collect();
    Accel::build(prims, &shapes, prims.len())
}

/// A closed latitude–longitude sphere mesh with shared vertices, radially perturbed.
fn closed_sphere(n_lat: usize, n_lon: usize, jitter: f32, rng: &mut Sampler) -> Vec<Prim> {
    let mut v = vec![Vec3A::Z];
    for i in 1..n_lat {
        let th = std::f32::consts::PI * i as f32 / n_lat as f32;
        for j in 0..n_lon {
            let ph = 2.0 * std::f32::consts::PI * j as f32 / n_lon as f32;
            v.push(Vec3A::new(
                th.sin() * ph.cos(),
                th.sin() * ph.sin(),
                th.cos(),
            ));
        }
    }
    v.push(-Vec3A::Z);
    for p in &mut v {
        *p *= 1.0 + jitter * (rng.next_1d() - 0.5);
    }
    let ring = |i: usize, j: usize| 1 + (i - 1) * n_lon + j % n_lon;
    let last = v.len() - 1;
    let mut tris = Vec::new();
    for j in 0..n_lon {
        tris.push([0, ring(1, j), ring(1, j + 1)]);
        tris.push([last, ring(n_lat - 1, j + 1), ring(n_lat - 1, j)]);
        for i in 1..n_lat - 1 {
            tris.push([ring(i, j), ring(i + 1, j), ring(i + 1, j + 1)]);
            tris.push([ring(i, j), ring(i + 1, j + 1), ring(i, j + 1)]);
        }
    }
    tris.into_iter()
        .map(|t| Prim::triangle(t.map(|k| v[k])))
        .collect()
}

#[test]
fn watertight_from_inside() {
    // pbrt-v4's TEST(Triangle, Watertight): every ray from inside a closed mesh must hit it, also
    // rays lying in mesh-edge planes (x = 0, y = 0) and rays aimed exactly at vertices.
    let mut rng = Sampler::new(1, 2, 3);
    for jitter in [0.0, 0.2] {
        let prims = closed_sphere(16, 32, jitter, &mut rng);
        let accel = build(&prims);
        let mut dirs: Vec<Vec3A> = (0..20_000)
            .map(|_| square_to_uniform_sphere(rng.next_2d()))
            .collect();
        dirs.extend((0..2000).map(|k| {
            let a = 2.0 * std::f32::consts::PI * k as f32 / 2000.0;
            Vec3A::new(0.0, a.cos(), a.sin())
        }));
        dirs.extend((0..2000).map(|k| {
            let a = 2.0 * std::f32::consts::PI * k as f32 / 2000.0;
            Vec3A::new(a.cos(), 0.0, a.sin())
        }));
        for p in &prims {
            if let Prim::Triangle { v: t, .. } = p {
                dirs.push(t[0].normalize());
            }
        }
        let leaks = dirs
            .iter()
            .filter(|d| {
                accel
                    .intersect(Vec3A::ZERO, **d, 0.0, f32::INFINITY)
                    .is_none()
            })
            .count();
        assert_eq!(
            leaks,
            0,
            "{leaks} of {} rays escaped the closed mesh (jitter {jitter})",
            dirs.len()
        );
    }
}

#[test]
fn negative_zero_directions_hit() {
    // A -0.0 direction component (obvhs' compressed-wide BVH, used before, missed such rays).
    let mut rng = Sampler::new(4, 5, 6);
    let prims = closed_sphere(8, 16, 0.1, &mut rng);
    let accel = build(&prims);
    for d in [
        Vec3A::new(-0.0, 0.0, 1.0),
        Vec3A::new(0.0, -0.0, 1.0),
        Vec3A::new(1.0, -0.0, 0.0),
        Vec3A::new(0.0, 1.0, -0.0),
        -Vec3A::new(0.0, 0.0, -1.0),
        Vec3A::new(-0.0, -0.0, -1.0),
    ] {
        assert!(
            accel
                .intersect(Vec3A::new(0.01, 0.02, 0.03), d, 0.0, f32::INFINITY)
                .is_some(),
            "missed {d:?}"
        );
        assert!(
            !accel.unoccluded(Vec3A::new(0.01, 0.02, 0.03), d, 0.0, 10.0, NONE),
            "shadow ray missed {d:?}"
        );
    }
}

/// Assert that the BVH's closest hit along `o + t d` (its distance, and its primitive if
/// `same_prim`) and its shadow-ray answer up to `shadow_t` agree with brute force; return whether
/// the ray hits.
fn matches_brute_force(
    accel: &Accel,
    prims: &[Prim],
    o: Vec3A,
    d: Vec3A,
    shadow_t: f32,
    same_prim: bool,
) -> bool {
    let a = accel.intersect(o, d, 0.0, f32::INFINITY);
    let b = intersect_brute(prims, o, d, 0.0, f32::INFINITY);
    assert_eq!(
        accel.unoccluded(o, d, 0.0, shadow_t, NONE),
        intersect_brute(prims, o, d, 0.0, shadow_t).is_none(),
        "shadow ray {o:?} + t {d:?}"
    );
    match (a, b) {
        (Some(a), Some(b)) => {
            assert!(!same_prim || a.prim == b.prim, "{a:?} vs {b:?}");
            assert!((a.t - b.t).abs() <= 1e-5 * b.t.max(1.0), "{a:?} vs {b:?}");
            true
        }
        (None, None) => false,
        _ => panic!("BVH and brute force disagree on {o:?} + t {d:?}: {a:?} vs {b:?}"),
    }
}

/// `n` random triangles in [-1, 1]³, each vertex within 0.2 of the first along every axis.
fn triangle_soup(n: usize, rng: &mut Sampler) -> Vec<Prim> {
    (0..n)
        .map(|_| {
            let c = r3(rng);
            Prim::triangle([c, c + r3(rng) * 0.2, c + r3(rng) * 0.2])
        })
        .collect()
}

/// A uniform point of [-1, 1]³.
fn r3(rng: &mut Sampler) -> Vec3A {
    Vec3A::new(rng.next_1d(), rng.next_1d(), rng.next_1d()) * 2.0 - Vec3A::ONE
}

/// How many of `rays` random rays (origins in [-1.5, 1.5]³) hit something, each checked against
/// brute force by [`matches_brute_force`] with a shadow ray to 2.
fn random_rays_match(
    accel: &Accel,
    prims: &[Prim],
    rng: &mut Sampler,
    rays: usize,
    same_prim: bool,
) -> u32 {
    let mut hits = 0;
    for _ in 0..rays {
        let o = r3(rng) * 1.5;
        let d = r3(rng).normalize();
        hits += matches_brute_force(accel, prims, o, d, 2.0, same_prim) as u32;
    }
    hits
}

/// The tree over `prims` (each its own shape) once for each node test this CPU runs, and once
/// with its traversal stack allocated per ray ([`Accel::each_node_test`]): each answers `rays` random rays (as [`random_rays_match`]) and segments with the very bits of the
/// first.
fn node_tests_agree(prims: &[Prim], rng: &mut Sampler, rays: usize) {
    let shapes: Vec<u32> = (0..prims.len() as u32).collect();
    let trees = Accel::each_node_test(prims, &shapes, prims.len());
    #[cfg(target_arch = "x86_64")]
    assert_eq!(
        trees.len(),
        2 + std::arch::is_x86_feature_detected!("avx512f") as usize
            + std::arch::is_x86_feature_detected!("avx2") as usize
    );
    for _ in 0..rays {
        let o = r3(rng) * 1.5;
        let d = r3(rng).normalize();
        let first = trees[0].intersect(o, d, 0.0, f32::INFINITY);
        let blocked = trees[0].unoccluded(o, d, 0.0, 1.0, NONE);
        for tree in &trees[1..] {
            let hit = tree.intersect(o, d, 0.0, f32::INFINITY);
            assert_eq!(
                hit.map(|h| (h.t.to_bits(), h.prim, h.b.map(f32::to_bits))),
                first.map(|h| (h.t.to_bits(), h.prim, h.b.map(f32::to_bits))),
                "{o:?} + t {d:?}"
            );
            assert_eq!(tree.unoccluded(o, d, 0.0, 1.0, NONE), blocked);
        }
    }
}

#[test]
fn bvh_matches_brute_force() {
    let mut rng = Sampler::new(8, 9, 10);
    let mut prims = triangle_soup(400, &mut rng);
    prims.push(Prim::Sphere {
        center: Vec3A::new(0.3, -0.2, 0.1),
        radius: 0.25,
    });
    prims.push(Prim::Disk {
        inv: glam::Affine3A::from_translation(glam::Vec3::new(0.0, 0.0, -0.5)).inverse(),
    });
    let accel = build(&prims);
    let hits = random_rays_match(&accel, &prims, &mut rng, 20_000, true);
    assert!(hits > 1000);
    node_tests_agree(&prims, &mut rng, 20_000);
}

#[test]
fn axis_plane_rays_match_brute_force() {
    // Rays in the planes of box faces (scan rays in a scene's symmetry planes, a laser aimed
    // straight at a wall) on an axis-aligned scene: a wall of quads on a 0.25 grid and a box.
    let mut prims = Vec::new();
    let quad = |prims: &mut Vec<Prim>, c: [Vec3A; 4]| {
        prims.push(Prim::triangle([c[0], c[1], c[2]]));
        prims.push(Prim::triangle([c[0], c[2], c[3]]));
    };
    for i in 0..8 {
        for j in 0..8 {
            let (x, y) = (-1.0 + 0.25 * i as f32, -1.0 + 0.25 * j as f32);
            quad(
                &mut prims,
                [
                    Vec3A::new(x, y, 0.0),
                    Vec3A::new(x + 0.25, y, 0.0),
                    Vec3A::new(x + 0.25, y + 0.25, 0.0),
                    Vec3A::new(x, y + 0.25, 0.0),
                ],
            );
        }
    }
    for z in [0.5f32, 1.0] {
        quad(
            &mut prims,
            [
                Vec3A::new(-0.25, -0.25, z),
                Vec3A::new(0.25, -0.25, z),
                Vec3A::new(0.25, 0.25, z),
                Vec3A::new(-0.25, 0.25, z),
            ],
        );
    }
    // The scene's own (a small scene's scan, on a CPU with one) and the tree with each node test.
    let shapes: Vec<u32> = (0..prims.len() as u32).collect();
    let mut accels = Accel::each_node_test(&prims, &shapes, prims.len());
    accels.insert(0, build(&prims));
    let mut rng = Sampler::new(11, 12, 13);
    let (mut tested, mut hits) = (0, 0u32);
    for _ in 0..4000 {
        // An origin on grid lines, in front of the wall; a direction with one or two zero
        // components (±0.0 both).
        let grid = |u: f32| -1.0 + 0.25 * (u * 9.0).floor();
        let o = Vec3A::new(
            grid(rng.next_1d()),
            grid(rng.next_1d()),
            -0.5 + 2.0 * rng.next_1d(),
        );
        let mut d = square_to_uniform_sphere(rng.next_2d());
        let zero = (rng.next_1d() * 6.0) as usize;
        for a in 0..3 {
            if a == zero % 3 || (zero >= 3 && a == (zero + 1) % 3) {
                d[a] = if rng.next_1d() < 0.5 { 0.0 } else { -0.0 };
            }
        }
        let Some(d) = d.try_normalize() else { continue };
        tested += 1;
        // Rays along the grid's edges hit two quads at once: only the distance must agree.
        for (k, accel) in accels.iter().enumerate() {
            let hit = matches_brute_force(accel, &prims, o, d, 1.5, false);
            hits += (k == 0 && hit) as u32;
        }
    }
    assert!(tested > 3000 && hits > 500, "{tested} rays, {hits} hits");
}

#[test]
fn analytic_primitives() {
    let s = Prim::Sphere {
        center: Vec3A::new(0.0, 0.0, 5.0),
        radius: 1.0,
    };
    let (t, _) = s
        .intersect(Vec3A::ZERO, Vec3A::Z, 0.0, f32::INFINITY)
        .expect("hit");
    assert!((t - 4.0).abs() < 1e-6);
    assert!((s.area() - 4.0 * std::f32::consts::PI).abs() < 1e-5);
    let d = Prim::Disk {
        inv: glam::Affine3A::from_scale_rotation_translation(
            glam::Vec3::new(2.0, 2.0, 1.0),
            glam::Quat::IDENTITY,
            glam::Vec3::new(0.0, 0.0, 3.0),
        )
        .inverse(),
    };
    assert!((d.area() - 4.0 * std::f32::consts::PI).abs() < 1e-4);
    assert!(
        d.intersect(Vec3A::new(1.9, 0.0, 0.0), Vec3A::Z, 0.0, f32::INFINITY)
            .is_some()
    );
    assert!(
        d.intersect(Vec3A::new(2.1, 0.0, 0.0), Vec3A::Z, 0.0, f32::INFINITY)
            .is_none()
    );
}

/// A shadow segment from a point of one planar shape to a point of another never meets either
/// plane, so skipping their primitives changes no answer: with an occluder in between (tested),
/// and without one (nothing left to test). The far end is a quad (the small-scene scan) or a disk,
/// which is planar too (the tree, with the disk among its other primitives); the occluder a
/// triangle, a sphere or a tilted disk, which no plane key of the ends skips.
#[test]
fn skipping_the_end_planes_changes_no_answer() {
    use glam::{Affine3A, Quat, Vec3};
    let mut rng = Sampler::new(11, 0, 0);
    let quad = |z: f32, s: f32| {
        let v = |x: f32, y: f32| Vec3A::new(x * s, y * s, z);
        [
            Prim::triangle([v(-1.0, -1.0), v(1.0, -1.0), v(1.0, 1.0)]),
            Prim::triangle([v(-1.0, -1.0), v(1.0, 1.0), v(-1.0, 1.0)]),
        ]
    };
    let disk = |to_world: Affine3A| Prim::Disk {
        inv: to_world.inverse(),
    };
    let occluders = [
        None,
        Some(Prim::triangle([
            Vec3A::new(-0.3, -0.5, 0.4),
            Vec3A::new(0.5, -0.2, 0.6),
            Vec3A::new(0.0, 0.5, 0.5),
        ])),
        Some(Prim::Sphere {
            center: Vec3A::new(0.1, 0.0, 0.5),
            radius: 0.25,
        }),
        Some(disk(Affine3A::from_scale_rotation_translation(
            Vec3::splat(0.3),
            Quat::from_rotation_x(0.7),
            Vec3::new(0.0, 0.1, 0.5),
        ))),
    ];
    for far_disk in [false, true] {
        for occluder in &occluders {
            // Shape 0: a relay wall at z = 0; shape 1: a flat letter-sized quad (or a disk of
            // radius 0.4) at z = 1; shape 2: the occluder between them.
            let mut prims: Vec<Prim> = quad(0.0, 1.0).into();
            let mut shapes = vec![0u32, 0];
            if far_disk {
                prims.push(disk(Affine3A::from_scale_rotation_translation(
                    Vec3::splat(0.4),
                    Quat::IDENTITY,
                    Vec3::new(0.0, 0.0, 1.0),
                )));
                shapes.push(1);
            } else {
                prims.extend(quad(1.0, 0.4));
                shapes.extend([1, 1]);
            }
            prims.extend(*occluder);
            shapes.extend(occluder.map(|_| 2));
            let accel = Accel::build(&prims, &shapes, 3);
            let ends = [accel.plane_of(0), accel.plane_of(1)];
            assert!(ends.iter().all(|&k| k != NO_PLANE));
            let planar_occluder = !matches!(occluder, Some(Prim::Sphere { .. }));
            assert_eq!(accel.plane_of(2) != NO_PLANE, planar_occluder);
            let (mut blocked, n) = (0, 20_000);
            for _ in 0..n {
                let mut u = || rng.next_1d() * 2.0 - 1.0;
                let x = Vec3A::new(u(), u(), 0.0);
                let y = Vec3A::new(0.4 * u(), 0.4 * u(), 1.0);
                // As `shadow_segment`: off the wall along its normal, ending short of y.
                let o = x + Vec3A::Z * 1e-4;
                let d = (y - o).normalize();
                let tmax = (y - o).length() * (1.0 - 1e-3);
                let full = accel.unoccluded(o, d, 0.0, tmax, NONE);
                assert_eq!(accel.unoccluded(o, d, 0.0, tmax, ends), full);
                // Skipping one end, as a shadow ray towards a point that is no surface's.
                assert_eq!(accel.unoccluded(o, d, 0.0, tmax, [ends[0], NO_PLANE]), full);
                assert_eq!(
                    full,
                    intersect_brute(&prims, o, d, 0.0, tmax).is_none(),
                    "{occluder:?}"
                );
                blocked += !full as usize;
            }
            // The occluder blocks a fair share of the segments; without it none is blocked.
            assert_eq!(blocked > n / 20, occluder.is_some(), "{blocked}");
        }
    }
}

#[test]
fn coincident_triangles_make_a_deep_tree_that_still_works() {
    // Thousands of copies of one triangle: the binary builder makes a deep tree, which the
    // 4-wide collapse must take without recursion; every ray through the triangle hits.
    let t = Prim::triangle([
        Vec3A::new(0.0, 0.0, 1.0),
        Vec3A::new(1.0, 0.0, 1.0),
        Vec3A::new(0.0, 1.0, 1.0),
    ]);
    let accel = build(&vec![t; 3000]);
    let (o, d) = (Vec3A::new(0.25, 0.25, 0.0), Vec3A::Z);
    let hit = accel.intersect(o, d, 0.0, f32::INFINITY).expect("missed");
    assert!((hit.t - 1.0).abs() < 1e-6 && hit.prim < 3000);
    assert!(!accel.unoccluded(o, d, 0.0, 2.0, NONE));
    assert!(
        accel
            .intersect(Vec3A::new(0.75, 0.75, 0.0), d, 0.0, f32::INFINITY)
            .is_none()
    );
}

/// Degenerate input for a tree builder, mixed with 300 random triangles and a sphere: 2,100
/// copies of one triangle (boxes with one centre: no split by position separates them) and 2,100
/// copies scaled about one of its vertices (boxes nested in each other, which chained PLOC's
/// nearest neighbours into quadratic time). The tree answers closest-hit and shadow rays as brute
/// force does.
#[test]
fn copies_and_nested_copies_of_one_triangle() {
    let mut rng = Sampler::new(31, 32, 33);
    let mut prims = triangle_soup(300, &mut rng);
    let corners = [
        Vec3A::new(-0.5, -0.5, 0.2),
        Vec3A::new(0.5, -0.5, 0.2),
        Vec3A::new(0.0, 0.5, 0.2),
    ];
    for k in 0..2100 {
        prims.insert(k % prims.len(), Prim::triangle(corners));
        let s = (k + 1) as f32 / 2100.0;
        let scaled = corners.map(|c| corners[0] + (c - corners[0]) * s - Vec3A::Z * 0.3);
        prims.insert((7 * k) % prims.len(), Prim::triangle(scaled));
    }
    prims.push(Prim::Sphere {
        center: Vec3A::new(0.3, -0.2, 0.1),
        radius: 0.25,
    });
    let accel = build(&prims);
    let hits = random_rays_match(&accel, &prims, &mut rng, 5_000, false);
    assert!(hits > 400, "{hits}");
}

/// A mesh large enough for the builder to split its top nodes and build their halves in parallel
/// (40,000 triangles, on a pool of two threads) answers closest-hit and shadow rays as brute force
/// does, like its tree built on one thread.
#[test]
fn large_mesh_built_in_parallel_matches_brute_force() {
    let mut rng = Sampler::new(41, 42, 43);
    let prims = triangle_soup(40_000, &mut rng);
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let accel = pool.install(|| build(&prims));
        let hits = random_rays_match(&accel, &prims, &mut rng, 600, false);
        assert!(hits > 100, "{threads} threads: {hits}");
    }
    node_tests_agree(&prims, &mut rng, 2_000);
}

/// The small-scene scan for each SIMD extension of this CPU gives brute force's closest hit bit for
/// bit (distance, primitive — the lowest index among equal distances — and barycentrics) and its
/// shadow-ray answer (skipping planes), on rays
/// through shared edges and vertices, along axes and with -0.0 components, with finite and
/// infinite ends; the tree agrees with it. Scenes: a closed sphere mesh (48 triangles), a box of
/// axis-aligned quads with two boxes inside (a Cornell box, 36), random triangles (17 and 64: a
/// part-filled and four full packs). The Cornell box's packs keep its walls apart.
#[test]
fn small_scene_scan_is_brute_force_bit_for_bit() {
    let mut rng = Sampler::new(21, 22, 23);
    let sphere = closed_sphere(4, 8, 0.1, &mut rng);
    let mut cornell = Vec::new();
    let quad = |prims: &mut Vec<Prim>, c: [Vec3A; 4]| {
        prims.push(Prim::triangle([c[0], c[1], c[2]]));
        prims.push(Prim::triangle([c[0], c[2], c[3]]));
    };
    let box_at = |prims: &mut Vec<Prim>, lo: Vec3A, hi: Vec3A| {
        let c = |x: bool, y: bool, z: bool| {
            Vec3A::new(
                if x { hi.x } else { lo.x },
                if y { hi.y } else { lo.y },
                if z { hi.z } else { lo.z },
            )
        };
        for a in [false, true] {
            quad(
                prims,
                [
                    c(a, false, false),
                    c(a, true, false),
                    c(a, true, true),
                    c(a, false, true),
                ],
            );
            quad(
                prims,
                [
                    c(false, a, false),
                    c(true, a, false),
                    c(true, a, true),
                    c(false, a, true),
                ],
            );
            quad(
                prims,
                [
                    c(false, false, a),
                    c(true, false, a),
                    c(true, true, a),
                    c(false, true, a),
                ],
            );
        }
    };
    // Five walls (the box open at z = 1, its last face), two boxes standing on the floor and a
    // light in the ceiling.
    box_at(&mut cornell, Vec3A::splat(-1.0), Vec3A::splat(1.0));
    cornell.truncate(10);
    box_at(
        &mut cornell,
        Vec3A::new(-0.6, -1.0, -0.6),
        Vec3A::new(-0.1, 0.2, -0.1),
    );
    box_at(
        &mut cornell,
        Vec3A::new(0.1, -1.0, 0.1),
        Vec3A::new(0.6, -0.5, 0.6),
    );
    let light = |x: f32, z: f32| Vec3A::new(x, 1.0, z);
    quad(
        &mut cornell,
        [
            light(-0.2, -0.2),
            light(0.2, -0.2),
            light(0.2, 0.2),
            light(-0.2, 0.2),
        ],
    );
    let random: Vec<Prim> = (0..MAX_TRIANGLES)
        .map(|_| {
            let c = r3(&mut rng);
            Prim::triangle([c, c + r3(&mut rng) * 0.5, c + r3(&mut rng) * 0.5])
        })
        .collect();
    let scenes = [sphere, cornell, random[..17].to_vec(), random];
    assert_eq!(scenes.each_ref().map(Vec::len), [48, 36, 17, MAX_TRIANGLES]);
    // The Cornell box's cuts keep its walls apart from each other and from the boxes standing in
    // it (a ray leaving a wall never enters that wall's flat box; a segment inside the room meets
    // none), so a ray scans few packs.
    if let Some(scan) = SmallScene::new(&scenes[1], |i| i as u32) {
        let flat = scan
            .bounds()
            .iter()
            .filter(|[lo, hi]| (*hi - *lo).min_element() == 0.0)
            .count();
        assert!(flat >= 5, "{:?}", scan.bounds());
    }
    #[cfg(target_arch = "x86_64")]
    let extensions = std::arch::is_x86_feature_detected!("avx512f") as usize
        + std::arch::is_x86_feature_detected!("avx2") as usize;
    #[cfg(not(target_arch = "x86_64"))]
    let extensions = 0;
    let mut rng = Sampler::new(24, 25, 26);
    let (mut rays, mut hits, mut blocked) = (0, 0, 0);
    for prims in &scenes {
        // Each triangle its own plane, as in `build`.
        let scans = SmallScene::each_extension(prims, |i| i as u32);
        assert_eq!(scans.len(), extensions);
        let accel = build(prims);
        let shapes: Vec<u32> = (0..prims.len() as u32).collect();
        let tree = Accel::build_tree(prims, &shapes, prims.len());
        let vertices: Vec<Vec3A> = prims
            .iter()
            .flat_map(|p| match p {
                Prim::Triangle { v, .. } => *v,
                _ => unreachable!(),
            })
            .collect();
        for k in 0..6000 {
            // Origins inside and outside; directions random, towards a vertex or an edge's
            // midpoint (shared edges and vertices), or with zero components (±0.0).
            let o =
                Vec3A::new(rng.next_1d(), rng.next_1d(), rng.next_1d()) * 3.0 - Vec3A::splat(1.5);
            let target = |i: usize| vertices[i % vertices.len()];
            let i = (rng.next_1d() * vertices.len() as f32) as usize;
            let mut d = match k % 4 {
                0 => square_to_uniform_sphere(rng.next_2d()),
                1 => target(i) - o,
                2 => (target(i) + target(i / 3 * 3 + (i + 1) % 3)) * 0.5 - o,
                _ => square_to_uniform_sphere(rng.next_2d()),
            };
            if k % 4 == 3 {
                for a in 0..3 {
                    if rng.next_1d() < 0.5 {
                        d[a] = if rng.next_1d() < 0.5 { 0.0 } else { -0.0 };
                    }
                }
            }
            let Some(d) = d.try_normalize() else { continue };
            let tmax = if k % 3 == 0 {
                1.0 + rng.next_1d()
            } else {
                f32::INFINITY
            };
            let want = intersect_brute(prims, o, d, 1e-4, tmax);
            let bits = |h: Option<nlos_rs::geometry::Hit>| {
                h.map(|h| (h.t.to_bits(), h.prim, h.b.map(f32::to_bits)))
            };
            // Every pack, the packs whose boxes the ray enters (away from axis planes, as the
            // accelerator asks), and for a finite segment those whose boxes overlap its own.
            let (a, b) = (o + 1e-4 * d, o + tmax * d);
            let segment = [a.min(b) - 1e-5, a.max(b) + 1e-5];
            let culled = |packs: Packs| Query {
                packs,
                ..every_pack(o, d, 1e-4, tmax)
            };
            for scan in &scans {
                let got = scan.intersect(every_pack(o, d, 1e-4, tmax));
                assert_eq!(bits(got), bits(want), "{o:?} + t {d:?} up to {tmax}");
                if d.abs().min_element() >= 1e-6 {
                    let got = scan.intersect(culled(Packs::Entered));
                    assert_eq!(
                        bits(got),
                        bits(want),
                        "entered: {o:?} + t {d:?} up to {tmax}"
                    );
                }
                if tmax.is_finite() {
                    let got = scan.intersect(culled(Packs::Only(scan.overlapping(segment))));
                    assert_eq!(
                        bits(got),
                        bits(want),
                        "overlap: {o:?} + t {d:?} up to {tmax}"
                    );
                }
            }
            // The scene's accelerator is the scan where there is one. The tree finds the same
            // distance to within rounding: at a vertex shared by several triangles their
            // distances differ in the last bit, and the tree skips a box entered beyond its
            // closest hit so far, so it may return one of the others.
            if !scans.is_empty() {
                assert_eq!(bits(accel.intersect(o, d, 1e-4, tmax)), bits(want));
            }
            match (tree.intersect(o, d, 1e-4, tmax), want) {
                (Some(a), Some(b)) => assert!((a.t - b.t).abs() <= 1e-6 * b.t, "{a:?} vs {b:?}"),
                (a, b) => assert!(
                    a.is_none() && b.is_none(),
                    "tree: {o:?} + t {d:?}: {a:?} vs {b:?}"
                ),
            }
            // Shadow rays, skipping up to two triangles' planes: all agree with brute force
            // over the other triangles.
            let pick = |u: f32| ((u * prims.len() as f32) as u32).min(prims.len() as u32 - 1);
            let skip = [
                pick(rng.next_1d()),
                if k % 2 == 0 {
                    NO_PLANE
                } else {
                    pick(rng.next_1d())
                },
            ];
            let t_end = 0.5 + 2.0 * rng.next_1d();
            let free = prims
                .iter()
                .enumerate()
                .filter(|(j, _)| !skip.contains(&(*j as u32)))
                .all(|(_, p)| p.intersect(o, d, 1e-4, t_end).is_none());
            let (a, b) = (o + 1e-4 * d, o + t_end * d);
            let segment = [a.min(b) - 1e-5, a.max(b) + 1e-5];
            for scan in &scans {
                let q = every_pack(o, d, 1e-4, t_end);
                assert_eq!(scan.unoccluded(q, skip), free, "{o:?} + t {d:?}");
                if d.abs().min_element() >= 1e-6 {
                    let q = Query {
                        packs: Packs::Entered,
                        ..q
                    };
                    assert_eq!(scan.unoccluded(q, skip), free, "entered: {o:?} + t {d:?}");
                }
                let q = Query {
                    packs: Packs::Only(scan.overlapping(segment)),
                    ..q
                };
                assert_eq!(scan.unoccluded(q, skip), free, "overlap: {o:?} + t {d:?}");
            }
            assert_eq!(accel.unoccluded(o, d, 1e-4, t_end, skip), free);
            assert_eq!(tree.unoccluded(o, d, 1e-4, t_end, skip), free);
            rays += 1;
            hits += want.is_some() as u32;
            blocked += !free as u32;
        }
    }
    assert!(
        rays > 20_000 && hits > 8_000 && blocked > 4_000,
        "{rays} rays, {hits} hits, {blocked} blocked"
    );
    // Not small: one triangle too many, or a sphere.
    let mut more = scenes[3].clone();
    more.push(more[0]);
    assert!(SmallScene::new(&more, |_| NO_PLANE).is_none());
    more.truncate(3);
    more.push(Prim::Sphere {
        center: Vec3A::ZERO,
        radius: 0.5,
    });
    assert!(SmallScene::new(&more, |_| NO_PLANE).is_none());
}

/// The scan against brute force on 400 random scenes of 1–64 triangles at three scales (1e-3, 1,
/// 1e3 m), a third of them degenerate (collinear or repeated vertices) and many sharing vertices,
/// with rays aimed at vertices and random ones, finite and infinite ends: closest hits bit for bit
/// and shadow-ray answers, on each extension of this CPU.
#[test]
fn small_scene_scan_matches_brute_force_on_random_and_degenerate_scenes() {
    fn point(rng: &mut Sampler, scale: f32) -> Vec3A {
        (Vec3A::new(rng.next_1d(), rng.next_1d(), rng.next_1d()) * 2.0 - Vec3A::ONE) * scale
    }
    let mut rng = Sampler::new(77, 1, 2);
    let pick = |rng: &mut Sampler, v: &[Vec3A]| {
        v[((rng.next_1d() * v.len() as f32) as usize).min(v.len() - 1)]
    };
    let mut queries = 0;
    for scene in 0..400 {
        let scale = [1e-3f32, 1.0, 1e3][scene % 3];
        let n = 1 + ((rng.next_1d() * MAX_TRIANGLES as f32) as usize).min(MAX_TRIANGLES - 1);
        let (mut vertices, mut prims) = (Vec::new(), Vec::new());
        for k in 0..n {
            let a = if k > 0 && rng.next_1d() < 0.5 {
                pick(&mut rng, &vertices)
            } else {
                point(&mut rng, scale)
            };
            let b = if k > 0 && rng.next_1d() < 0.3 {
                pick(&mut rng, &vertices)
            } else {
                point(&mut rng, scale)
            };
            let c = match k % 7 {
                0 => a + (b - a) * 0.5,
                1 => a,
                _ => point(&mut rng, scale),
            };
            vertices.extend([a, b, c]);
            prims.push(Prim::triangle([a, b, c]));
        }
        let scans = SmallScene::each_extension(&prims, |i| i as u32);
        let accel = build(&prims);
        for k in 0..500 {
            let o = (Vec3A::new(rng.next_1d(), rng.next_1d(), rng.next_1d()) * 3.0
                - Vec3A::splat(1.5))
                * scale;
            let mut d = if rng.next_1d() < 0.5 {
                square_to_uniform_sphere(rng.next_2d())
            } else {
                (pick(&mut rng, &vertices) - o).normalize_or(Vec3A::X)
            };
            // Every tenth ray nearly along an axis (the packs' box test takes another path).
            if k % 10 == 0 {
                let a = k / 10 % 3;
                d = (Vec3A::AXES[a] * d[a].signum() + (d - Vec3A::AXES[a] * d[a]) * 1e-7)
                    .normalize();
            }
            let tmax = if rng.next_1d() < 0.5 {
                f32::INFINITY
            } else {
                3.0 * scale * rng.next_1d()
            };
            let bits = |h: Option<nlos_rs::geometry::Hit>| {
                h.map(|h| (h.t.to_bits(), h.prim, h.b.map(f32::to_bits)))
            };
            let want = bits(intersect_brute(&prims, o, d, 0.0, tmax));
            let t_end = tmax.min(10.0 * scale);
            let free = intersect_brute(&prims, o, d, 0.0, t_end).is_none();
            for scan in &scans {
                assert_eq!(
                    bits(scan.intersect(every_pack(o, d, 0.0, tmax))),
                    want,
                    "scene {scene}: {o:?} + t {d:?}"
                );
                assert_eq!(
                    scan.unoccluded(every_pack(o, d, 0.0, t_end), NONE),
                    free,
                    "scene {scene}: {o:?} + t {d:?}"
                );
                queries += 1;
            }
            // The accelerator: the scan where the CPU has one, each ray testing only the packs
            // whose boxes it enters.
            assert_eq!(
                bits(accel.intersect(o, d, 0.0, tmax)),
                want,
                "scene {scene}"
            );
            assert_eq!(
                accel.unoccluded(o, d, 0.0, t_end, NONE),
                free,
                "scene {scene}"
            );
        }
    }
    // (Off x86-64 no scan is built and none is queried.)
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        assert!(queries >= 200_000, "{queries}");
    }
    #[cfg(not(target_arch = "x86_64"))]
    assert_eq!(queries, 0);
}
