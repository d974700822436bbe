//! Paths in lockstep lanes (`integrator::path_packet`): its samplers give the scalar routines'
//! bits, its counter-based numbers are uniform, its ray packets meet what the BVH meets, and its
//! renders agree with the scalar tracers' whatever the thread count — `transient_path` on
//! mitransient's Cornell box file and on variants of it (curved shading normals, finite depth,
//! Russian roulette from the second bounce, camera unwarping, direct light discarded, many
//! lights, mono and rgb), and `transient_nlos_path` on mitransient's camera files with
//! hidden-geometry sampling off (two-sided surfaces with two
//! reflectances, one-sided ones, finite depth, `filter_bounces`, direct paths discarded, first and
//! last bounces accounted for) and on tal's scan-point captures (single and confocal).

// Loops over the lanes index several arrays by one lane at once.
#![allow(clippy::needless_range_loop)]

mod common;

use glam::{Vec2, Vec3A};
use nlos_rs::Scene;
use nlos_rs::capture::Capture;
use nlos_rs::geometry::Prim;
use nlos_rs::geometry::ray_packet::{Balls, LANES, MAX_BALLS, NO_PLANE, Packet, PacketScene};
use nlos_rs::integrator::path_packet::PathPacket;
use nlos_rs::render::{Monitor, RenderOptions, Rendered, render};
use nlos_rs::sampling::{
    ONE_MINUS_EPSILON, Sampler, lane_key, lane_uniform, square_to_uniform_disk_concentric,
    square_to_uniform_disk_concentric_lanes, square_to_uniform_triangle,
    square_to_uniform_triangle_lanes,
};
use nlos_rs::scene::{Los, Setup};
use nlos_rs::simd::F8;
use std::collections::HashMap;
use std::f32::consts::FRAC_1_SQRT_2;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

fn cbox_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/mitransient/cornell-box")
}

/// mitransient's `cbox_diffuse.xml` at `res`², with `edit` applied to its text.
fn cbox(res: u32, edit: impl Fn(String) -> String) -> Scene {
    let dir = cbox_dir();
    let text = edit(std::fs::read_to_string(dir.join("cbox_diffuse.xml")).expect("the file"));
    let params: HashMap<String, String> = [("res".to_string(), res.to_string())].into();
    let props = nlos_rs::xml::parse(&text, &dir.join("cbox_diffuse.xml"), &params).expect("parses");
    Scene::from_props(&props, &dir).expect("valid scene")
}

fn los(scene: &Scene) -> &Los {
    let Setup::Los(los) = &scene.setup else {
        panic!("a line-of-sight scene")
    };
    los
}

/// The Cornell box with an octahedron (radius 90, shaded by vertex normals along its radii, so
/// normals vary over each face) on the small box and a flat panel with curved normals, written as an OBJ file in the temporary folder,
/// one per test (`tag`) so that tests running at once do not share it; the test removes it once
/// its scenes are loaded.
fn octahedron_obj(tag: &str) -> PathBuf {
    let name = format!("nlos_rs_los_octahedron_{}_{tag}.obj", std::process::id());
    let path = std::env::temp_dir().join(name);
    let mut s = String::new();
    let (c, r) = ([185.0, 255.0, 170.0], 90.0);
    let dirs = [
        [1., 0., 0.],
        [-1., 0., 0.],
        [0., 1., 0.],
        [0., -1., 0.],
        [0., 0., 1.],
        [0., 0., -1.],
    ];
    for d in dirs {
        s += &format!(
            "v {} {} {}\n",
            c[0] + r * d[0],
            c[1] + r * d[1],
            c[2] + r * d[2]
        );
        s += &format!("vn {} {} {}\n", d[0], d[1], d[2]);
    }
    // Faces (1-based), counter-clockwise seen from outside.
    for (a, b, k) in [
        (1, 3, 5),
        (3, 2, 5),
        (2, 4, 5),
        (4, 1, 5),
        (3, 1, 6),
        (2, 3, 6),
        (4, 2, 6),
        (1, 4, 6),
    ] {
        s += &format!("f {a}//{a} {b}//{b} {k}//{k}\n");
    }
    // A flat panel facing the camera before the back wall, in the same shape: two triangles that
    // make a parallelogram, its vertex normals no affine field.
    for (v, n) in [
        ([330., 250., 500.], [-0.5, -0.5, -FRAC_1_SQRT_2]),
        ([480., 250., 500.], [0.5, -0.5, -FRAC_1_SQRT_2]),
        ([480., 450., 500.], [0.5, 0.5, -FRAC_1_SQRT_2]),
        ([330., 450., 500.], [0.8, 0., -0.6]),
    ] {
        s += &format!(
            "v {} {} {}\nvn {} {} {}\n",
            v[0], v[1], v[2], n[0], n[1], n[2]
        );
    }
    s += "f 7//7 9//9 8//8\nf 7//7 10//10 9//9\n";
    std::fs::write(&path, s).expect("scratch file");
    path
}

/// A latitude-longitude sphere of centre `c` and radius `r`, `rings` × `segments` quads
/// (triangles at the poles), its vertex normals along its radii, as an OBJ file in the temporary
/// folder (`tag` as in [`octahedron_obj`]).
fn sphere_obj(tag: &str, rings: usize, segments: usize, c: [f64; 3], r: f64) -> PathBuf {
    let name = format!("nlos_rs_los_sphere_{}_{tag}.obj", std::process::id());
    let path = std::env::temp_dir().join(name);
    let mut s = String::new();
    for i in 0..=rings {
        let th = std::f64::consts::PI * i as f64 / rings as f64;
        for j in 0..segments {
            let ph = std::f64::consts::TAU * j as f64 / segments as f64;
            let n = [th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin()];
            s += &format!(
                "v {} {} {}\nvn {} {} {}\n",
                c[0] + r * n[0],
                c[1] + r * n[1],
                c[2] + r * n[2],
                n[0],
                n[1],
                n[2]
            );
        }
    }
    let at = |i: usize, j: usize| i * segments + j % segments + 1;
    for i in 0..rings {
        for j in 0..segments {
            let (a, b, c, d) = (at(i, j), at(i, j + 1), at(i + 1, j), at(i + 1, j + 1));
            if i > 0 {
                s += &format!("f {a}//{a} {b}//{b} {c}//{c}\n");
            }
            if i + 1 < rings {
                s += &format!("f {b}//{b} {d}//{d} {c}//{c}\n");
            }
        }
    }
    std::fs::write(&path, s).expect("scratch file");
    path
}

/// Line-of-sight scenes past the packet test (more than 64 triangles, or spheres and disks) take
/// the lanes with their meshes and curved primitives in a tree: lockstep renders agree with the
/// scalar tracer's and are bit-identical at 1, 2 and 3 threads, with a curved sphere of 100
/// triangles on the Cornell box's small box (Lambertian and glass), an analytic sphere there
/// (Lambertian, and glass with a disk facing the camera), and ten spheres (more than the lanes
/// test at once: the rest go to the tree).
#[test]
fn lockstep_through_the_tree_agrees_with_the_scalar_tracer() {
    // On the Cornell box's small box.
    let obj = sphere_obj("tree", 6, 10, [185.0, 255.0, 170.0], 90.0);
    let with = |bsdf: &str| {
        let shape = format!(
            "<shape type=\"obj\"><string name=\"filename\" value=\"{}\"/>{bsdf}</shape>\n</scene>",
            obj.display()
        );
        cbox(6, |t| t.replace("</scene>", &shape))
    };
    let analytic =
        |shapes: &str| cbox(6, |t| t.replace("</scene>", &format!("{shapes}\n</scene>")));
    let sphere = |bsdf: &str| {
        format!(
            "<shape type=\"sphere\"><point name=\"center\" x=\"185\" y=\"255\" z=\"170\"/>\
             <float name=\"radius\" value=\"90\"/>{bsdf}</shape>"
        )
    };
    let disk = "<shape type=\"disk\"><transform name=\"to_world\"><scale value=\"80\"/>\
                <translate x=\"400\" y=\"300\" z=\"450\"/></transform><ref id=\"gray\"/>\
                <boolean name=\"flip_normals\" value=\"true\"/></shape>";
    // Ten spheres about the box's middle, radii 25 to 70: more than the lanes test at once.
    let balls: String = (0..10)
        .map(|k| {
            let (x, y, z) = (
                100 + 40 * (k % 5),
                120 + 60 * (k / 5) + 10 * (k % 3),
                150 + 30 * k,
            );
            let bsdf = if k == 9 {
                "<bsdf type=\"dielectric\"/>"
            } else {
                "<ref id=\"white\"/>"
            };
            format!(
                "<shape type=\"sphere\"><point name=\"center\" x=\"{x}\" y=\"{y}\" z=\"{z}\"/>\
                 <float name=\"radius\" value=\"{}\"/>{bsdf}</shape>",
                25 + 5 * k
            )
        })
        .collect();
    let cases = [
        (
            "a curved sphere of 100 triangles, rgb",
            with("<ref id=\"white\"/>"),
            false,
        ),
        (
            "the sphere in glass, mono",
            with("<bsdf type=\"dielectric\"/>"),
            true,
        ),
        (
            "an analytic sphere, rgb",
            analytic(&sphere("<ref id=\"white\"/>")),
            false,
        ),
        (
            "an analytic sphere of glass and a disk facing the camera, mono",
            analytic(&(sphere("<bsdf type=\"dielectric\"/>") + disk)),
            true,
        ),
        (
            "ten analytic spheres (eight in lanes, two in the tree; one of glass), mono",
            analytic(&balls),
            true,
        ),
    ];
    std::fs::remove_file(&obj).expect("scratch file");
    los_cases_agree(&cases);
}

/// The lane forms of both samplers at the points `u`.
#[cfg_attr(target_arch = "x86_64", target_feature(enable = "avx2,fma"))]
unsafe fn lanes_of(u: &[Vec2; LANES]) -> ([[f32; LANES]; 2], [[f32; LANES]; 2]) {
    let x = F8::load(&u.map(|u| u.x));
    let y = F8::load(&u.map(|u| u.y));
    let (dx, dy) = square_to_uniform_disk_concentric_lanes(x, y);
    let (b1, b2) = square_to_uniform_triangle_lanes(x, y);
    ([dx.store(), dy.store()], [b1.store(), b2.store()])
}

/// The lane forms of the concentric disk and the uniform triangle give, lane by lane, the bits of
/// the scalar routines (which tests/sampling.rs χ²-tests against their densities), on the square's
/// edges, its centre lines and 400,000 random points.
#[test]
fn lane_samplers_give_the_scalar_bits() {
    if !nlos_rs::simd::available() {
        return; // no AVX2 on this x86-64 CPU: the lanes never run here
    }
    let edge = [0.0, 0.25, 0.5, 0.75, ONE_MINUS_EPSILON];
    let mut rng = Sampler::new(5, 0, 0);
    let points: Vec<Vec2> = (edge
        .iter()
        .flat_map(|&x| edge.iter().map(move |&y| Vec2::new(x, y))))
    .chain((0..400_000).map(|_| rng.next_2d()))
    .collect();
    for chunk in points.chunks(LANES) {
        let mut u = [Vec2::ZERO; LANES];
        u[..chunk.len()].copy_from_slice(chunk);
        // SAFETY: the CPU runs AVX2 and FMA (checked above).
        let (disk, tri) = unsafe { lanes_of(&u) };
        for (l, &p) in u.iter().enumerate() {
            let d = square_to_uniform_disk_concentric(p);
            let t = square_to_uniform_triangle(p);
            assert_eq!(
                [disk[0][l].to_bits(), disk[1][l].to_bits()],
                [d.x.to_bits(), d.y.to_bits()],
                "disk at {p}"
            );
            assert_eq!(
                [tri[0][l].to_bits(), tri[1][l].to_bits()],
                [t.x.to_bits(), t.y.to_bits()],
                "triangle at {p}"
            );
        }
    }
}

/// The counter-based numbers of lockstep samples are uniform one at a time and in pairs: of one
/// sample's consecutive dimensions, of consecutive samples' same dimension, and of neighbouring
/// pixels' same sample (χ² over 31 and 31×31 cells, 400,000 draws each).
#[test]
fn lane_uniforms_are_uniform_and_pairwise_independent() {
    use common::{N, RES, Z_CRIT, chi2_z};
    let key = lane_key(9, 4);
    let other = lane_key(9, 5);
    type Draw<'a> = Box<dyn Fn(u64) -> (f32, f32) + 'a>;
    let pairs: [(&str, Draw); 4] = [
        (
            "one dimension",
            Box::new(|i| (lane_uniform(key.sample(i / 8), (i % 8) as u32), 0.5)),
        ),
        (
            "consecutive dimensions",
            Box::new(|i| {
                let (s, d) = (key.sample(i / 16), (i % 16) as u32);
                (lane_uniform(s, d), lane_uniform(s, d + 1))
            }),
        ),
        (
            "consecutive samples",
            Box::new(|i| {
                let d = (i % 8) as u32;
                (
                    lane_uniform(key.sample(i / 8), d),
                    lane_uniform(key.sample(i / 8 + 1), d),
                )
            }),
        ),
        (
            "neighbouring pixels",
            Box::new(|i| {
                let d = (i % 8) as u32;
                (
                    lane_uniform(key.sample(i / 8), d),
                    lane_uniform(other.sample(i / 8), d),
                )
            }),
        ),
    ];
    for (name, draw) in pairs {
        let mut obs = vec![0.0; RES * RES];
        for i in 0..N as u64 {
            let (a, b) = draw(i);
            assert!((0.0..1.0).contains(&a) && (0.0..1.0).contains(&b));
            let (x, y) = ((a * RES as f32) as usize, (b * RES as f32) as usize);
            obs[y.min(RES - 1) * RES + x.min(RES - 1)] += 1.0;
        }
        let exp = vec![N as f64 / (RES * RES) as f64; RES * RES];
        let z = if name == "one dimension" {
            let rows: Vec<f64> = (0..RES)
                .map(|x| (0..RES).map(|y| obs[y * RES + x]).sum())
                .collect();
            chi2_z(&rows, &vec![N as f64 / RES as f64; RES])
        } else {
            chi2_z(&obs, &exp)
        };
        assert!(z < Z_CRIT, "{name}: chi-square z = {z:.2}");
    }
}

/// The least barycentric coordinate of `x` (in the plane of triangle `v`): negative outside it.
fn least_barycentric(v: [Vec3A; 3], x: Vec3A) -> f32 {
    let (e1, e2, w) = (v[1] - v[0], v[2] - v[0], x - v[0]);
    let big_n = e1.cross(e2);
    let b1 = w.cross(e2).dot(big_n) / big_n.length_squared();
    let b2 = e1.cross(w).dot(big_n) / big_n.length_squared();
    b1.min(b2).min(1.0 - b1 - b2)
}

/// A uniform point of triangle `v` and a cosine-weighted direction about its normal `n`.
fn on_surface(v: [Vec3A; 3], n: Vec3A, rng: &mut Sampler) -> (Vec3A, Vec3A) {
    let b = square_to_uniform_triangle(rng.next_2d());
    let x = v[0] * (1.0 - b.x - b.y) + v[1] * b.x + v[2] * b.y;
    let f = nlos_rs::math::Frame::new(n);
    (
        x,
        f.to_world(nlos_rs::sampling::square_to_cosine_hemisphere(
            rng.next_2d(),
        )),
    )
}

/// In the Cornell box (a room open towards the camera, with two boxes and the octahedron), packets
/// of eight rays meet what the scene's BVH meets: from random points inside the room every ray
/// meets a surface where the BVH finds one (none slips between two triangles), at the BVH's
/// distance and in its plane, and leaves the room where the BVH finds none; from points on the
/// surfaces (skipping their own plane, as lockstep paths start) likewise; and shadow rays between
/// two surface points are blocked exactly when the scene says the points do not see each other.
#[test]
fn packet_rays_meet_what_the_bvh_meets() {
    let obj = octahedron_obj("rays");
    let scene = cbox(4, |t| add_octahedron(t, &obj));
    std::fs::remove_file(&obj).expect("scratch file");
    let Some(packets) = PacketScene::new(&scene.prims, |i, j| {
        scene.prim_shape[i] == scene.prim_shape[j]
    }) else {
        assert!(!nlos_rs::simd::available());
        return;
    };
    let forms = packets.each_extension();
    assert_eq!(forms.len(), 1 + nlos_rs::simd::wide_available() as usize);
    let tris: Vec<([Vec3A; 3], Vec3A)> = scene
        .prims
        .iter()
        .map(|p| match *p {
            Prim::Triangle { v, n } => (v, n),
            _ => panic!("triangles only"),
        })
        .collect();
    let mut rng = Sampler::new(21, 0, 0);
    let (mut inside, mut surface, mut escaped, mut other, mut corners) = (0, 0, 0, 0, 0);
    let mut grazes = 0;
    let (mut shadows, mut blocked) = (0, 0);
    for round in 0..40_000 {
        let mut p = Packet {
            skip: [[NO_PLANE; LANES]; 2],
            ..Packet::default()
        };
        let mut from = [None; LANES];
        for l in 0..LANES {
            let (o, d, skip) = if round % 2 == 0 {
                let u = Vec3A::new(rng.next_1d(), rng.next_1d(), rng.next_1d());
                let o = Vec3A::new(10.0, 10.0, 10.0) + u * Vec3A::new(530.0, 520.0, 530.0);
                let d = nlos_rs::sampling::square_to_uniform_sphere(rng.next_2d());
                (o, d, NO_PLANE)
            } else {
                let i = ((rng.next_1d() * tris.len() as f32) as usize).min(tris.len() - 1);
                let (o, d) = on_surface(tris[i].0, tris[i].1, &mut rng);
                from[l] = Some(i);
                (o, d, packets.plane(i as u32))
            };
            for a in 0..3 {
                (p.o[a][l], p.d[a][l]) = (o[a], d[a]);
            }
            (p.tmin[l], p.tmax[l], p.skip[0][l]) = (0.0, f32::INFINITY, skip);
        }
        let (t, prim) = packets.closest(&p);
        // Every compiled form of the test (AVX-512's where the CPU has it, AVX2's) gives the
        // same bits.
        for form in &forms {
            let (tf, pf) = form.closest(&p);
            assert_eq!((tf.map(f32::to_bits), pf), (t.map(f32::to_bits), prim));
        }
        let mut shadow = p;
        let mut lanes = 0;
        for l in 0..LANES {
            let o = Vec3A::new(p.o[0][l], p.o[1][l], p.o[2][l]);
            let d = Vec3A::new(p.d[0][l], p.d[1][l], p.d[2][l]);
            // From a surface, the BVH's ray starts past the rounding about its origin (which the
            // packet's skips by its plane); a packet hit that near (a corner) is not compared.
            let tmin = from[l].map_or(0.0, |_| 1e-4 * (1.0 + o.abs().max_element()));
            if prim[l] != u32::MAX && t[l] <= tmin {
                corners += 1;
                continue;
            }
            let bvh = scene.accel.intersect(o, d, tmin, f32::INFINITY);
            // The room is open towards the camera: a ray may leave it, in both or in neither —
            // or graze an open edge, where the packet's slack takes what the BVH's exact test
            // does not: its hit then lies on the triangle's boundary.
            let Some(hit) = bvh else {
                if prim[l] != u32::MAX {
                    let least = least_barycentric(tris[prim[l] as usize].0, o + d * t[l]);
                    assert!(
                        least.abs() <= 1e-5,
                        "ray from {o} along {d}: met {} at {} ({least}) where the BVH meets nothing",
                        prim[l],
                        t[l]
                    );
                    grazes += 1;
                }
                escaped += 1;
                continue;
            };
            assert!(
                prim[l] != u32::MAX,
                "ray from {o} along {d} slipped past {hit:?}"
            );
            if from[l].is_none() {
                inside += 1;
            } else {
                surface += 1;
            }
            // Distances agree to the f32 rounding of a plane test at the scene's coordinates
            // (about 1e-6 of them), divided by the cosine with the plane met.
            let cos = tris[hit.prim as usize].1.dot(d).abs().max(1e-3);
            let slack = 4e-6 * (1.0 + o.abs().max_element() + hit.t) / cos;
            assert!((t[l] - hit.t).abs() <= slack, "{} against {}", t[l], hit.t);
            // In the BVH's plane (coincident surfaces, such as a box's bottom on the floor, share
            // a key), and on the triangle reported (of a parallelogram, the half hit).
            assert_eq!(
                packets.plane(prim[l]),
                packets.plane(hit.prim),
                "ray from {o} along {d}: plane of {} at {} against {} at {}",
                prim[l],
                t[l],
                hit.prim,
                hit.t
            );
            let least = least_barycentric(tris[prim[l] as usize].0, o + d * t[l]);
            assert!(
                least >= -1e-5,
                "ray from {o} along {d}: {} met outside it ({least})",
                prim[l]
            );
            other += (prim[l] != hit.prim) as u32;
            // A shadow ray to a random point on another surface.
            if from[l].is_some() {
                let j = ((rng.next_1d() * tris.len() as f32) as usize).min(tris.len() - 1);
                let (y, _) = on_surface(tris[j].0, tris[j].1, &mut rng);
                let w = y - o;
                let r = w.length();
                if packets.plane(j as u32) == p.skip[0][l] || r < 1.0 {
                    continue;
                }
                for a in 0..3 {
                    shadow.d[a][l] = w[a] / r;
                }
                shadow.tmax[l] = r;
                shadow.skip[1][l] = packets.plane(j as u32);
                lanes |= 1 << l;
            }
        }
        if lanes == 0 {
            continue;
        }
        let open = packets.unoccluded(&shadow, lanes);
        for form in &forms {
            assert_eq!(form.unoccluded(&shadow, lanes), open);
        }
        for l in 0..LANES {
            if lanes >> l & 1 == 0 {
                continue;
            }
            let o = Vec3A::new(shadow.o[0][l], shadow.o[1][l], shadow.o[2][l]);
            let d = Vec3A::new(shadow.d[0][l], shadow.d[1][l], shadow.d[2][l]);
            let r = shadow.tmax[l];
            // What the BVH meets between the ends, past the planes of both (a shadow ray meets
            // each of them at its end alone; from a grazing direction the BVH may find the
            // origin's own plane anywhere along the ray by rounding), within `margin` of the
            // segment's length of the ends.
            let skip = [shadow.skip[0][l], shadow.skip[1][l]];
            let meets = |margin: f32| {
                let (mut from, to) = (margin * r, r * (1.0 - margin));
                while let Some(h) = scene.accel.intersect(o, d, from, to) {
                    if !skip.contains(&packets.plane(h.prim)) {
                        return Some(h);
                    }
                    from = h.t;
                }
                None
            };
            let (first, clear_margin) = (meets(1e-3), meets(1e-5));
            shadows += 1;
            if open >> l & 1 == 0 {
                blocked += 1;
                assert!(
                    clear_margin.is_some(),
                    "shadow ray from {o} along {d} ({r}) blocked by nothing"
                );
            } else {
                assert!(
                    first.is_none(),
                    "shadow ray from {o} along {d} ({r}) passes {first:?}"
                );
            }
        }
    }
    println!(
        "{inside} rays from inside and {surface} from surfaces met the room ({other} on another \
         triangle than the BVH's, at a shared edge or a coincident surface, {escaped} left it, {grazes} of them grazing an open edge the packet meets, {corners} met a surface at its origin's corner); {shadows} shadow rays ({blocked} blocked)"
    );
    let met = inside + surface;
    assert!(escaped < met && other < met / 100 && corners + grazes < met / 1000);
    assert!(blocked > shadows / 20 && blocked < shadows);
}

/// Spheres tested eight rays at once (`Balls`, a split scene's) meet what the scalar sphere test
/// (in double precision) meets, at the same distance to f32 rounding: eight spheres of radii from
/// 1e-2 to 1e3 at coordinates up to 1e3, rays from anywhere and from their surfaces (offset off
/// them as lockstep paths start, outwards or inwards), and shadow segments, tangents aside.
#[test]
fn balls_meet_what_the_sphere_test_meets() {
    if !nlos_rs::simd::available() {
        return;
    }
    let mut rng = Sampler::new(5, 0, 0);
    let mut u3 = || Vec3A::new(rng.next_1d(), rng.next_1d(), rng.next_1d());
    let spheres: Vec<(Vec3A, f32)> = (0..MAX_BALLS)
        .map(|k| {
            let scale = 10f32.powi(k as i32 % 6 - 2);
            (
                (u3() * 2.0 - 1.0) * 1e3f32.min(scale * 8.0),
                scale * (0.5 + u3().x),
            )
        })
        .collect();
    let balls = Balls::new(
        spheres
            .iter()
            .enumerate()
            .map(|(i, &(c, r))| (c, r, i as u32)),
    );
    let forms = balls.each_extension();
    assert_eq!(forms.len(), 1 + nlos_rs::simd::wide_available() as usize);
    let prims: Vec<Prim> = spheres
        .iter()
        .map(|&(center, radius)| Prim::Sphere { center, radius })
        .collect();
    let scalar = |o: Vec3A, d: Vec3A, tmin: f32, tmax: f32| {
        (prims.iter().enumerate())
            .filter_map(|(i, p)| p.intersect(o, d, tmin, tmax).map(|(t, _)| (t, i as u32)))
            .min_by(|a, b| a.0.total_cmp(&b.0))
    };
    let (mut hits, mut from_surface, mut tangents, mut shadows, mut blocked) = (0, 0, 0, 0, 0);
    for round in 0..20_000 {
        let mut p = Packet {
            skip: [[NO_PLANE; LANES]; 2],
            ..Packet::default()
        };
        for l in 0..LANES {
            let k = (round * LANES + l) % MAX_BALLS;
            let (c, r) = spheres[k];
            let d = nlos_rs::sampling::square_to_uniform_sphere(Vec2::new(u3().x, u3().y));
            let o = if l % 2 == 0 {
                // Near sphere k, or off its surface.
                c + (u3() * 2.0 - 1.0) * 3.0 * r
            } else {
                let n = nlos_rs::sampling::square_to_uniform_sphere(Vec2::new(u3().x, u3().y));
                from_surface += 1;
                nlos_rs::geometry::offset_origin(c + n * r, n, d)
            };
            for a in 0..3 {
                (p.o[a][l], p.d[a][l]) = (o[a], d[a]);
            }
            p.tmax[l] = if round % 3 == 0 {
                2.0 * r
            } else {
                f32::INFINITY
            };
        }
        let (mut t, mut prim) = ([f32::INFINITY; LANES], [u32::MAX; LANES]);
        balls.closest(&p, &mut t, &mut prim);
        let open = balls.unoccluded(&p, 0xff);
        // Every compiled form gives the same bits.
        for form in &forms {
            let (mut tf, mut pf) = ([f32::INFINITY; LANES], [u32::MAX; LANES]);
            form.closest(&p, &mut tf, &mut pf);
            assert_eq!((tf.map(f32::to_bits), pf), (t.map(f32::to_bits), prim));
            assert_eq!(form.unoccluded(&p, 0xff), open);
        }
        for l in 0..LANES {
            let o = Vec3A::new(p.o[0][l], p.o[1][l], p.o[2][l]);
            let d = Vec3A::new(p.d[0][l], p.d[1][l], p.d[2][l]);
            let want = scalar(o, d, 0.0, p.tmax[l]);
            // A ray within f32 rounding of a tangent (or of its interval's end) may go either
            // way.
            let near_tangent = spheres.iter().any(|&(c, r)| {
                let f = o - c;
                let q = f - d * f.dot(d);
                let end = f + d * p.tmax[l].min(1e30);
                ((q.length() - r).abs() <= 1e-5 * (r + f.length()))
                    || (p.tmax[l].is_finite()
                        && (end.length() - r).abs() <= 1e-5 * (r + f.length()))
            });
            if near_tangent {
                tangents += 1;
                continue;
            }
            shadows += 1;
            blocked += (open >> l & 1 == 0) as u32;
            assert_eq!(
                open >> l & 1 == 0,
                want.is_some(),
                "shadow ray from {o} along {d}"
            );
            match want {
                None => assert_eq!(prim[l], u32::MAX, "ray from {o} along {d} met {}", prim[l]),
                Some((tw, i)) => {
                    hits += 1;
                    assert_eq!(prim[l], i, "ray from {o} along {d}");
                    // The point lies on the sphere to the rounding of o − c and of the roots'
                    // arithmetic (a few ulps), and the distance to that divided by the cosine
                    // with the surface (which the square root of the discriminant amplifies).
                    let (c, r) = spheres[i as usize];
                    let scale = o.abs().max_element() + c.abs().max_element() + r + tw;
                    let off = ((o + d * t[l] - c).length() - r).abs();
                    assert!(
                        off <= 4e-6 * scale,
                        "ray from {o} along {d}: {off} off the sphere"
                    );
                    let (f, d64) = ((o - c).as_dvec3(), d.as_dvec3());
                    let q = f - d64 * f.dot(d64);
                    let cos = ((r as f64).powi(2) - q.length_squared()).max(0.0).sqrt() / r as f64;
                    let slack = 4e-6 * scale / cos.max(1e-3) as f32;
                    assert!(
                        (t[l] - tw).abs() <= slack,
                        "ray from {o} along {d}: {} against {tw}",
                        t[l]
                    );
                }
            }
        }
    }
    println!(
        "{hits} hits of {shadows} rays ({from_surface} from surfaces, {blocked} blocked), {tangents} near a tangent"
    );
    assert!(hits > shadows / 4 && hits < shadows && tangents < shadows / 1000);
    assert_eq!(blocked, hits);
}

/// The octahedron's shape, added to the Cornell box's XML.
fn add_octahedron(text: String, obj: &Path) -> String {
    let shape = format!(
        "<shape type=\"obj\"><string name=\"filename\" value=\"{}\"/><ref id=\"gray\"/></shape>\n</scene>",
        obj.display()
    );
    text.replace("</scene>", &shape)
}

/// Each render's features: per pixel and channel its steady value, and per channel the
/// transient summed over pixels in groups of 25 bins.
fn features(r: &Rendered) -> Vec<f64> {
    let c = *r.transient_shape.last().expect("channels");
    let bins = r.transient_shape[r.transient_shape.len() - 2];
    let mut f: Vec<f64> = r.steady.iter().map(|&v| v as f64).collect();
    let mut profile = vec![0.0; bins.div_ceil(25) * c];
    for (i, &v) in r.transient.iter().enumerate() {
        let (bin, ch) = ((i / c) % bins, i % c);
        profile[(bin / 25) * c + ch] += v as f64;
    }
    f.extend(profile);
    f
}

/// Assert that two estimators agree on every feature with a positive mean in either (Welch t,
/// |t| < 4.5) and that each has some; return how many features were compared.
fn agree(name: &str, a: &[Vec<f64>], b: &[Vec<f64>]) -> usize {
    let stats = |x: &[Vec<f64>], k: usize| {
        let n = x.len() as f64;
        let m = x.iter().map(|r| r[k]).sum::<f64>() / n;
        let v = x.iter().map(|r| (r[k] - m).powi(2)).sum::<f64>() / (n - 1.0);
        (m, v / n)
    };
    let mut compared = 0;
    for k in 0..a[0].len() {
        let ((ma, va), (mb, vb)) = (stats(a, k), stats(b, k));
        if ma == 0.0 && mb == 0.0 {
            continue;
        }
        let t = (ma - mb) / (va + vb).sqrt();
        assert!(
            t.abs() < 4.5,
            "{name}: feature {k}: {ma} (lockstep) vs {mb} (scalar), t = {t}"
        );
        compared += 1;
    }
    assert!(compared > 0, "{name}: nothing rendered");
    compared
}

fn run(scene: &Scene, mono: bool, spp: u64, seed: u64, scalar: bool, threads: usize) -> Rendered {
    // Variance estimates keep per-sample values, which the lockstep lanes do not: such a render
    // takes the scalar path tracer.
    let opts = RenderOptions {
        spp: Some(spp),
        seed,
        mono,
        threads: Some(threads),
        variance: scalar,
        ..Default::default()
    };
    render(scene, &opts, &Monitor::default()).expect("render")
}

/// Lockstep renders agree with the scalar path tracer's (16 seeds each, every pixel and channel
/// and the time profile) on mitransient's Cornell box file and on variants of it, and are
/// bit-identical at 1, 2 and 3 threads.
#[test]
fn lockstep_agrees_with_the_scalar_tracer() {
    let obj = octahedron_obj("renders");
    // Before the back wall: a triangle facing the room (a light part that is no parallelogram),
    // and a square whose second triangle's vertex normals face the wall (one-sided, it emits
    // there alone): two parts, not one parallelogram.
    let tri = std::env::temp_dir().join(format!("nlos_rs_los_triangle_{}.obj", std::process::id()));
    std::fs::write(
        &tri,
        "v 100 100 540\nv 100 200 540\nv 200 100 540\n\
         v 300 100 540\nv 300 200 540\nv 400 200 540\nv 400 100 540\n\
         vn 0 0 -1\nvn 0 0 1\n\
         f 1//1 2//1 3//1\nf 4//1 5//1 6//1\nf 4//2 6//2 7//2\n",
    )
    .expect("scratch file");
    let integrator = |extra: &'static str| {
        move |t: String| t.replace("<integer name=\"max_depth\" value=\"8\"/>", extra)
    };
    let cases: Vec<(&str, Scene, bool)> = vec![
        ("cbox_diffuse.xml, rgb", cbox(6, |t| t), false),
        (
            "with a curved octahedron, mono, depth 3, direct light discarded",
            cbox(6, |t| {
                add_octahedron(
                    integrator(
                        "<integer name=\"max_depth\" value=\"3\"/><boolean name=\"discard_direct_light\" value=\"true\"/>",
                    )(t),
                    &obj,
                )
            }),
            true,
        ),
        (
            "unbounded depth, roulette from depth 2, camera unwarped",
            cbox(6, |t| {
                integrator("<integer name=\"max_depth\" value=\"-1\"/><integer name=\"rr_depth\" value=\"2\"/>")(t)
                    .replace("name=\"camera_unwarp\" value=\"false\"", "name=\"camera_unwarp\" value=\"true\"")
                    .replace("name=\"start_opl\" value=\"1000\"", "name=\"start_opl\" value=\"0\"")
            }),
            false,
        ),
        (
            "lit by the luminaire, the small box's six faces, a triangle and a square of two facings, mono",
            cbox(6, |t| {
                let glow = |rgb: &str| {
                    format!(
                        "<emitter type=\"area\"><rgb name=\"radiance\" value=\"{rgb}\"/></emitter>"
                    )
                };
                let triangle = format!(
                    "<shape type=\"obj\"><string name=\"filename\" value=\"{}\"/><ref id=\"white\"/>{}</shape>\n</scene>",
                    tri.display(),
                    glow("40, 40, 40")
                );
                t.replace(
                    "value=\"meshes/cbox_smallbox.obj\"/>",
                    &format!("value=\"meshes/cbox_smallbox.obj\"/>{}", glow("3, 2, 1")),
                )
                .replace("</scene>", &triangle)
            }),
            true,
        ),
        (
            "the luminaire an angulararea light (full within 20 degrees, none beyond 35), mono",
            cbox(6, |t| {
                t.replace(
                    "<emitter type=\"area\">",
                    "<emitter type=\"angulararea\"><float name=\"cutoff_angle\" value=\"35\"/>\
                     <float name=\"beam_width\" value=\"20\"/>",
                )
            }),
            true,
        ),
    ];
    // An open pane of glass across the room: what is seen through it is in the glass's medium
    // (its light is scaled by the refraction and slower by η).
    let pane = std::env::temp_dir().join(format!("nlos_rs_los_pane_{}.obj", std::process::id()));
    std::fs::write(
        &pane,
        "v 60 60 300\nv 500 60 300\nv 500 500 300\nv 60 500 300\nf 1 3 2\nf 1 4 3\n",
    )
    .expect("scratch file");
    let mut cases = cases;
    cases.push((
        "a pane of glass across the room, mono",
        cbox(6, |t| {
            glazed(
                t.replace(
                    "</scene>",
                    &format!(
                        "<shape type=\"obj\"><string name=\"filename\" value=\"{}\"/>\
                         <bsdf type=\"dielectric\"/></shape>\n</scene>",
                        pane.display()
                    ),
                ),
                1,
            )
        }),
        true,
    ));
    cases.push((
        "boxes of glass (bk7, and water tinted), rgb",
        cbox_boxes(
            "<bsdf type=\"dielectric\"/>",
            "<bsdf type=\"dielectric\"><string name=\"int_ior\" value=\"water\"/>\
             <rgb name=\"specular_transmittance\" value=\"0.9, 0.6, 0.4\"/>\
             <rgb name=\"specular_reflectance\" value=\"0.5, 0.8, 1.0\"/></bsdf>",
        ),
        false,
    ));
    cases.push((
        "a mirror small box and a gold large box (conductors), rgb",
        cbox_boxes(
            "<bsdf type=\"conductor\"/>",
            "<bsdf type=\"conductor\"><string name=\"material\" value=\"Au\"/>\
             <rgb name=\"specular_reflectance\" value=\"0.9, 0.8, 0.7\"/></bsdf>",
        ),
        false,
    ));
    // General BSDFs, evaluated and sampled lane by lane.
    cases.push((
        "a rough conductor small box and a rough plastic large box (GGX), rgb",
        cbox_boxes(
            "<bsdf type=\"roughconductor\"><float name=\"alpha\" value=\"0.2\"/></bsdf>",
            "<bsdf type=\"roughplastic\"><string name=\"distribution\" value=\"ggx\"/>\
             <float name=\"alpha\" value=\"0.1\"/>\
             <rgb name=\"diffuse_reflectance\" value=\"0.2, 0.5, 0.7\"/></bsdf>",
        ),
        false,
    ));
    // (A glossy floor mirrors the light, where a light sample's weight against BSDF sampling
    // counts most.)
    cases.push((
        "a smooth plastic small box, a blend of diffuse and rough gold as the large box and a \
         glossy floor (Beckmann, alpha 0.05), mono",
        cbox_edited(
            "<bsdf type=\"plastic\"/>",
            "<bsdf type=\"blendbsdf\"><float name=\"weight\" value=\"0.4\"/>\
             <bsdf type=\"diffuse\"/><bsdf type=\"roughconductor\">\
             <string name=\"material\" value=\"Au\"/><float name=\"alpha\" value=\"0.3\"/>\
             </bsdf></bsdf>",
            |t| {
                let floor = "value=\"meshes/cbox_floor.obj\"/>\n        <ref id=\"white\"/>";
                assert!(t.contains(floor));
                t.replace(
                    floor,
                    "value=\"meshes/cbox_floor.obj\"/><bsdf type=\"roughconductor\">\
                     <float name=\"alpha\" value=\"0.05\"/></bsdf>",
                )
            },
        ),
        true,
    ));
    std::fs::remove_file(&obj).expect("scratch file");
    std::fs::remove_file(&tri).expect("scratch file");
    std::fs::remove_file(&pane).expect("scratch file");
    los_cases_agree(&cases);
}

/// Assert that each line-of-sight scene of `cases` (name, scene, mono) takes the lanes and that
/// their renders agree with the scalar tracer's ([`agrees_with_the_scalar_tracer`]).
fn los_cases_agree(cases: &[(&str, Scene, bool)]) {
    for (name, scene, mono) in cases {
        assert!(
            PathPacket::new(scene, los(scene), *mono).is_some() || !nlos_rs::simd::available(),
            "{name}: not lockstep"
        );
        agrees_with_the_scalar_tracer(name, scene, *mono);
    }
}

/// Assert that lockstep renders of `scene` agree with the scalar tracer's (16 seeds of 1,024
/// samples each; every pixel and channel and the time profile) and are bit-identical at 1, 2 and 3 threads.
fn agrees_with_the_scalar_tracer(name: &str, scene: &Scene, mono: bool) {
    let lockstep: Vec<_> = (0..16)
        .map(|s| features(&run(scene, mono, 1024, s, false, 2)))
        .collect();
    let scalar: Vec<_> = (100..116)
        .map(|s| features(&run(scene, mono, 1024, s, true, 2)))
        .collect();
    let n = agree(name, &lockstep, &scalar);
    println!("{name}: {n} features agree");
    let one = run(scene, mono, 64, 7, false, 1);
    for threads in [2, 3] {
        let other = run(scene, mono, 64, 7, false, threads);
        assert_eq!(one.transient, other.transient, "{name}: {threads} threads");
        assert_eq!(one.steady, other.steady, "{name}: {threads} threads");
    }
}

/// mitransient's Cornell box (6×6 pixels) with the BSDFs of its small and large boxes replaced
/// by `small` and `large` (XML).
fn cbox_boxes(small: &str, large: &str) -> Scene {
    cbox_edited(small, large, |t| t)
}

/// [`cbox_boxes`], with `edit` applied to the text first.
fn cbox_edited(small: &str, large: &str, edit: impl Fn(String) -> String) -> Scene {
    cbox(6, |t| {
        let t = edit(t);
        let was =
            |name: &str| format!("value=\"meshes/cbox_{name}.obj\"/>\n        <ref id=\"gray\"/>");
        let now = |name: &str, bsdf: &str| format!("value=\"meshes/cbox_{name}.obj\"/>{bsdf}");
        assert!(t.contains(&was("smallbox")) && t.contains(&was("largebox")));
        t.replace(&was("smallbox"), &now("smallbox", small))
            .replace(&was("largebox"), &now("largebox", large))
    })
}

/// `text` with `count` dielectric BSDFs in it (a test's edit took).
fn glazed(text: String, count: usize) -> String {
    assert_eq!(text.matches("type=\"dielectric\"").count(), count);
    text
}

/// mitransient's NLOS file `file` (a perspective camera looks at the relay wall) on an 8×8 film
/// with hidden-geometry sampling off, with `edit` applied to its text.
fn nlos_file(file: &str, edit: impl Fn(String) -> String) -> Scene {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/mitransient/transient-nlos");
    let text = std::fs::read_to_string(dir.join(file)).expect("the file");
    let text = edit(
        text.replace(
            "name=\"nlos_hidden_geometry_sampling\" value=\"true\"",
            "name=\"nlos_hidden_geometry_sampling\" value=\"false\"",
        )
        .replace("name=\"width\" value=\"32\"", "name=\"width\" value=\"8\"")
        .replace(
            "name=\"height\" value=\"32\"",
            "name=\"height\" value=\"8\"",
        ),
    );
    let props = nlos_rs::xml::parse(&text, &dir.join(file), &HashMap::new()).expect("parses");
    Scene::from_props(&props, &dir).expect("valid scene")
}

/// `transient_nlos_path` in lockstep lanes agrees with the scalar tracer on mitransient's camera
/// files (the Z in a room, the Z alone) and on variants of them.
#[test]
fn nlos_lockstep_agrees_with_the_scalar_tracer() {
    let room_sphere = sphere_obj("room", 6, 10, [0.5, -0.5, 2.4], 0.3);
    let integrator = |extra: &'static str| {
        move |t: String| {
            t.replace(
                "<integrator type=\"transient_nlos_path\">",
                &format!("<integrator type=\"transient_nlos_path\">{extra}"),
            )
        }
    };
    let cases: Vec<(&str, Scene, bool)> = vec![
        (
            "nlos-z-room.xml, mono",
            nlos_file("nlos-z-room.xml", |t| t),
            true,
        ),
        (
            "nlos-z-simple.xml, depth 4, first and last bounces accounted for, rgb",
            nlos_file("nlos-z-simple.xml", |t| {
                integrator("<integer name=\"max_depth\" value=\"4\"/>")(t)
                    .replace(
                        "name=\"account_first_and_last_bounces\" value=\"False\"",
                        "name=\"account_first_and_last_bounces\" value=\"True\"",
                    )
                    // The two legs (about 2.8 m each) move the window on.
                    .replace(
                        "name=\"start_opl\" value=\"5.25\"",
                        "name=\"start_opl\" value=\"10.9\"",
                    )
            }),
            false,
        ),
        (
            "nlos-z-room.xml, two reflectances a side, direct paths discarded, roulette from depth 2, rgb",
            nlos_file("nlos-z-room.xml", |t| {
                integrator("<integer name=\"rr_depth\" value=\"2\"/>")(t)
                    .replace(
                        "<bsdf type=\"diffuse\" name=\"bsdf\"/>",
                        "<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.8, 0.6, 0.3\"/></bsdf>\
                         <bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.1, 0.3, 0.9\"/></bsdf>",
                    )
                    .replace(
                        "name=\"discard_direct_paths\" value=\"False\"",
                        "name=\"discard_direct_paths\" value=\"True\"",
                    )
            }),
            false,
        ),
        (
            "nlos-z-room.xml, the Z in glass, mono",
            nlos_file("nlos-z-room.xml", |t| {
                glazed(t.replace(
                    "value=\"meshes/hidden_geometry_Z.ply\"/>\n\t\t<ref id=\"default-bsdf\" name=\"bsdf\"/>",
                    "value=\"meshes/hidden_geometry_Z.ply\"/><bsdf type=\"dielectric\"/>",
                ), 1)
            }),
            true,
        ),
        (
            "nlos-z-room.xml, the Z in rough plastic (a general BSDF), rgb",
            nlos_file("nlos-z-room.xml", |t| {
                t.replace(
                    "value=\"meshes/hidden_geometry_Z.ply\"/>\n\t\t<ref id=\"default-bsdf\" name=\"bsdf\"/>",
                    "value=\"meshes/hidden_geometry_Z.ply\"/><bsdf type=\"roughplastic\">\
                     <float name=\"alpha\" value=\"0.2\"/></bsdf>",
                )
            }),
            false,
        ),
        (
            "nlos-z-room.xml with a curved sphere of 100 triangles beside the Z (packet and tree), rgb",
            nlos_file("nlos-z-room.xml", |t| {
                t.replace(
                    "</scene>",
                    &format!(
                        "<shape type=\"obj\"><string name=\"filename\" value=\"{}\"/></shape>\n</scene>",
                        room_sphere.display()
                    ),
                )
            }),
            false,
        ),
        (
            "nlos-z-room.xml with an analytic sphere beside the Z (in lanes), mono",
            nlos_file("nlos-z-room.xml", |t| {
                t.replace(
                    "</scene>",
                    "<shape type=\"sphere\"><point name=\"center\" x=\"0.5\" y=\"-0.5\" \
                     z=\"2.4\"/><float name=\"radius\" value=\"0.3\"/></shape>\n</scene>",
                )
            }),
            true,
        ),
        (
            "nlos-z-room.xml, one-sided, filter_bounces 3, mono",
            nlos_file("nlos-z-room.xml", |t| {
                integrator("<integer name=\"filter_bounces\" value=\"3\"/>")(t).replace(
                    "<ref id=\"default-bsdf\" name=\"bsdf\"/>",
                    "<bsdf type=\"diffuse\"><float name=\"reflectance\" value=\"0.7\"/></bsdf>",
                )
            }),
            true,
        ),
    ];
    std::fs::remove_file(&room_sphere).expect("scratch file");
    nlos_lanes_agree(&cases);
}

/// Each NLOS case (name, scene, mono) is rendered in lanes (where the CPU has them) and agrees
/// with the scalar tracer ([`agrees_with_the_scalar_tracer`]).
fn nlos_lanes_agree(cases: &[(&str, Scene, bool)]) {
    for (name, scene, mono) in cases {
        let Setup::Nlos(nlos) = &scene.setup else {
            panic!("{name}: an NLOS scene")
        };
        let capture = Capture::new(scene, *mono, &AtomicBool::new(false)).expect("capture");
        assert!(
            PathPacket::nlos(scene, nlos, &capture, *mono).is_some() || !nlos_rs::simd::available(),
            "{name}: not lockstep"
        );
        agrees_with_the_scalar_tracer(name, scene, *mono);
    }
}

/// tal's capture `file` (tests/data/tal021: relay-wall scan points, a Z 1 m behind) with
/// hidden-geometry sampling off, with `edit` applied to its text.
fn tal_file(file: &str, edit: impl Fn(String) -> String) -> Scene {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/tal021");
    let text = std::fs::read_to_string(dir.join(file)).expect("the file");
    let off = "name=\"nlos_hidden_geometry_sampling\" value=\"false\"";
    let text = edit(text.replace("name=\"nlos_hidden_geometry_sampling\" value=\"true\"", off));
    assert!(text.contains(off));
    let props = nlos_rs::xml::parse(&text, &dir.join(file), &HashMap::new()).expect("parses");
    Scene::from_props(&props, &dir).expect("valid scene")
}

/// `transient_nlos_path` in lockstep lanes agrees with the scalar tracer on captures of
/// relay-wall scan points, whose first vertex is the scan point itself (no camera ray): tal's
/// confocal capture (each pixel its own laser spot) and its single capture with the laser aimed
/// at the wall's centre, at unbounded depth and with `filter_bounces`, first and last bounces
/// accounted for.
#[test]
fn scan_point_lockstep_agrees_with_the_scalar_tracer() {
    let mut single = tal_file("single.xml", |t| t);
    single.focus_laser_at(Vec3A::ZERO).expect("aimed");
    let cases: Vec<(&str, Scene, bool)> = vec![
        (
            "tal's confocal.xml, mono",
            tal_file("confocal.xml", |t| t),
            true,
        ),
        (
            "tal's confocal.xml, filter_bounces 4, first and last bounces accounted for, rgb",
            tal_file("confocal.xml", |t| {
                t.replace(
                    "name=\"filter_bounces\" value=\"-1\"",
                    "name=\"filter_bounces\" value=\"4\"",
                )
                .replace(
                    "name=\"account_first_and_last_bounces\" value=\"false\"",
                    "name=\"account_first_and_last_bounces\" value=\"true\"",
                )
            }),
            false,
        ),
        (
            "tal's single.xml, aimed at the wall's centre, mono",
            single,
            true,
        ),
    ];
    nlos_lanes_agree(&cases);
}
