//! Issue 13 §1–§2: the terrain's albedo measured on the environment map (`terrain_albedo =
//! "map"`), the turbidity chosen by residual (`turbidity = "fit"`), and the uniform sky of
//! overcast frames, on the winter scenes (a Hošek–Wilkie sky of turbidity 3 rendered by the
//! generator's tracer; beyond the proxy's ground, which ends 15 m away, snow of albedo 0.8 or
//! asphalt of 0.08) and on a synthetic overcast world.

use crate::common::*;
use heliar::envmap::bake::terrain::resolve_scene;
use heliar::estimate::{Estimator, EstimatorConfig, FrameEstimate};
use heliar::geometry::raycast::RayScene;
use heliar::io::frames::{Frame, Linearizer, Response};
use heliar::report::lighting_error;
use heliar::scene::Scene;
use heliar::scene::settings::{SkyShape, SkyTermsConfig, TerrainAlbedo, TerrainSource, Turbidity};
use std::path::Path;
use std::sync::Arc;

fn scene(rel: &str) -> (Scene, Arc<RayScene>) {
    let scene = Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(rel)).unwrap();
    let ray = Arc::new(RayScene::new(scene.proxy.clone()));
    (scene, ray)
}

/// Every frame of the scene's sequence with its `(Pd, Pa)` errors against the truth.
fn estimate_all(scene: &Scene, ray: Arc<RayScene>) -> Vec<(FrameEstimate, f64, f64)> {
    let seq = scene.sequences[0].clone();
    let truth = seq.truth.clone().expect("truth file");
    let mut est = Estimator::new(scene, ray).unwrap();
    let lin = seq.photometry.linearizer();
    seq.files
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let e = est.estimate(i, &seq.times[i], &Frame::load(p).unwrap(), &lin).unwrap();
            let (ed, ea) = lighting_error(&e.pd.unwrap(), &e.pa.unwrap(), &truth[i].pd, &truth[i].pa);
            (e, ed, ea)
        })
        .collect()
}

fn means(r: &[(FrameEstimate, f64, f64)]) -> (f64, f64) {
    let n = r.len() as f64;
    (r.iter().map(|x| x.1).sum::<f64>() / n, r.iter().map(|x| x.2).sum::<f64>() / n)
}

/// The map's texels below the horizon past the proxy give the terrain's albedo: snow 0.8 and
/// asphalt 0.08 in the generator (measured: (0.792, 0.786, 0.812) from 386 texels and
/// (0.082, 0.081, 0.082); since the sky column carries the shaped sky's interreflected light,
/// (0.845, 0.813, 0.825) and (0.087, 0.084, 0.083), the capture's red `Pa` being 5.8% low
/// instead of 1.2% high). Tolerances: ±0.05 (6%) for snow, ±0.01 (12%) for asphalt, about the
/// deviation the lighting at capture brings (2–6% in `Pa`). Each
/// frame's report says which albedo it used and that it came from the map.
#[test]
fn the_environment_map_gives_the_terrain_albedo_of_snow_and_asphalt() {
    for (variant, truth, tol) in [("snow", 0.8f32, 0.05f32), ("asphalt", 0.08, 0.01)] {
        let (mut s, ray) = scene(&format!("winter/{variant}"));
        s.estimator.sky.terrain_albedo = TerrainAlbedo::Map;
        let t = resolve_scene(&mut s, &ray).unwrap().expect("map asked for");
        eprintln!("{variant}: {t:?}");
        assert_eq!(t.source, TerrainSource::Map, "{t:?}");
        assert!(t.texels >= 32, "{t:?}");
        for c in 0..3 {
            assert!((t.albedo_rgb[c] - truth).abs() < tol, "{variant} channel {c}: {:?} against {truth}", t.albedo_rgb);
        }
        let r = estimate_all(&s, ray);
        let (d, a) = means(&r);
        eprintln!("{variant} with the map's albedo: Pd {:.2}% Pa {:.2}%", 100.0 * d, 100.0 * a);
        for (e, _, _) in &r {
            let used = e.terrain.as_ref().expect("a terrain in the model");
            assert_eq!((used.source, used.albedo_rgb), (TerrainSource::Map, t.albedo_rgb));
        }
        // Measured with the map's albedo: snow 1.2% / 2.6% (the default 0.2: 2.4% / 2.7%),
        // asphalt 1.0% / 2.2% (the default: 1.1% / 2.2%), as with the true albedo.
        assert!(d < 0.025 && a < 0.035, "{variant}: Pd {d} Pa {a}");
    }
}

/// A map whose proxy covers everything below the horizon (the courtyard, whose walls leave 46
/// texels of terrain in view, with a 2 km ground added under it), and a scene without an
/// `[envmap]`, fall back to the default albedo and say why.
#[test]
fn a_map_without_terrain_in_view_falls_back_with_a_reason() {
    use heliar::geometry::Material;
    let (mut s, _) = scene("courtyard");
    s.estimator.sky = SkyTermsConfig { terrain_albedo: TerrainAlbedo::Map, ..SkyTermsConfig::default() };
    let mut mesh = s.proxy.clone();
    let mat = mesh.add_material(Material::diffuse("far ground", [0.3; 3]));
    let node = mesh.add_node("far ground", false);
    mesh.push_quad(glam::Vec3::new(-1000.0, -0.01, -1000.0), glam::Vec3::Z * 2000.0, glam::Vec3::X * 2000.0, node, mat);
    let ray = Arc::new(RayScene::new(mesh));
    let mut no_map = s.clone();
    let t = resolve_scene(&mut s, &ray).unwrap().unwrap();
    assert_eq!((t.source, t.albedo_rgb), (TerrainSource::Fallback, [0.2; 3]), "{t:?}");
    let note = t.note.unwrap_or_default();
    assert!(note.contains("texels") && note.contains("env"), "{note}");
    no_map.manifest.envmap = None;
    let t = resolve_scene(&mut no_map, &ray).unwrap().unwrap();
    assert_eq!(t.source, TerrainSource::Fallback);
    assert!(t.note.unwrap_or_default().contains("[envmap]"));
}

/// `"map"` is the default, and its measurement is cached in `baked/terrain.json` under the
/// bake's input key and the ray geometry: a second load reads the same bits from the cache (and
/// says so), a corrupt cache file is measured again and rewritten, and a caller's changed geometry
/// (here a 2 km ground that hides all terrain) never gets the cached value.
#[test]
fn the_map_terrain_is_the_default_and_is_cached_by_its_inputs() {
    assert_eq!(SkyTermsConfig::default().terrain_albedo, TerrainAlbedo::Map);
    let dir = scratch_courtyard("terrain-cache");
    let load = || {
        let mut s = Scene::load(&dir).unwrap();
        s.estimator.sky = SkyTermsConfig::default();
        let ray = Arc::new(RayScene::new(s.proxy.clone()));
        (s, ray)
    };
    let cache = dir.join("baked").join(heliar::envmap::bake::terrain::CACHE_FILE);
    let (mut s, ray) = load();
    let first = resolve_scene(&mut s, &ray).unwrap().unwrap();
    // The courtyard's walls leave 46 texels of its dark terrain in view: (0.14, 0.13, 0.12).
    assert_eq!(first.source, TerrainSource::Map, "{first:?}");
    assert!(cache.is_file(), "no cache written");
    let (mut s, ray) = load();
    let again = resolve_scene(&mut s, &ray).unwrap().unwrap();
    assert_eq!((again.albedo_rgb, again.texels), (first.albedo_rgb, first.texels));
    assert!(again.note.as_deref().unwrap_or_default().contains("read from"), "{again:?}");
    assert_eq!(s.estimator.sky.terrain_rgb(), first.albedo_rgb, "the scene's model uses it");
    std::fs::write(&cache, b"{ not json").unwrap();
    let (mut s, ray) = load();
    let remeasured = resolve_scene(&mut s, &ray).unwrap().unwrap();
    assert_eq!(remeasured.albedo_rgb, first.albedo_rgb);
    assert!(!remeasured.note.as_deref().unwrap_or_default().contains("read from"), "{remeasured:?}");
    assert!(std::fs::read_to_string(&cache).unwrap().contains("\"key\""), "cache not rewritten");
    // The same files, other geometry: the cache does not apply.
    use heliar::geometry::Material;
    let (mut s, _) = load();
    let mut mesh = s.proxy.clone();
    let mat = mesh.add_material(Material::diffuse("far ground", [0.3; 3]));
    let node = mesh.add_node("far ground", false);
    mesh.push_quad(glam::Vec3::new(-1000.0, -0.01, -1000.0), glam::Vec3::Z * 2000.0, glam::Vec3::X * 2000.0, node, mat);
    let covered = resolve_scene(&mut s, &Arc::new(RayScene::new(mesh))).unwrap().unwrap();
    assert_eq!(covered.source, TerrainSource::Fallback, "{covered:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `turbidity = "fit"` on the winter scenes (truth: turbidity 3): every frame reports each
/// candidate's residual and keeps the smallest, its `sky_model` names it, and its values are the
/// bits of the fixed turbidity it chose (same draw, same fit). Measured: it picks 2 on six of the
/// eight frames, 3 on one, 6 on one; the residual prefers a clearer sky than the truth's, whose
/// model error (the interreflected part of `c` keeps the uniform sky) a flatter shape absorbs.
/// `Pd` then errs more than with the fixed 3 (snow 3.9% / 5.0% mean / worst against 2.4%,
/// asphalt 4.8% / 6.9% against 1.1%) and `Pa` less (1.4% / 2.0% against 2.6% / 2.2%); the
/// bounds below are those measurements with a margin. Since the sky column carries the shaped
/// sky's interreflected light, the fit still picks 6, 2, 2, 2 on snow (Pd 4.8%, Pa 4.1%).
#[test]
fn the_turbidity_chosen_by_residual_is_reported_and_reproducible() {
    for variant in ["snow", "asphalt"] {
        let (mut s, ray) = scene(&format!("winter/{variant}"));
        s.estimator.sky.turbidity = Turbidity::Fit;
        // The surface flags carry each frame's fitted model into the later frames' draws, so a
        // run at a fixed turbidity draws differently once anything is flagged; the property here
        // is per frame (same draw, same fit).
        s.estimator.surface_flags = false;
        let fit = estimate_all(&s, ray.clone());
        let chosen: Vec<f64> = fit.iter().map(|(e, _, _)| e.turbidity_fit.as_ref().expect("a turbidity fit").chosen).collect();
        let (d, a) = means(&fit);
        eprintln!("{variant}: chosen {chosen:?}; Pd {:.2}% Pa {:.2}%", 100.0 * d, 100.0 * a);
        for (e, _, _) in &fit {
            let f = e.turbidity_fit.as_ref().unwrap();
            assert_eq!(f.candidates.iter().map(|c| c.0).collect::<Vec<_>>(), [2.0, 3.0, 4.0, 6.0], "{f:?}");
            assert!(f.candidates.iter().all(|c| c.1.is_some_and(|r| r >= f.residual)), "{f:?}");
            assert_eq!(e.sky_model.as_deref(), Some(format!("hosek_wilkie T={}", f.chosen).as_str()));
            assert!(e.condition_number.is_some_and(|c| c < s.estimator.max_condition), "{e:?}");
        }
        assert!(d < 0.06 && a < 0.045, "{variant}: Pd {d} Pa {a}");
        // Frame by frame, the fit equals the fixed turbidity it chose.
        let mut distinct = chosen.clone();
        distinct.sort_by(f64::total_cmp);
        distinct.dedup();
        for t in distinct {
            s.estimator.sky.turbidity = Turbidity::Value(t);
            let fixed = estimate_all(&s, ray.clone());
            for (k, ((f, _, _), (x, _, _))) in fit.iter().zip(&fixed).enumerate().filter(|(k, _)| chosen[*k] == t) {
                assert_eq!((f.pd, f.pa, f.condition_number, f.pd_se), (x.pd, x.pa, x.condition_number, x.pd_se), "{variant} frame {k} at turbidity {t}");
            }
        }
    }
}

/// A frame without direct sun switches the next frames to the uniform sky; the reports say so.
#[test]
fn overcast_frames_use_the_uniform_sky_and_say_so() {
    let time = afternoon();
    let l = sun_dir(&time);
    let w = world(WorldSpec::default(), l);
    let pa = [0.6, 0.7, 0.9];
    let overcast = frame(render(&w, l, [0.0; 3], pa, 0.01, 1));
    let sky = SkyTermsConfig { terrain_albedo: TerrainAlbedo::Rgb([0.0; 3]), directions: 256, ..SkyTermsConfig::default() };
    assert_eq!(sky.shape, SkyShape::HosekWilkie);
    // The fit of a frame without sun is ill-conditioned on this view (κ ≈ 30: few shadowed
    // samples); the bound is raised so that its `Pd ≈ 0` reaches the smoother, as a
    // well-conditioned overcast view's would (the switch is what is tested here).
    let mut est = estimator(&w, EstimatorConfig { sky, max_condition: 1e3, ..EstimatorConfig::default() });
    let lin = Linearizer::new(&Response::Linear, 1.0, 1.0, Some(f32::INFINITY));
    let first = est.estimate(0, &time, &overcast, &lin).unwrap();
    assert_eq!(first.sky_model.as_deref(), Some("hosek_wilkie T=3"), "{first:?}");
    assert_eq!(first.status, heliar::estimate::Status::NoDirectSun, "{first:?}");
    let next = est.estimate(1, &(time + chrono::Duration::seconds(1)), &overcast, &lin).unwrap();
    assert_eq!(next.sky, SkyShape::Uniform, "{next:?}");
    assert_eq!(next.sky_model.as_deref(), Some("uniform"), "{next:?}");
    // Under the uniform sky the overcast frame's Pa is the rendered one (uniform sky, no sun).
    assert!(rel_err(next.pa.unwrap(), pa) < 0.03, "{next:?}");
}

/// The estimator's ambient column is the renderer's sky light (issue 13 §1, "one sky model is
/// used everywhere"): for pool entries of the winter snow scene at its 10° sun, `a` (the
/// uniform `c`, the sky's shape through the entry's open directions, the interreflected part of
/// `c` under the shaped sky, the terrain) against `ρ/π` times `c` path-traced whole under the
/// same sky (`transport_under`, 2048 paths, every bounce). Mean ratio over 60 entries within 2%
/// per channel (the Monte Carlo noise of 60 × 2048 paths is ≈ 0.3%); without the
/// interreflected part (before it was added) red was 4% low on walls facing the low sun.
#[test]
fn the_estimators_sky_column_equals_the_sky_light_traced_whole() {
    use heliar::geometry::ambient::{TransportQuality, UniformSky, transport_under, transport_with_bounced};
    use heliar::sky::radiance::{ShapeMinusUniform, SkyModel};
    let (scene, ray) = scene("winter/snow");
    let seq = scene.sequences[0].clone();
    let mut est = Estimator::new(&scene, ray.clone()).unwrap();
    let lin = seq.photometry.linearizer();
    let i = 3;
    est.estimate(i, &seq.times[i], &Frame::load(&seq.files[i]).unwrap(), &lin).unwrap();
    let (_, l) = est.sun_at(&seq.times[i]).unwrap();
    let cfg = &est.config().sky;
    let model = SkyModel { hosek_turbidity: Some(cfg.turbidity.value()), terrain_albedo: cfg.terrain_rgb() };
    let sky = model.for_sun(Some(l));
    let (pool, a) = (est.pool(), &est.sun_sky().expect("sky terms").a);
    let q = TransportQuality { paths: 2048, max_bounces: 4 };
    let step = (pool.len() / 60).max(1);
    let (mut got, mut want, mut ir) = (glam::DVec3::ZERO, glam::DVec3::ZERO, glam::DVec3::ZERO);
    for k in (0..pool.len()).step_by(step).take(60) {
        let c = transport_under(&ray, pool.point[k], pool.normal[k], None, &sky, q, 77 + k as u64).c;
        want += (pool.albedo[k] * c / std::f32::consts::PI).as_dvec3();
        got += glam::Vec3::from(a[k]).as_dvec3();
        let (_, d) = transport_with_bounced(&ray, pool.point[k], pool.normal[k], None, &UniformSky, &[ShapeMinusUniform(&sky)], q, 99 + k as u64);
        ir += (pool.albedo[k] * d[0].c / std::f32::consts::PI).as_dvec3();
    }
    let ratio = got / want;
    eprintln!("estimator a / traced: {ratio:?}; without the interreflected part: {:?}", (got - ir) / want);
    assert!((ratio - glam::DVec3::ONE).abs().max_element() < 0.02, "{ratio:?}");
}
