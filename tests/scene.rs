//! Scene building, hidden-geometry sampling against its density, and render invariants.

use glam::{DMat4, DVec3, Vec2, Vec3A};
use nlos_rs::props::{Props, Value};
use nlos_rs::render::{Monitor, RenderOptions, render};
use nlos_rs::sampling::Sampler;
use nlos_rs::scene::AreaSampler;
use nlos_rs::{NlosError, Scene};
use std::path::Path;

fn obj(plugin: &str, entries: Vec<(&str, Value)>) -> Value {
    let mut p = Props::new(plugin, None);
    for (k, v) in entries {
        p.insert(k, v).expect("distinct keys");
    }
    Value::Object(p)
}

/// Relay wall (2×2 m at z = 0), two hidden rectangles facing it (areas 0.16 and 0.64 m²).
fn scene_props(extra_integrator: Vec<(&str, Value)>, film_extra: Vec<(&str, Value)>) -> Props {
    let rect = |c: [f64; 3], half: f64| {
        let m = DMat4::from_translation(DVec3::from(c))
            * DMat4::from_rotation_x(std::f64::consts::PI)
            * DMat4::from_scale(DVec3::splat(half));
        obj("rectangle", vec![("to_world", Value::Matrix(m))])
    };
    let mut film = vec![
        ("width", Value::Int(4)),
        ("height", Value::Int(4)),
        ("temporal_bins", Value::Int(400)),
        ("bin_width_opl", Value::Float(0.01)),
        ("start_opl", Value::Float(1.0)),
        ("rfilter", obj("box", vec![])),
    ];
    film.retain(|(k, _)| !film_extra.iter().any(|(e, _)| e == k));
    film.extend(film_extra);
    let meter = obj(
        "nlos_capture_meter",
        vec![
            ("sensor_origin", Value::Vec3([-0.5, 0.0, 0.25])),
            (
                "sampler",
                obj("independent", vec![("sample_count", Value::Int(300))]),
            ),
            ("film", obj("transient_hdr_film", film)),
        ],
    );
    let mut integ = vec![
        ("nlos_laser_sampling", Value::Bool(true)),
        ("nlos_hidden_geometry_sampling", Value::Bool(true)),
        ("max_depth", Value::Int(-1)),
    ];
    integ.retain(|(k, _)| !extra_integrator.iter().any(|(e, _)| e == k));
    integ.extend(extra_integrator);
    let laser =
        nlos_rs::math::look_at([-0.5, 0.0, 0.25], [0.0; 3], [0.0, 1.0, 0.0]).expect("valid");
    let mut root = Props::new("scene", None);
    root.insert("integrator", obj("transient_nlos_path", integ))
        .unwrap();
    root.insert("small", rect([0.3, 0.2, 0.8], 0.2)).unwrap();
    root.insert("big", rect([-0.2, -0.1, 1.2], 0.4)).unwrap();
    root.insert(
        "laser",
        obj(
            "projector",
            vec![
                ("fov", Value::Float(0.2)),
                ("to_world", Value::Matrix(laser)),
            ],
        ),
    )
    .unwrap();
    root.insert("wall", obj("rectangle", vec![("nlos_sensor", meter)]))
        .unwrap();
    root
}

fn load(p: &Props) -> Scene {
    Scene::from_props(p, Path::new(".")).expect("valid scene")
}

/// Each scan point's total (steady value), per seed of `seeds`, at `spp`.
fn totals(scene: &Scene, spp: u64, seeds: std::ops::Range<u64>) -> Vec<Vec<f64>> {
    seeds
        .map(|seed| {
            let opts = RenderOptions {
                spp: Some(spp),
                seed,
                ..Default::default()
            };
            let r = render(scene, &opts, &Monitor::default()).expect("render");
            r.steady.iter().map(|&v| v as f64).collect()
        })
        .collect()
}

/// Assert that two estimators' totals (per seed, per scan point) agree at every scan point (Welch
/// t, |t| < 4.5, and a positive mean); return the sums over scan points of each mean's variance.
fn agree(a: &[Vec<f64>], b: &[Vec<f64>]) -> (f64, f64) {
    let mean_and_variance = |x: &[Vec<f64>], p: usize| {
        let n = x.len() as f64;
        let m = x.iter().map(|r| r[p]).sum::<f64>() / n;
        let v = x.iter().map(|r| (r[p] - m).powi(2)).sum::<f64>() / (n - 1.0);
        (m, v / n)
    };
    let (mut var_a, mut var_b) = (0.0, 0.0);
    for p in 0..a[0].len() {
        let ((ma, va), (mb, vb)) = (mean_and_variance(a, p), mean_and_variance(b, p));
        let t = (ma - mb) / (va + vb).sqrt();
        assert!(
            ma > 0.0 && t.abs() < 4.5,
            "pixel {p}: {ma} vs {mb}, t = {t}"
        );
        (var_a, var_b) = (var_a + va, var_b + vb);
    }
    (var_a, var_b)
}

#[test]
fn hidden_geometry_sampling_is_uniform_by_area() {
    let scene = load(&scene_props(vec![], vec![]));
    let wall = scene.nlos().expect("an NLOS scene").relay_wall;
    let hg = AreaSampler::new(&scene, |s| Some(s) != wall).expect("hidden geometry");
    assert!(
        (hg.total_area() - 0.8).abs() < 1e-5,
        "area {}",
        hg.total_area()
    );
    let (n, res) = (400_000usize, 8usize);
    let mut counts = vec![0.0f64; 2 * res * res];
    let mut rng = Sampler::new(0, 0, 0);
    for _ in 0..n {
        let it = hg.sample(&scene, &mut rng);
        let (k, c, half) = if it.p.z < 1.0 {
            (0, [0.3, 0.2], 0.2)
        } else {
            (1, [-0.2, -0.1], 0.4)
        };
        let u = ((it.p.x - c[0]) / (2.0 * half) + 0.5).clamp(0.0, 0.999);
        let v = ((it.p.y - c[1]) / (2.0 * half) + 0.5).clamp(0.0, 0.999);
        assert!((it.ns.z + 1.0).abs() < 1e-5, "normal faces the wall");
        counts[k * res * res + (v * res as f32) as usize * res + (u * res as f32) as usize] += 1.0;
    }
    // Expected: area fraction of each shape, spread uniformly over its cells.
    let exp: Vec<f64> = (0..2 * res * res)
        .map(|i| if i < res * res { 0.2 } else { 0.8 } * n as f64 / (res * res) as f64)
        .collect();
    let chi2: f64 = counts
        .iter()
        .zip(&exp)
        .map(|(o, e)| (o - e) * (o - e) / e)
        .sum();
    let k = (2 * res * res - 1) as f64;
    let z = ((chi2 / k).powf(1.0 / 3.0) - (1.0 - 2.0 / (9.0 * k))) / (2.0 / (9.0 * k)).sqrt();
    assert!(z < 3.1, "chi-square z = {z}");
}

#[test]
fn unknown_keys_are_rejected_with_plugin_and_key() {
    let p = scene_props(vec![("max_dpeth", Value::Int(3))], vec![]);
    match Scene::from_props(&p, Path::new(".")) {
        Err(NlosError::Property { plugin, key, .. }) => assert_eq!(
            (plugin.as_str(), key.as_str()),
            ("transient_nlos_path", "max_dpeth")
        ),
        other => panic!("expected a property error, got {:?}", other.err()),
    }
    let p = scene_props(vec![], vec![("temporal_bins", Value::Float(3.0))]);
    let e = Scene::from_props(&p, Path::new("."))
        .err()
        .expect("type error")
        .to_string();
    assert!(
        e.contains("transient_hdr_film") && e.contains("temporal_bins"),
        "{e}"
    );
}

#[test]
fn bit_identical_whatever_the_thread_count() {
    // 4×4 and 1×1 films split each pixel's blocks into chunks (render::chunks_per_pixel); the
    // sum must not depend on which thread rendered which chunk. A 40×40 film's pixels go to the
    // threads in groups of decreasing size (render::guided_groups), whichever thread is free.
    for side in [40, 4, 1] {
        let size = vec![("width", Value::Int(side)), ("height", Value::Int(side))];
        let scene = load(&scene_props(vec![], size));
        let run = |threads| {
            render(
                &scene,
                &RenderOptions {
                    spp: Some(if side > 4 { 512 } else { 2000 }),
                    seed: 3,
                    threads: Some(threads),
                    ..Default::default()
                },
                &Monitor::default(),
            )
            .expect("render")
        };
        let a = run(1);
        for threads in [2, 3] {
            let b = run(threads);
            assert_eq!(a.transient, b.transient, "{side}x{side}, {threads} threads");
            assert_eq!(a.steady, b.steady);
        }
        assert!(a.transient.iter().any(|&v| v > 0.0));
    }
}

#[test]
fn per_scan_point_preparation_is_the_same_in_a_pool_and_outside() {
    // A render prepares its scan points and laser spots on its own pool's threads
    // (`parallel::map_indices`); called outside a pool (the binding's `scan_points`) the same
    // work runs on the caller's thread. Both give the same points, in order.
    let scene = load(&scene_props(
        vec![("capture_type", Value::Str("confocal".into()))],
        vec![("width", Value::Int(40)), ("height", Value::Int(30))],
    ));
    let alone = nlos_rs::capture::scan_points(&scene).expect("scan points");
    let pool = nlos_rs::parallel::pool(Some(3)).expect("pool");
    let shared = pool.install(|| nlos_rs::capture::scan_points(&scene).expect("scan points"));
    assert_eq!(alone.len(), 1200);
    assert!(alone.iter().any(Option::is_some));
    let key = |p: &[Option<nlos_rs::geometry::Interaction>]| {
        p.iter()
            .map(|x| x.map(|x| (x.p.to_array().map(f32::to_bits), x.shape)))
            .collect::<Vec<_>>()
    };
    assert_eq!(key(&alone), key(&shared));
    let spots = |p: &[Option<nlos_rs::geometry::Interaction>]| {
        nlos_rs::capture::laser_spots(&scene, p, true, &Default::default())
            .expect("spots")
            .iter()
            .map(|s| {
                (
                    s.it.p.to_array().map(f32::to_bits),
                    s.incident.to_array().map(f32::to_bits),
                )
            })
            .collect::<Vec<_>>()
    };
    assert_eq!(spots(&alone), pool.install(|| spots(&alone)));
}

#[test]
fn preparation_kept_with_the_scene_changes_nothing() {
    // A render of every pixel keeps what it prepares (scan points, laser spots, cones) with the
    // scene, per variant, for the renders after it (`scene::Prepared`). Those renders equal a
    // fresh scene's; a cancelled render keeps nothing; a copy of the scene with a setting changed
    // prepares its own.
    let props_with = |first_leg: bool| {
        scene_props(
            vec![
                ("nlos_hidden_geometry_sampling", Value::Bool(false)),
                ("account_first_and_last_bounces", Value::Bool(first_leg)),
            ],
            vec![("width", Value::Int(12)), ("height", Value::Int(10))],
        )
    };
    let props = props_with(false);
    let run = |scene: &Scene, mono: bool, cancel: bool| {
        let m = Monitor::default();
        m.cancel.store(cancel, std::sync::atomic::Ordering::Relaxed);
        let opts = RenderOptions {
            spp: Some(64),
            seed: 7,
            threads: Some(2),
            mono,
            ..Default::default()
        };
        render(scene, &opts, &m).map(|r| (r.transient, r.steady))
    };
    let scene = load(&props);
    assert!(matches!(
        run(&scene, true, true),
        Err(NlosError::Interrupted)
    ));
    let first = run(&scene, true, false).expect("render");
    let rgb = run(&scene, false, false).expect("render");
    assert!(first.0.iter().any(|&v| v > 0.0));
    assert_eq!(run(&scene, true, false).expect("render"), first);
    assert_eq!(run(&scene, false, false).expect("render"), rgb);
    assert_eq!(run(&load(&props), true, false).expect("render"), first);
    // The first leg counted: every scan point's path starts farther along in time.
    let mut changed = scene.clone();
    let nlos_rs::scene::Setup::Nlos(n) = &mut changed.setup else {
        panic!("an NLOS scene")
    };
    n.settings.account_first_and_last_bounces = true;
    let fresh = run(&load(&props_with(true)), true, false).expect("render");
    assert_ne!(fresh, first);
    assert_eq!(run(&changed, true, false).expect("render"), fresh);
    // The laser aimed elsewhere, in place: its spot moves.
    let target = Vec3A::new(0.1, 0.05, 0.0);
    let mut aimed = load(&props);
    aimed.focus_laser_at(target).expect("aim");
    let fresh = run(&aimed, true, false).expect("render");
    assert_ne!(fresh, first);
    let mut scene = scene;
    scene.focus_laser_at(target).expect("aim");
    assert_eq!(run(&scene, true, false).expect("render"), fresh);
}

#[test]
fn steady_is_the_time_integral_when_the_window_holds_everything() {
    let scene = load(&scene_props(vec![], vec![]));
    let r = render(
        &scene,
        &RenderOptions {
            spp: Some(500),
            seed: 0,
            threads: None,
            mono: false,
            ..Default::default()
        },
        &Monitor::default(),
    )
    .expect("render");
    assert_eq!(r.transient_shape, vec![4, 4, 400, 3]);
    for px in 0..16 {
        for c in 0..3 {
            let sum: f64 = (0..400)
                .map(|t| r.transient[(px * 400 + t) * 3 + c] as f64)
                .sum();
            let st = r.steady[px * 3 + c] as f64;
            assert!(
                (sum - st).abs() <= 1e-4 * st.max(1e-12),
                "pixel {px}: {sum} vs {st}"
            );
        }
    }
}

#[test]
fn cancellation_stops_the_render() {
    let scene = load(&scene_props(vec![], vec![]));
    let m = Monitor::default();
    m.cancel.store(true, std::sync::atomic::Ordering::Relaxed);
    let r = render(
        &scene,
        &RenderOptions {
            spp: Some(100_000),
            seed: 0,
            threads: None,
            ..Default::default()
        },
        &m,
    );
    assert!(matches!(r, Err(NlosError::Interrupted)));
}

#[test]
fn exhaustive_layout_and_uv() {
    let p = scene_props(
        vec![("capture_type", Value::Str("exhaustive".into()))],
        vec![
            ("exhaustive_scan", Value::Bool(true)),
            ("laser_scan_width", Value::Int(4)),
            ("laser_scan_height", Value::Int(4)),
        ],
    );
    let scene = load(&p);
    let r = render(
        &scene,
        &RenderOptions {
            spp: Some(64),
            seed: 0,
            threads: None,
            ..Default::default()
        },
        &Monitor::default(),
    )
    .expect("render");
    assert_eq!(r.transient_shape, vec![4, 4, 4, 4, 400, 1]);
    assert_eq!(r.steady_shape, vec![4, 4, 1]);
    // Pixel (x, y) scans local (2(x+½)/W − 1, 2(y+½)/H − 1, 0): pixel (3, 0) is at (+0.75, −0.75).
    let (p, n) = scene
        .relay_wall_point(Vec2::new(3.5 / 4.0, 0.5 / 4.0))
        .expect("relay wall");
    assert!((p.x - 0.75).abs() < 1e-6 && (p.y + 0.75).abs() < 1e-6 && (n.z - 1.0).abs() < 1e-6);
}

#[test]
fn camera_rays_follow_mitsubas_convention() {
    use nlos_rs::sensor::Camera;
    let mut cam = Props::new("perspective", None);
    let look = nlos_rs::math::look_at([0.0, 0.0, 3.9], [0.0; 3], [0.0, 1.0, 0.0]).expect("valid");
    cam.insert("fov", Value::Float(90.0)).unwrap();
    cam.insert("near_clip", Value::Float(0.5)).unwrap();
    cam.insert("to_world", Value::Matrix(look)).unwrap();
    let film = obj(
        "transient_hdr_film",
        vec![
            ("width", Value::Int(4)),
            ("height", Value::Int(2)),
            ("rfilter", obj("box", vec![])),
        ],
    );
    cam.insert("film", film).unwrap();
    let (camera, meter) = Camera::from_props(&cam).expect("camera");
    assert_eq!((meter.film.width, meter.film.height), (4, 2));
    // Centre of the film: straight down the optical axis (world -z).
    let nlos_rs::geometry::Ray { o, d, tmin, .. } = camera.ray(Vec2::new(0.5, 0.5));
    assert!((o.z - 3.9).abs() < 1e-6 && (d.z + 1.0).abs() < 1e-6 && (tmin - 0.5).abs() < 1e-6);
    // uv (0, 0) is the top-left corner: camera +x is world -x here ("left"), +y is up; fov 90° on x
    // gives tan 1 across x and 1/aspect = 0.5 across y.
    let nlos_rs::geometry::Ray { d, tmin, .. } = camera.ray(Vec2::new(0.0, 0.0));
    let expect = glam::Vec3A::new(-1.0, 0.5, -1.0).normalize();
    assert!((d - expect).length() < 1e-6, "{d:?}");
    assert!((tmin - 0.5 / expect.z.abs()).abs() < 1e-5);
}

#[test]
fn sample_reuse_agrees_with_one_path_per_scan_point() {
    // The same scene with a light subpath shared by every scan point and with one path per scan
    // point: each scan point's total agrees across 12 seeds (Welch t per point, |t| < 4.5).
    let shared = load(&scene_props(vec![], vec![]));
    let per_point = load(&scene_props(
        vec![("nlos_sample_reuse", Value::Bool(false))],
        vec![],
    ));
    assert!(nlos_rs::integrator::shares_samples(&shared));
    assert!(!nlos_rs::integrator::shares_samples(&per_point));
    let (a, b) = (
        totals(&shared, 4096, 0..12),
        totals(&per_point, 4096, 100..112),
    );
    agree(&a, &b);
}

#[test]
fn sample_reuse_takes_delta_surfaces_that_no_path_leaves() {
    // A smooth plastic rectangle (a delta coating) before the others, facing the relay wall: no
    // hidden geometry lies in front of it, so no path goes on from it and the render shares light
    // subpaths; each scan point's total agrees with one path per scan point across 12 seeds.
    // Behind the others it would send paths on to them by its mirror reflection: no sharing.
    let with_plastic = |z: f64, extra: Vec<(&str, Value)>| {
        let mut p = scene_props(extra, vec![]);
        let m = DMat4::from_translation(DVec3::new(0.1, -0.2, z))
            * DMat4::from_rotation_x(std::f64::consts::PI)
            * DMat4::from_scale(DVec3::splat(0.15));
        p.insert(
            "plastic",
            obj(
                "rectangle",
                vec![
                    ("to_world", Value::Matrix(m)),
                    ("bsdf", obj("plastic", vec![])),
                ],
            ),
        )
        .unwrap();
        load(&p)
    };
    assert!(!nlos_rs::integrator::shares_samples(&with_plastic(
        1.6,
        vec![]
    )));
    let shared = with_plastic(0.5, vec![]);
    let per_point = with_plastic(0.5, vec![("nlos_sample_reuse", Value::Bool(false))]);
    assert!(nlos_rs::integrator::shares_samples(&shared));
    agree(
        &totals(&shared, 4096, 0..12),
        &totals(&per_point, 4096, 100..112),
    );
}

#[test]
fn sample_reuse_carries_hidden_glass() {
    // A glass cube before the two rectangles: light subpaths refract through it and each pixel
    // traces the paths whose vertex after its scan point lies on it; each scan point's total
    // agrees with one path per scan point across 12 seeds.
    let with_glass = |extra: Vec<(&str, Value)>| {
        let mut p = scene_props(extra, vec![]);
        let m = DMat4::from_translation(DVec3::new(0.1, 0.0, 0.6))
            * DMat4::from_scale(DVec3::splat(0.15));
        p.insert(
            "glass",
            obj(
                "cube",
                vec![
                    ("to_world", Value::Matrix(m)),
                    ("bsdf", obj("dielectric", vec![])),
                ],
            ),
        )
        .unwrap();
        load(&p)
    };
    let shared = with_glass(vec![]);
    let per_point = with_glass(vec![("nlos_sample_reuse", Value::Bool(false))]);
    assert!(nlos_rs::integrator::shares_samples(&shared));
    agree(
        &totals(&shared, 4096, 0..12),
        &totals(&per_point, 4096, 100..112),
    );
}

#[test]
fn hidden_geometry_sampling_sees_the_back_of_two_sided_surfaces() {
    // The scene plus a two-sided diffuse rectangle whose normal points away from the relay wall
    // (only its back is seen), direct light only: hidden-geometry sampling, with and without
    // sample reuse, agrees per scan point with BSDF sampling, which has no facing test.
    let with_back = |integrator: Vec<(&str, Value)>| {
        let mut p = scene_props(integrator, vec![]);
        p.insert(
            "back",
            obj(
                "rectangle",
                vec![
                    (
                        "to_world",
                        Value::Matrix(
                            DMat4::from_translation(DVec3::new(0.1, 0.3, 1.0))
                                * DMat4::from_scale(DVec3::splat(0.3)),
                        ),
                    ),
                    (
                        "bsdf",
                        obj("twosided", vec![("bsdf", obj("diffuse", vec![]))]),
                    ),
                ],
            ),
        )
        .unwrap();
        load(&p)
    };
    let direct = || ("filter_bounces", Value::Int(2));
    let bsdf = totals(
        &with_back(vec![
            direct(),
            ("nlos_hidden_geometry_sampling", Value::Bool(false)),
        ]),
        16384,
        100..116,
    );
    for reuse in [true, false] {
        let hgs = with_back(vec![direct(), ("nlos_sample_reuse", Value::Bool(reuse))]);
        agree(&totals(&hgs, 2048, 0..16), &bsdf);
    }
}

#[test]
fn hidden_vertices_mix_hidden_geometry_and_bsdf_sampling_without_bias() {
    // Three two-sided rectangles crossing at one point (a "star", light exchanged across their
    // intersection lines), two hidden vertices only (filter_bounces=3), the relay wall among the
    // sampled geometry: the one-sample mixture of hidden-geometry and BSDF sampling at hidden
    // vertices, with and without sample reuse, agrees per scan point with BSDF sampling alone.
    let star = |integrator: Vec<(&str, Value)>| {
        let mut p = scene_props(integrator, vec![]);
        let twosided = || obj("twosided", vec![("bsdf", obj("diffuse", vec![]))]);
        let centre = DMat4::from_translation(DVec3::new(0.0, 0.0, 1.0));
        for (name, turn) in [
            (
                "star_x",
                DMat4::from_rotation_y(std::f64::consts::FRAC_PI_2),
            ),
            (
                "star_y",
                DMat4::from_rotation_x(std::f64::consts::FRAC_PI_2),
            ),
            ("star_z", DMat4::IDENTITY),
        ] {
            let m = centre * turn * DMat4::from_scale(DVec3::splat(0.3));
            let shape = obj(
                "rectangle",
                vec![("to_world", Value::Matrix(m)), ("bsdf", twosided())],
            );
            p.insert(name, shape).unwrap();
        }
        load(&p)
    };
    let setting = |hgs: bool| {
        vec![
            ("filter_bounces", Value::Int(3)),
            (
                "nlos_hidden_geometry_sampling_includes_relay_wall",
                Value::Bool(true),
            ),
            ("nlos_hidden_geometry_sampling", Value::Bool(hgs)),
        ]
    };
    let bsdf = totals(&star(setting(false)), 16384, 100..116);
    for reuse in [true, false] {
        let mut s = setting(true);
        s.push(("nlos_sample_reuse", Value::Bool(reuse)));
        agree(&totals(&star(s), 4096, 0..16), &bsdf);
    }
}

#[test]
fn vertices_with_a_delta_part_keep_only_hidden_hits() {
    // With hidden-geometry sampling on, every vertex after the first lies on the hidden geometry.
    // Where a BSDF has a delta part the BSDF draws the next direction, and a ray that meets the
    // relay wall ends the path there, as a hidden-geometry draw would never reach it. A blend of
    // diffuse 0.9 and a black mirror (weight 0.2) is diffuse 0.72 with a delta part: a panel of
    // it agrees per scan point with a panel of diffuse 0.72, whose next vertices the mixture
    // draws. (Keeping the relay wall's hits, as before, rendered the blend 4% brighter at a
    // scan point, t = 6.1.)
    let with_panel = |bsdf: Value| {
        let mut p = scene_props(vec![], vec![]);
        let m = DMat4::from_translation(DVec3::new(0.0, -0.3, 0.6))
            * DMat4::from_rotation_x(std::f64::consts::PI)
            * DMat4::from_scale(DVec3::splat(0.3));
        p.insert(
            "panel",
            obj(
                "rectangle",
                vec![("to_world", Value::Matrix(m)), ("bsdf", bsdf)],
            ),
        )
        .unwrap();
        load(&p)
    };
    let blend = obj(
        "blendbsdf",
        vec![
            ("weight", Value::Float(0.2)),
            (
                "a",
                obj("diffuse", vec![("reflectance", Value::Float(0.9))]),
            ),
            (
                "b",
                obj(
                    "conductor",
                    vec![("specular_reflectance", Value::Float(0.0))],
                ),
            ),
        ],
    );
    let diffuse = obj("diffuse", vec![("reflectance", Value::Float(0.72))]);
    agree(
        &totals(&with_panel(blend), 4096, 0..16),
        &totals(&with_panel(diffuse), 4096, 100..116),
    );
}

#[test]
fn a_shared_render_in_parts_equals_the_whole() {
    use nlos_rs::render::{Plan, assemble, render_part};
    let scene = load(&scene_props(vec![], vec![]));
    let opts = RenderOptions {
        spp: Some(1500),
        seed: 5,
        ..Default::default()
    };
    let whole = render(&scene, &opts, &Monitor::default()).expect("render");
    let plan = Plan::new(&scene, &opts).expect("plan");
    assert!(plan.shared && plan.chunks > 1);
    let mut parts = Vec::new();
    for pixels in [0..3, 3..4, 4..16] {
        for chunks in [0..1, 1..plan.chunks] {
            let part = render_part(&scene, &opts, pixels.clone(), chunks, &Monitor::default());
            parts.push(part.expect("part"));
        }
    }
    let a = assemble(&plan, &parts).expect("assemble");
    assert_eq!(a.transient, whole.transient);
    assert_eq!(a.steady, whole.steady);
}

#[test]
fn black_shapes_are_left_out_of_hidden_geometry_without_bias() {
    // The scene plus a black rectangle (a diffuse of reflectance zero) of 4 m² behind the others,
    // facing the relay wall, where it blocks no path that carries light: hidden-geometry
    // sampling leaves it out (its area is still the two rectangles' 0.8 m²), and each scan
    // point's total agrees with the scene without it across seeds (Welch t per point, |t| < 4.5),
    // whether the light subpaths are shared or traced per scan point.
    for reuse in [true, false] {
        let with_black = |black: bool| {
            let mut p = scene_props(vec![("nlos_sample_reuse", Value::Bool(reuse))], vec![]);
            if black {
                let m = DMat4::from_translation(DVec3::new(0.0, 0.0, 3.0))
                    * DMat4::from_rotation_x(std::f64::consts::PI);
                let bsdf = obj("diffuse", vec![("reflectance", Value::Float(0.0))]);
                p.insert(
                    "black",
                    obj(
                        "rectangle",
                        vec![("to_world", Value::Matrix(m)), ("bsdf", bsdf)],
                    ),
                )
                .unwrap();
            }
            load(&p)
        };
        let black = with_black(true);
        let area = black
            .hidden_geometry(false)
            .expect("hidden geometry")
            .total_area();
        assert!((area - 0.8).abs() < 1e-5, "area {area}");
        agree(
            &totals(&black, 1024, 0..24),
            &totals(&with_black(false), 1024, 100..124),
        );
    }
}

#[test]
fn visibility_guide_agrees_and_spends_less_on_unlit_geometry() {
    // The scene plus a 4 m² rectangle behind the others, facing away from the relay wall (one-sided
    // diffuse, lit only from behind: a first hidden vertex there carries nothing). The guided first
    // vertex (default) and the uniform one agree per scan point across seeds, and the guide's
    // variance is lower: about 7.5 times (7.38 and 7.65 over 128 seeds each, on two random
    // streams; 32 seeds measured 4.93 on one and 2.88 on the other).
    let with_back = |guided: bool| {
        let mut p = scene_props(
            vec![("nlos_visibility_guiding", Value::Bool(guided))],
            vec![],
        );
        let m = DMat4::from_translation(DVec3::new(0.0, 0.0, 1.6)) * DMat4::from_scale(DVec3::ONE);
        p.insert(
            "back",
            obj("rectangle", vec![("to_world", Value::Matrix(m))]),
        )
        .unwrap();
        load(&p)
    };
    let (a, b) = (
        totals(&with_back(true), 1024, 0..128),
        totals(&with_back(false), 1024, 200..328),
    );
    let (var_a, var_b) = agree(&a, &b);
    println!(
        "variance of the mean, uniform / guided: {:.2}",
        var_b / var_a
    );
    assert!(
        var_b / var_a > 4.0,
        "uniform / guided variance {}",
        var_b / var_a
    );
}

/// Viewpoints on the relay wall of [`scene_props`], as the rays from in front of it find them:
/// 16 scan points within 0.9 m of its centre and 3 laser spots within 0.3 m.
fn wall_viewpoints(
    scene: &Scene,
    rng: &mut Sampler,
) -> (
    Vec<nlos_rs::geometry::Interaction>,
    Vec<nlos_rs::geometry::Interaction>,
) {
    let mut on_wall = |half: f32| {
        let (u, v) = (rng.next_1d() * 2.0 - 1.0, rng.next_1d() * 2.0 - 1.0);
        let o = Vec3A::new(u * half, v * half, 0.1);
        scene.intersect(o, -Vec3A::Z, 1.0).expect("the wall").1
    };
    let scan = (0..16).map(|_| on_wall(0.9)).collect();
    let spots = (0..3).map(|_| on_wall(0.3)).collect();
    (scan, spots)
}

/// A face proved hidden from the scan points (or the laser spots) by a blocker
/// (integrator/clear_view.rs) is: every shadow ray between a point of it and each of them, both
/// ways round, meets something. Scenes: the base scene, an occluder (a rectangle 1.2 to 3 m wide
/// at z = 1.5, tilted at random, or an L in its place), a rectangle through it (across its
/// plane), and rectangles and cubes behind it, in its shadow, partly out of it or beside it. Many
/// points are flagged.
#[test]
fn faces_behind_a_blocker_are_hidden_as_the_rays_say() {
    use nlos_rs::integrator::clear_view::ClearView;
    let mut rng = Sampler::new(7, 0, 0);
    let (mut flagged, mut checked) = (0u64, 0u64);
    // An L of three unit squares in z = 0, its vertices shared.
    let l_shape =
        std::env::temp_dir().join(format!("nlos_rs_l_occluder_{}.obj", std::process::id()));
    std::fs::write(
        &l_shape,
        "v -1 -1 0\nv 0 -1 0\nv 1 -1 0\nv -1 0 0\nv 0 0 0\nv 1 0 0\nv -1 1 0\nv 0 1 0\n\
         f 1 2 5\nf 1 5 4\nf 2 3 6\nf 2 6 5\nf 4 5 8\nf 4 8 7\n",
    )
    .expect("scratch file");
    for case in 0..40 {
        let mut p = scene_props(vec![], vec![]);
        let mut r = |lo: f64, hi: f64| lo + (hi - lo) * rng.next_1d() as f64;
        let occluder = DMat4::from_translation(DVec3::new(r(-0.3, 0.3), r(-0.3, 0.3), 1.5))
            * DMat4::from_rotation_x(std::f64::consts::PI + r(-0.3, 0.3))
            * DMat4::from_rotation_y(r(-0.3, 0.3))
            * DMat4::from_scale(DVec3::splat(r(0.6, 1.5)));
        // Every other case, an L in place of the rectangle (a notch where its +x, +y quarter
        // would be): planar but not convex, so no blocker.
        let shape = if case % 2 == 0 {
            obj("rectangle", vec![("to_world", Value::Matrix(occluder))])
        } else {
            obj(
                "obj",
                vec![
                    ("filename", Value::Str(l_shape.display().to_string())),
                    ("to_world", Value::Matrix(occluder)),
                ],
            )
        };
        p.insert("occluder", shape).unwrap();
        // A rectangle through the occluder, across its plane, clear of the base rectangles'
        // shadows: part of it is in plain view.
        let through = DMat4::from_translation(DVec3::new(r(0.5, 0.7), r(-0.7, -0.5), 1.5))
            * DMat4::from_rotation_y(std::f64::consts::FRAC_PI_2 + r(-0.3, 0.3))
            * DMat4::from_scale(DVec3::splat(r(0.05, 0.12)));
        p.insert(
            "through",
            obj("rectangle", vec![("to_world", Value::Matrix(through))]),
        )
        .unwrap();
        for k in 0..4 {
            let m = DMat4::from_translation(DVec3::new(r(-1.2, 1.2), r(-1.2, 1.2), r(1.8, 2.6)))
                * DMat4::from_rotation_x(r(0.0, 6.3))
                * DMat4::from_rotation_y(r(0.0, 6.3))
                * DMat4::from_scale(DVec3::splat(r(0.05, 0.3)));
            let plugin = ["rectangle", "cube"][(case + k) % 2];
            p.insert(
                format!("behind{k}"),
                obj(plugin, vec![("to_world", Value::Matrix(m))]),
            )
            .unwrap();
        }
        let scene = load(&p);
        let (scan, spots) = wall_viewpoints(&scene, &mut rng);
        let clear = ClearView::new(
            &scene,
            scan.iter(),
            spots.iter(),
            scene.hidden_geometry(false),
        );
        for i in 0..scene.prims.len() {
            for _ in 0..50 {
                let (y_p, ng, b) = scene.prims[i].sample_area(rng.next_2d());
                let y = scene.surface_point(i, y_p, ng, b);
                for (points, hidden) in [
                    (&scan, clear.hidden_from_scan_points(&y)),
                    (&spots, clear.hidden_from_spots(&y)),
                ] {
                    if hidden {
                        flagged += 1;
                        for w in points.iter() {
                            assert!(
                                !scene.visible_to(w, &y) && !scene.visible_to(&y, w),
                                "case {case} prim {i}: seen from {:?}",
                                w.p
                            );
                            checked += 1;
                        }
                    }
                }
            }
        }
    }
    std::fs::remove_file(&l_shape).expect("scratch file");
    println!("{flagged} points hidden, {checked} shadow rays checked");
    assert!(flagged > 10_000, "{flagged} points hidden");
}

/// A scan point's cone (integrator/scan_cone.rs) keeps every direction whose ray meets its
/// sphere: scan points on the plane z = 0 and spheres placed at random (above, across and below
/// that plane, near and far), cosine-weighted directions drawn as the diffuse BSDF draws them,
/// each from a point within the cone's reach of its scan point (half the cones reach as far as a
/// camera pixel's footprint), and each ray that meets the sphere (from the origin it is really
/// traced from) must pass both the square's test and the cone's. Most rays that miss must be
/// turned down.
#[test]
fn scan_cones_keep_every_ray_that_meets_their_sphere() {
    use nlos_rs::geometry::Interaction;
    use nlos_rs::integrator::scan_cone::ScanCone;
    use nlos_rs::math::Frame;
    use nlos_rs::sampling::square_to_cosine_hemisphere;
    let mut rng = Sampler::new(7, 0, 0);
    let (mut met, mut missed, mut turned_down, mut near_edge) = (0u64, 0u64, 0u64, 0u64);
    for case in 0..400 {
        let r = |rng: &mut Sampler, lo: f32, hi: f32| lo + (hi - lo) * rng.next_1d();
        let n = if case % 2 == 0 { Vec3A::Z } else { -Vec3A::Z };
        let p = Vec3A::new(r(&mut rng, -1.0, 1.0), r(&mut rng, -1.0, 1.0), 0.0);
        let x = Interaction {
            p,
            ng: n,
            ns: n,
            shape: 0,
            prim: 0,
        };
        let center = Vec3A::new(
            r(&mut rng, -2.0, 2.0),
            r(&mut rng, -2.0, 2.0),
            n.z * r(&mut rng, -0.5, 2.0),
        );
        let radius = r(&mut rng, 0.02, 1.0);
        let reach = if case % 4 < 2 {
            0.0
        } else {
            r(&mut rng, 0.0, 0.1)
        };
        let Some(cone) = ScanCone::new(&x, n, reach, (center, radius)) else {
            assert!(
                (center - p).length() <= radius * 1.01 + reach,
                "case {case}: no cone from outside"
            );
            continue;
        };
        assert!(cone.drawn_about(n) && !cone.drawn_about(-n));
        for _ in 0..2000 {
            // A first vertex within the reach, on the plane.
            let (a, b) = (
                std::f32::consts::TAU * rng.next_1d(),
                0.999 * reach * rng.next_1d().sqrt(),
            );
            let y = Interaction {
                p: p + Vec3A::new(b * a.cos(), b * a.sin(), 0.0),
                ..x
            };
            assert!(cone.holds_at(&y));
            let u = rng.next_2d();
            let wo = Frame::new(n).to_world(square_to_cosine_hemisphere(u));
            let o = y.offset_origin(wo);
            // The ray against the sphere: the least distance of its line from the centre.
            let oc = center - o;
            let along = oc.dot(wo);
            let gap = (oc - wo * along).length();
            let meets = along > 0.0 && gap <= radius || oc.length() <= radius;
            let kept = cone.may_reach_square(u) && cone.may_reach(wo);
            if meets {
                met += 1;
                near_edge += u64::from(gap > 0.98 * radius);
                assert!(
                    kept,
                    "case {case}: a ray meeting the sphere was turned down (u {u})"
                );
            } else {
                missed += 1;
                turned_down += u64::from(!kept);
            }
        }
    }
    let share = turned_down as f64 / missed as f64;
    println!("met {met} (near the edge {near_edge}), missed {missed}, turned down {share:.3}");
    assert!(
        near_edge > 1000,
        "too few rays near the cones' edges: {near_edge}"
    );
    assert!(
        share > 0.9,
        "the cones turn down only {share:.3} of the rays that miss"
    );
}

/// Over a whole scene (the relay wall and two hidden rectangles), every scan point gets a cone,
/// and each direction its cone turns down meets nothing when traced.
#[test]
fn scan_cones_turn_down_only_rays_that_meet_nothing() {
    use nlos_rs::capture::Capture;
    use nlos_rs::integrator::scan_cone::scan_cones;
    use nlos_rs::math::Frame;
    use nlos_rs::sampling::square_to_cosine_hemisphere;
    let scene = load(&scene_props(
        vec![("nlos_hidden_geometry_sampling", Value::Bool(false))],
        vec![],
    ));
    let capture =
        Capture::new(&scene, true, &std::sync::atomic::AtomicBool::new(false)).expect("capture");
    let points: Vec<_> = capture
        .scan_points
        .iter()
        .map(|it| it.map(|it| (it, (scene.meter.origin - it.p).normalize(), 0.0)))
        .collect();
    let cones = scan_cones(&scene, &scene.shape_bsdfs(true), &points, 0..points.len());
    let mut rng = Sampler::new(3, 0, 0);
    let (mut hits, mut turned_down, mut traced) = (0u64, 0u64, 0u64);
    for (point, cone) in points.iter().zip(&cones) {
        let ((x, _, _), cone) = (point.expect("on the wall"), cone.expect("a cone"));
        for _ in 0..20_000 {
            let u = rng.next_2d();
            let wo = Frame::new(x.ns).to_world(square_to_cosine_hemisphere(u));
            let hit = scene.intersect(x.offset_origin(wo), wo, f32::INFINITY);
            traced += 1;
            hits += u64::from(hit.is_some());
            if !(cone.may_reach_square(u) && cone.may_reach(wo)) {
                turned_down += 1;
                assert!(hit.is_none(), "a turned-down direction meets {hit:?}");
            }
        }
    }
    println!("traced {traced}, hits {hits}, turned down {turned_down}");
    assert!(hits > 0 && turned_down > traced / 2);
}

/// mitransient's `nlos-z-simple.xml` (a perspective camera looks at the relay wall) and its camera.
fn mitransient_camera_file() -> (Scene, nlos_rs::sensor::Camera) {
    camera_scene(&mitransient_nlos_file("nlos-z-simple.xml"))
}

/// The properties of one of mitransient's NLOS example files.
fn mitransient_nlos_file(name: &str) -> Props {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/mitransient/transient-nlos")
        .join(name);
    nlos_rs::xml::load(&path, &Default::default()).expect("mitransient's file")
}

/// The scene of one of mitransient's NLOS example files (their meshes beside them) and its camera.
fn camera_scene(props: &Props) -> (Scene, nlos_rs::sensor::Camera) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/mitransient/transient-nlos");
    let scene = Scene::from_props(props, &dir).expect("valid scene");
    let camera = scene
        .nlos()
        .expect("NLOS")
        .camera
        .clone()
        .expect("a camera");
    (scene, camera)
}

/// Every ray of a pixel counted as covered meets that pixel's sole shape — its corner, edge and
/// centre rays and random ones; the covered pixels, and the pixels with a sole shape that only
/// some of their rays meet.
fn check_covered_pixels(scene: &Scene, camera: &nlos_rs::sensor::Camera) -> (usize, usize) {
    use nlos_rs::integrator::scan_cone::pixel_footprints;
    use nlos_rs::sampling::ONE_MINUS_EPSILON;
    use std::sync::atomic::AtomicBool;
    let (w, h) = (scene.meter.film.width, scene.meter.film.height);
    let seen_by = pixel_footprints(scene, camera, &AtomicBool::new(false), 0..usize::MAX);
    let mut rng = Sampler::new(7, 0, 0);
    let edge = [0.0, 0.5, ONE_MINUS_EPSILON];
    let (mut covered, mut partly) = (0, 0);
    for pixel in 0..w * h {
        let jitters = edge
            .iter()
            .flat_map(|&x| edge.iter().map(move |&y| Vec2::new(x, y)))
            .chain((0..400).map(|_| rng.next_2d()));
        let meets: Vec<bool> = jitters
            .map(|j| {
                let r = camera.pixel_ray(pixel, w, h, j);
                scene
                    .accel
                    .intersect(r.o, r.d, r.tmin, r.tmax)
                    .is_some_and(|hit| {
                        seen_by.sole_shapes[pixel] == Some(scene.prim_shape[hit.prim as usize])
                    })
            })
            .collect();
        if seen_by.covered[pixel] {
            covered += 1;
            assert!(meets.iter().all(|&m| m), "pixel {pixel}");
        } else if meets.iter().any(|&m| m) && !meets.iter().all(|&m| m) {
            partly += 1;
        }
    }
    println!("covered {covered}, partly {partly} of {}", w * h);
    (covered, partly)
}

/// mitransient's camera file: the film holds covered pixels, and pixels only some of whose rays
/// meet the relay wall (past its edges).
#[test]
fn covered_camera_pixels_meet_their_wall_with_every_ray() {
    let (scene, camera) = mitransient_camera_file();
    // The relay wall (Plane.ply) is a flat sheet, the Z is not.
    assert!(scene.is_flat(0) && !scene.is_flat(1));
    let (covered, partly) = check_covered_pixels(&scene, &camera);
    let pixels = scene.meter.film.width * scene.meter.film.height;
    assert!(covered > pixels / 2 && partly > 0);
}

/// mitransient's room (the camera inside walls that surround it, so no sphere around the rest of
/// the scene leaves it outside): the pixels whose rays nothing else can meet on their way to the
/// relay wall are covered; with a small panel halfway between the camera and the wall, the pixels
/// whose rays may meet it are not.
#[test]
fn camera_pixels_in_a_room_meet_their_wall_with_every_ray() {
    let mut props = mitransient_nlos_file("nlos-z-room.xml");
    let (scene, camera) = camera_scene(&props);
    let pixels = scene.meter.film.width * scene.meter.film.height;
    let (covered, _) = check_covered_pixels(&scene, &camera);
    assert!(covered > pixels / 2);
    // The panel, 0.1 m wide, halfway along the central pixel's ray.
    let r = camera.pixel_ray(
        scene.meter.film.width * (scene.meter.film.height / 2) + scene.meter.film.width / 2,
        scene.meter.film.width,
        scene.meter.film.height,
        Vec2::splat(0.5),
    );
    let hit = scene
        .accel
        .intersect(r.o, r.d, r.tmin, r.tmax)
        .expect("the wall");
    let mid = r.o + r.d * (0.5 * hit.t);
    let m = DMat4::from_translation(DVec3::new(mid.x as f64, mid.y as f64, mid.z as f64))
        * DMat4::from_scale(DVec3::splat(0.05));
    props
        .insert(
            "panel",
            obj("rectangle", vec![("to_world", Value::Matrix(m))]),
        )
        .unwrap();
    let (scene, camera) = camera_scene(&props);
    let (behind_panel, _) = check_covered_pixels(&scene, &camera);
    assert!(behind_panel > pixels / 4 && behind_panel < covered);
}

/// mitransient's Cornell box file (line of sight): its walls are single quads shaded by vertex
/// normals, planar but not flat sheets. Pixels whose rays nothing but one wall can meet (no other
/// primitive in their pyramid) are found among them, and for every ray of such a pixel (corner,
/// edge and centre rays, and random ones) that wall's triangles alone give the hit the whole
/// scene gives, bit for bit ([`Scene::camera_hit`], which `transient_path` takes for such pixels).
#[test]
fn line_of_sight_pixels_with_a_sole_shape_meet_it_alone() {
    use nlos_rs::integrator::scan_cone::pixel_footprints;
    use nlos_rs::sampling::ONE_MINUS_EPSILON;
    use nlos_rs::scene::Setup;
    use std::sync::atomic::AtomicBool;
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/mitransient/cornell-box");
    let params = [("res".to_string(), "40".to_string())].into();
    let props = nlos_rs::xml::load(&dir.join("cbox_diffuse.xml"), &params).expect("the file");
    let scene = Scene::from_props(&props, &dir).expect("valid scene");
    let Setup::Los(los) = &scene.setup else {
        panic!("a line-of-sight scene")
    };
    let (w, h) = (scene.meter.film.width, scene.meter.film.height);
    let seen_by = pixel_footprints(&scene, &los.camera, &AtomicBool::new(false), 0..usize::MAX);
    let sole: Vec<_> = (0..w * h)
        .filter_map(|p| seen_by.sole_shapes[p].map(|s| (p, s)))
        .collect();
    println!("{} of {} pixels with a sole shape", sole.len(), w * h);
    assert!(sole.len() > w * h / 4);
    assert!(
        sole.iter()
            .all(|&(_, s)| scene.is_planar(s as usize) && !scene.is_flat(s as usize))
    );
    // Not flat sheets: no pixel's footprint cone may be judged before its camera ray.
    assert!(seen_by.covered.iter().all(|&c| !c));
    let mut rng = Sampler::new(11, 0, 0);
    let edge = [0.0, 0.5, ONE_MINUS_EPSILON];
    for &(pixel, shape) in &sole {
        let jitters = edge
            .iter()
            .flat_map(|&x| edge.iter().map(move |&y| Vec2::new(x, y)))
            .chain((0..100).map(|_| rng.next_2d()));
        for j in jitters {
            let r = los.camera.pixel_ray(pixel, w, h, j);
            let found = scene.accel.intersect(r.o, r.d, r.tmin, r.tmax);
            let alone = scene.camera_hit(&r, Some(shape));
            assert_eq!(
                alone.map(|h| (h.t, h.prim, h.b)),
                found.map(|h| (h.t, h.prim, h.b)),
                "pixel {pixel}"
            );
        }
    }
}

/// mitransient's camera file: every pixel that sees the relay wall gets a footprint cone, which
/// holds for the first vertices its jittered camera rays find, and each direction it turns down
/// meets nothing; where a pixel's rays can meet the wall alone, its triangles alone give the hit
/// the whole scene gives.
#[test]
fn camera_footprint_cones_turn_down_only_rays_that_meet_nothing() {
    use nlos_rs::geometry::bvh::intersect_brute;
    use nlos_rs::integrator::scan_cone::{pixel_footprints, scan_cones};
    use nlos_rs::math::Frame;
    use nlos_rs::sampling::square_to_cosine_hemisphere;
    use std::sync::atomic::AtomicBool;
    let (scene, camera) = mitransient_camera_file();
    let (w, h) = (scene.meter.film.width, scene.meter.film.height);
    let seen_by = pixel_footprints(&scene, &camera, &AtomicBool::new(false), 0..usize::MAX);
    let footprints = seen_by.points;
    let cones = scan_cones(
        &scene,
        &scene.shape_bsdfs(true),
        &footprints,
        0..footprints.len(),
    );
    // The camera sees past the wall's edges in some pixels: those have no footprint.
    let seen = footprints.iter().flatten().count();
    assert!(seen > w * h / 2 && cones.iter().flatten().count() == seen);
    let mut rng = Sampler::new(5, 0, 0);
    let (mut first, mut held, mut turned_down, mut hits) = (0u64, 0u64, 0u64, 0u64);
    let mut sole = 0;
    for (pixel, cone) in cones.iter().enumerate() {
        let Some(cone) = cone else { continue };
        for _ in 0..8 {
            let r = camera.pixel_ray(pixel, w, h, rng.next_2d());
            let found = scene.accel.intersect(r.o, r.d, r.tmin, r.tmax);
            // A pixel whose rays meet one shape only: its triangles alone give the same hit.
            if let Some(shape) = seen_by.sole_shapes[pixel] {
                let prims = scene.shapes[shape as usize].prims.clone();
                let alone = intersect_brute(&scene.prims[prims.clone()], r.o, r.d, r.tmin, r.tmax);
                let alone = alone.map(|h| (h.t, h.prim + prims.start as u32, h.b));
                assert_eq!(alone, found.map(|h| (h.t, h.prim, h.b)), "pixel {pixel}");
                sole += 1;
            }
            let Some(x) = found.map(|hit| scene.interaction(r.o, r.d, &hit)) else {
                continue;
            };
            first += 1;
            if !cone.holds_at(&x) {
                continue;
            }
            held += 1;
            for _ in 0..40 {
                let u = rng.next_2d();
                let wo = Frame::new(x.ns).to_world(square_to_cosine_hemisphere(u));
                let hit = scene.intersect(x.offset_origin(wo), wo, f32::INFINITY);
                hits += u64::from(hit.is_some());
                if cone.drawn_about(x.ns) && !(cone.may_reach_square(u) && cone.may_reach(wo)) {
                    turned_down += 1;
                    assert!(
                        hit.is_none(),
                        "pixel {pixel}: a turned-down direction meets {hit:?}"
                    );
                }
            }
        }
    }
    println!(
        "first vertices {first}, held {held}, hits {hits}, turned down {turned_down}, sole {sole}"
    );
    assert!(
        sole > first / 2,
        "{sole} of {first} camera rays in pixels that see one shape"
    );
    assert!(
        held == first && first > 0,
        "{held} of {first} first vertices within their footprint"
    );
    assert!(hits > 0 && turned_down > held * 40 / 2);
}

/// A hidden-geometry draw judged to face away from a point by its first uniform alone
/// (`AreaSampler::faces_away`, which lets a scan point's paths end before the point is made) faces
/// away wherever its second uniform puts it: the cosine at the drawn point towards the point, with
/// its shading normal, as `HiddenEdge` computes it, is below zero. Over random cubes and
/// rectangles, flipped or not, with flat shading or vertex normals tilted up to about 23°, some
/// two-sided (never judged: their back is drawn as well), seen
/// from random points, from balls about them (a camera pixel's footprint) and from points on the
/// surfaces; and the judgement is not idle: on flat triangles it turns down every draw from a point
/// whose cosine is below −0.01.
#[test]
fn draws_judged_to_face_away_do() {
    use nlos_rs::math::Frame;
    let mut rng = Sampler::new(11, 0, 0);
    let (mut judged, mut flat_away, mut flat_caught, mut tilted_judged) = (0u64, 0u64, 0u64, 0u64);
    let mut two_sided_away = 0u64;
    for case in 0..24 {
        let mut p = scene_props(vec![], vec![]);
        let mut r = |lo: f64, hi: f64| lo + (hi - lo) * rng.next_1d() as f64;
        for k in 0..1 + case % 3 {
            let m = DMat4::from_translation(DVec3::new(r(-1.0, 1.0), r(-1.0, 1.0), r(0.3, 2.0)))
                * DMat4::from_rotation_x(r(-3.0, 3.0))
                * DMat4::from_rotation_y(r(-3.0, 3.0))
                * DMat4::from_scale(DVec3::splat(r(0.05, 0.5)));
            let plugin = ["cube", "rectangle"][(case + k) % 2];
            let flip = Value::Bool((case / 2 + k) % 2 == 1);
            let mut entries = vec![("to_world", Value::Matrix(m)), ("flip_normals", flip)];
            // A third shape two-sided: draws onto it are never judged (both sides are drawn).
            if k == 2 {
                let twosided = obj("twosided", vec![("bsdf", obj("diffuse", vec![]))]);
                entries.push(("bsdf", twosided));
            }
            p.insert(format!("extra{k}"), obj(plugin, entries)).unwrap();
        }
        let mut scene = load(&p);
        let behind: Vec<bool> = scene
            .shape_bsdfs(true)
            .iter()
            .map(|b| b.scatters_behind())
            .collect();
        let two_sided = |shape: u32| behind[shape as usize];
        let tilted = case % 2 == 1;
        if tilted {
            for i in 0..scene.prims.len() {
                if let nlos_rs::geometry::Prim::Triangle { n, .. } = scene.prims[i] {
                    let f = Frame::new(n);
                    let mut tilt = || {
                        let (a, b) = (rng.next_1d() * 0.6 - 0.3, rng.next_1d() * 0.6 - 0.3);
                        (n + f.to_world(Vec3A::new(a, b, 0.0))).normalize()
                    };
                    scene.prim_normals[i] = Some([tilt(), tilt(), tilt()]);
                }
            }
        }
        let hg = AreaSampler::new(&scene, |_| true).expect("area");
        assert!(hg.judges_facing());
        for k in 0..100 {
            // Every other point on the surfaces themselves (a scan point on the relay wall, in
            // the plane of the wall's own triangles): where rounding alone decides.
            let q = if k % 2 == 0 {
                hg.sample(&scene, &mut rng).p
            } else {
                Vec3A::new(
                    rng.next_1d() * 4.0 - 2.0,
                    rng.next_1d() * 4.0 - 2.0,
                    rng.next_1d() * 4.0 - 1.0,
                )
            };
            // Every fourth point judged for a ball about it (a camera pixel's footprint), each
            // draw checked from a point in the ball.
            let radius = if k % 4 == 1 { 0.2 * rng.next_1d() } else { 0.0 };
            for _ in 0..100 {
                let mut ahead = rng.clone();
                let away = hg.faces_away(ahead.next_pair().0, q, radius);
                // The same pair draws the point.
                let y = hg.sample(&scene, &mut rng);
                let offset = Vec3A::new(rng.next_1d(), rng.next_1d(), rng.next_1d()) - 0.5;
                let seen_from = q + offset.normalize_or_zero() * radius * rng.next_1d().sqrt();
                let v = y.p - seen_from;
                let r = v.length_squared().sqrt();
                let cos_y = y.ns.dot(-(v / r));
                if away {
                    assert!(!two_sided(y.shape), "case {case}: a two-sided draw judged");
                    assert!(
                        cos_y < 0.0,
                        "case {case}: judged away at {seen_from} but cos {cos_y}"
                    );
                    judged += 1;
                    tilted_judged += u64::from(tilted);
                }
                if !tilted && radius == 0.0 && cos_y < -0.01 {
                    if two_sided(y.shape) {
                        two_sided_away += 1;
                    } else {
                        flat_away += 1;
                        flat_caught += u64::from(away);
                    }
                }
            }
        }
    }
    println!(
        "judged {judged} (tilted {tilted_judged}); flat away {flat_away}, caught {flat_caught}; \
         two-sided away {two_sided_away}"
    );
    assert!(judged > 50_000 && tilted_judged > 10_000);
    assert_eq!(flat_caught, flat_away);
    assert!(
        two_sided_away > 1000,
        "{two_sided_away} two-sided draws facing away"
    );
}

/// The clear views answer as the rays would: a triangle flagged as seen whole from the scan
/// points (or the laser spots) is unoccluded from each of them, both ways round, at random points
/// of it; a ray leaving a triangle on a side flagged open meets no hidden geometry, and the test
/// before the warp agrees with the one after. Scenes: the wall and two rectangles facing it, the
/// small one in front of part of the big one, plus random rectangles (facing the wall or tilted),
/// spheres, disks and cubes among them. The small rectangle is seen whole, the big one is not.
#[test]
fn clear_views_answer_as_the_rays_do() {
    use nlos_rs::geometry::{Interaction, Prim};
    use nlos_rs::integrator::clear_view::ClearView;
    use nlos_rs::math::Frame;
    use nlos_rs::sampling::square_to_cosine_hemisphere;
    let mut rng = Sampler::new(5, 0, 0);
    let (mut checked, mut open_checked, mut flagged_scenes, mut ends) = (0u64, 0u64, 0, 0u64);
    for case in 0..40 {
        let mut p = scene_props(vec![], vec![]);
        let mut r = |lo: f64, hi: f64| lo + (hi - lo) * rng.next_1d() as f64;
        for k in 0..case % 5 {
            let c = DVec3::new(r(-1.0, 1.0), r(-1.0, 1.0), r(0.3, 2.0));
            let turn = DMat4::from_rotation_x(std::f64::consts::PI + r(-1.5, 1.5) * (k % 2) as f64)
                * DMat4::from_rotation_y(r(-1.0, 1.0) * (k % 2) as f64);
            let m =
                DMat4::from_translation(c) * turn * DMat4::from_scale(DVec3::splat(r(0.05, 0.4)));
            let plugin = ["rectangle", "sphere", "disk", "cube"][(case + k) % 4];
            p.insert(
                format!("extra{k}"),
                obj(plugin, vec![("to_world", Value::Matrix(m))]),
            )
            .unwrap();
        }
        let scene = load(&p);
        let hidden = scene.hidden_geometry(false);
        let (scan, spots) = wall_viewpoints(&scene, &mut rng);
        let clear = ClearView::new(&scene, scan.iter(), spots.iter(), hidden);
        // The base scene's two rectangles: areas 0.16 m² at z = 0.8 and 0.64 m² at z = 1.2.
        let shape_of = |area: f64, z: f32| {
            (0..scene.shapes.len())
                .find(|&s| {
                    let first = scene.shapes[s].prims.start;
                    (scene.shapes[s].area - area).abs() < 1e-4
                        && matches!(scene.prims[first], Prim::Triangle { v, .. } if v.iter().all(|v| (v.z - z).abs() < 1e-5))
                })
                .expect("the base rectangles")
        };
        let (small, big) = (shape_of(0.16, 0.8), shape_of(0.64, 1.2));
        let mut flagged = false;
        for i in 0..scene.prims.len() {
            let shape = scene.prim_shape[i] as usize;
            for _ in 0..200 {
                let (y_p, ng, b) = scene.prims[i].sample_area(rng.next_2d());
                let y = scene.surface_point(i, y_p, ng, b);
                for (points, seen) in [
                    (&scan, clear.seen_from_scan_points(&y)),
                    (&spots, clear.seen_from_spots(&y)),
                ] {
                    if shape == small && case % 5 == 0 {
                        assert!(seen, "case {case}: the small rectangle in the open");
                    }
                    if shape == big {
                        assert!(
                            !seen,
                            "case {case}: the big rectangle is partly behind the small one"
                        );
                    }
                    if seen {
                        flagged = true;
                        let w =
                            &points[(rng.next_1d() * points.len() as f32) as usize % points.len()];
                        assert!(
                            scene.visible_to(w, &y) && scene.visible_to(&y, w),
                            "case {case} prim {i}"
                        );
                        checked += 1;
                    }
                }
                // A path ends at y where every side its BSDF leaves by is open: the front alone
                // for a one-sided BSDF over flat shading, both sides otherwise.
                let (front, back) = (
                    clear.misses_hidden(&y, y.ng),
                    clear.misses_hidden(&y, -y.ng),
                );
                let tilted = Interaction {
                    ns: (y.ng + 0.1 * Frame::new(y.ng).to_world(Vec3A::X)).normalize(),
                    ..y
                };
                assert_eq!(
                    clear.reaches_no_hidden(&y, false),
                    front && (back || y.ns == y.ng)
                );
                assert_eq!(clear.reaches_no_hidden(&y, true), front && back);
                assert_eq!(clear.reaches_no_hidden(&tilted, false), front && back);
                ends += clear.reaches_no_hidden(&y, false) as u64;
                // A direction from y: cosine-weighted about either side, as the mixture draws.
                let n = if rng.next_1d() < 0.5 { y.ng } else { -y.ng };
                let u = rng.next_2d();
                let wo = Frame::new(n).to_world(square_to_cosine_hemisphere(u));
                if clear.misses_hidden_about(&y, n, u) {
                    assert!(
                        clear.misses_hidden(&y, wo),
                        "case {case} prim {i}: before and after the warp"
                    );
                }
                if clear.misses_hidden(&y, wo) {
                    let hit = scene.intersect(y.offset_origin(wo), wo, f32::INFINITY);
                    let meets_hidden = hit.is_some_and(|(_, h)| hidden.unwrap().covers(h.shape));
                    assert!(
                        !meets_hidden,
                        "case {case} prim {i}: an open side meets hidden geometry"
                    );
                    open_checked += 1;
                }
            }
        }
        flagged_scenes += flagged as u32;
    }
    println!(
        "{checked} connections, {open_checked} open-side rays, {flagged_scenes} scenes flagged, \
         {ends} points where paths end"
    );
    assert!(checked > 10_000 && open_checked > 10_000 && flagged_scenes >= 20 && ends > 1_000);
}
