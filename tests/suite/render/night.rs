//! The night composite of the dusk scene against the path-traced reference (issue 16 §4: "composite
//! over the object and its lamp shadow ≤ 8%").
//!
//! At night (`scenes/dusk`, frame 4: the sun 5° down, a faint sky, the street lamp on) the statue
//! is lit by the lamp from 51° above the horizon. Its pedestal's top is one pixel row high on
//! screen, seen at a grazing angle, and lit only in a band on the lamp's side (the sphere above
//! overhangs it). With MSAA the shading fragments used to take their attributes at the pixel's
//! centre: for the top's sliver that is a point extrapolated far behind its covered samples,
//! under the sphere, where the lamp's shadow map says dark. The row came out 3–4× too dark and
//! carried 40% of the object's squared error. The object shaders now interpolate at the
//! centroid of the covered samples (`shaders/common/object.wgsl`).

use super::support::*;
use heliar::lighting::LampScales;
use heliar::render::reference::{Classes, composite_error};
use heliar::render::{Compositor, CompositorConfig, VideoFrame};

/// The issue's bound on the night frame with the scene's own estimate (measured 5.3% with the
/// default MSAA 4 and the bundled seed, debug build, lavapipe; 8.05% before centroid
/// interpolation; estimator seeds 0–4 give 4.9–6.7%, docs/measurements.md).
const NIGHT_TARGET: f64 = 0.08;
/// Relative RMSE over the statue's pixels with the truth's lamp scale, which leaves the
/// compositor's own error (measured 3.4%; 7.1% with attributes at the pixel centre). The margin
/// covers the adapter's rasterisation; the reference's own noise over the object is 1.2%.
const OBJECT_WITH_TRUE_K: f64 = 0.045;

#[test]
fn the_night_composite_is_within_the_issues_bound_and_the_pedestal_top_is_lit() {
    let scene = scene_as_cli("dusk");
    let mut run = ReferenceRun::new(&scene);
    let (k, index) = (1, run.refs.frames[1]);
    assert_eq!(index, 4, "the night reference frame (sky and lamp)");
    let (frame, estimate) = run.estimate_through(index);
    let ReferenceRun { refs, lin, ray, statue, .. } = run;
    let config = CompositorConfig::for_scene(&scene);
    let lighting = heliar::run::outdoor::lighting_of(&estimate);
    assert!(!lighting.above_horizon, "the sun is down at frame 4");
    let video = VideoFrame::from_frame(&frame, &lin);
    let classes = Classes::with_lamps(&scene, &statue, &ray, refs.crop, None, &[scene.lights[0].position.as_vec3()]);
    let reference = refs.image(k).unwrap();

    let mut comp = Compositor::for_scene(gpu(), &scene, ray.clone(), config.clone()).expect("compositor");
    let e = composite_error(&classes, &comp.render(&video, &lighting).unwrap().0.image, &reference);
    eprintln!(
        "night frame, the estimate's lighting (k {:?}): {:.2}% over the object and its lamp shadow (object {:.2}%, shadow {:.2}%)",
        lighting.lamps.as_slice(),
        100.0 * e.object_and_shadow,
        100.0 * e.object,
        100.0 * e.shadow
    );
    assert!(e.object_and_shadow <= NIGHT_TARGET, "night composite {:.2}% > {:.0}%", 100.0 * e.object_and_shadow, 100.0 * NIGHT_TARGET);

    let truth = heliar::lighting::Lighting { lamps: LampScales::from_slice(&[[1.0; 3]]), ..lighting };
    let mut comp = Compositor::for_scene(gpu(), &scene, ray.clone(), config).expect("compositor");
    let t = composite_error(&classes, &comp.render(&video, &truth).unwrap().0.image, &reference);
    eprintln!("night frame, the truth's k: object {:.2}% (mean {:.5} against {:.5})", 100.0 * t.object, t.object_mean, t.object_mean_reference);
    assert!(t.object <= OBJECT_WITH_TRUE_K, "object {:.2}% with the truth's k", 100.0 * t.object);
}
