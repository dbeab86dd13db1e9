//! `[virtual_objects.motion]` read and checked: manifest keyframes or a glTF node animation
//! into a [`Motion`], every refusal naming the file and field (`super::motion` for the model).

use super::manifest::{KeyTimeValue, KeyframeSpec, MotionSpec};
use super::motion::{Motion, MotionClock, Track};
use super::paths::Within;
use super::{SceneError, finite3, invalid, parse_time};
use gltf::animation::{Interpolation, Property};
use gltf::animation::util::ReadOutputs;
use glam::{Mat4, Quat, Vec3};
use std::path::Path;

/// The motion of object `i` from its `motion` table. `placement` is the manifest's placement
/// (translation, rotation, scale) and `scale` its uniform scale.
pub(super) fn motion(within: &Within, m: &Path, i: usize, spec: &MotionSpec, placement: Mat4, scale: f64) -> Result<Motion, SceneError> {
    let field = format!("virtual_objects[{i}].motion");
    match (&spec.gltf, spec.keyframes.is_empty()) {
        (Some(_), false) => Err(invalid(m, &field, "give either `keyframes` or `gltf`, not both")),
        (None, true) => Err(invalid(m, &format!("{field}.keyframes"), "no keyframes: give at least one keyframe, or a `gltf` file with a node animation")),
        (None, false) => {
            if spec.animation.is_some() || spec.node.is_some() {
                return Err(invalid(m, &field, "`animation` and `node` choose a glTF animation; they need `gltf`"));
            }
            keyframes(m, &field, &spec.keyframes, scale)
        }
        (Some(file), true) => {
            let path = within.join(m, &format!("{field}.gltf"), file)?;
            if !path.exists() {
                return Err(invalid(m, &format!("{field}.gltf"), format!("{} does not exist", path.display())));
            }
            gltf_animation(&path, spec, placement, within.confine())
        }
    }
}

/// Manifest keyframes: one time kind, strictly increasing, finite values.
fn keyframes(m: &Path, field: &str, keys: &[KeyframeSpec], scale: f64) -> Result<Motion, SceneError> {
    let mut seconds = Vec::with_capacity(keys.len());
    let mut absolute = Vec::with_capacity(keys.len());
    let (mut translations, mut rotations) = (Vec::new(), Vec::new());
    for (k, key) in keys.iter().enumerate() {
        let f = |name: &str| format!("{field}.keyframes[{k}].{name}");
        match &key.time {
            KeyTimeValue::Seconds(s) if s.is_finite() => seconds.push(*s),
            KeyTimeValue::Seconds(s) => return Err(invalid(m, &f("time"), format!("{s} is not a finite number of seconds"))),
            KeyTimeValue::Time(t) => absolute.push(parse_time(m, &f("time"), &t.to_string())?),
        }
        if !seconds.is_empty() && !absolute.is_empty() {
            return Err(invalid(m, &f("time"), "mixes seconds from the sequence start and RFC 3339 times; use one kind per motion"));
        }
        translations.push(finite3(m, &f("translation"), key.translation)?.as_vec3());
        if !key.rotation_y_deg.is_finite() {
            return Err(invalid(m, &f("rotation_y_deg"), "must be a finite number"));
        }
        rotations.push(Quat::from_rotation_y((key.rotation_y_deg as f32).to_radians()));
    }
    let (clock, times) = match absolute.first() {
        Some(t0) => (MotionClock::Absolute(*t0), absolute.iter().map(|t| (*t - *t0).num_microseconds().unwrap_or(i64::MAX) as f64 / 1e6).collect()),
        None => (MotionClock::FromStart, seconds),
    };
    check_increasing(&times).map_err(|k| invalid(m, &format!("{field}.keyframes[{k}].time"), format!("is not after keyframes[{}].time; key times must increase", k - 1)))?;
    Ok(Motion {
        clock,
        translation: Some(Track { times: times.clone(), values: translations }),
        rotation: Some(Track { times, values: rotations }),
        static_translation: Vec3::ZERO,
        static_rotation: Quat::IDENTITY,
        // Identity factors multiply exactly, so the pose equals the static placement's matrix.
        scale: Vec3::splat(scale as f32),
        left: Mat4::IDENTITY,
        right: Mat4::IDENTITY,
    })
}

/// `Err(k)` for the first key `k` whose time is not above key `k - 1`'s.
fn check_increasing(times: &[f64]) -> Result<(), usize> {
    match times.windows(2).position(|w| !(w[1] > w[0])) {
        Some(k) => Err(k + 1),
        None => Ok(()),
    }
}

/// The channels of one node of one animation, read.
#[derive(Default)]
struct NodeTracks {
    translation: Option<Track<Vec3>>,
    rotation: Option<Track<Quat>>,
}

/// A glTF node animation (module docs of `super::motion`).
fn gltf_animation(path: &Path, spec: &MotionSpec, placement: Mat4, confine: Option<&Path>) -> Result<Motion, SceneError> {
    let gerr = |message: String| SceneError::Gltf { path: path.to_owned(), message };
    let (doc, buffers, _) = super::gltf::import_checked(path, confine)?;
    let anim = match &spec.animation {
        Some(name) => doc.animations().find(|a| a.name() == Some(name.as_str())).ok_or_else(|| gerr(format!("animations: no animation named '{name}'")))?,
        None => doc.animations().next().ok_or_else(|| gerr("animations: the file has no animation (motion.gltf needs a node animation)".into()))?,
    };
    let label = format!("animations[{}]{}", anim.index(), anim.name().map(|n| format!(" '{n}'")).unwrap_or_default());
    let first = anim.channels().next().ok_or_else(|| gerr(format!("{label}: no channels, so no keyframes")))?;
    let node = match &spec.node {
        Some(name) => doc.nodes().find(|n| n.name() == Some(name.as_str())).ok_or_else(|| gerr(format!("nodes: no node named '{name}' (motion.node)")))?,
        None => first.target().node(),
    };
    let node_label = node.name().map(|n| format!("'{n}'")).unwrap_or_else(|| format!("nodes[{}]", node.index()));
    let mut tracks = NodeTracks::default();
    for ch in anim.channels().filter(|c| c.target().node().index() == node.index()) {
        let at = format!("{label}.channels[{}]", ch.index());
        let property = ch.target().property();
        if !matches!(property, Property::Translation | Property::Rotation) {
            return Err(gerr(format!("{at}: animates {property:?} of node {node_label}; only translation and rotation channels are supported (rigid motion)")));
        }
        if ch.sampler().interpolation() != Interpolation::Linear {
            return Err(gerr(format!("{at}: interpolation {:?} is not supported; export with LINEAR", ch.sampler().interpolation())));
        }
        let reader = ch.reader(|b| buffers.get(b.index()).map(|d| d.0.as_slice()));
        let times: Vec<f64> = reader.read_inputs().map(|it| it.map(f64::from).collect()).unwrap_or_default();
        if times.is_empty() {
            return Err(gerr(format!("{at}: no keyframes (an empty input accessor)")));
        }
        if let Some(k) = times.iter().position(|t| !t.is_finite()) {
            return Err(gerr(format!("{at}: key time {k} is not finite")));
        }
        check_increasing(&times).map_err(|k| gerr(format!("{at}: key time {k} ({}) is not after key time {} ({}); times must increase", times[k], k - 1, times[k - 1])))?;
        match reader.read_outputs() {
            Some(ReadOutputs::Translations(it)) => {
                let values: Vec<Vec3> = it.map(Vec3::from).collect();
                check_values(&at, times.len(), values.len(), values.iter().all(|v| v.is_finite())).map_err(gerr)?;
                tracks.translation = Some(Track { times, values });
            }
            Some(ReadOutputs::Rotations(r)) => {
                let values: Vec<Quat> = r.into_f32().map(|q| Quat::from_array(q).normalize()).collect();
                check_values(&at, times.len(), values.len(), values.iter().all(|q| q.is_finite())).map_err(gerr)?;
                tracks.rotation = Some(Track { times, values });
            }
            _ => return Err(gerr(format!("{at}: the output accessor cannot be read as {property:?}"))),
        }
    }
    if tracks.translation.is_none() && tracks.rotation.is_none() {
        return Err(gerr(format!("{label}: no translation or rotation channel targets node {node_label} (motion.node)")));
    }
    let parent = parent_transform(&doc, node.index()).ok_or_else(|| gerr(format!("node {node_label} is not in the file's scene")))?;
    let (t, r, s) = node.transform().decomposed();
    let rest = Mat4::from_cols_array_2d(&node.transform().matrix());
    let right = (parent * rest).inverse();
    if !right.is_finite() {
        return Err(gerr(format!("node {node_label}: its rest transform cannot be inverted (zero scale)")));
    }
    Ok(Motion {
        clock: MotionClock::FromStart,
        translation: tracks.translation,
        rotation: tracks.rotation,
        static_translation: Vec3::from(t),
        static_rotation: Quat::from_array(r).normalize(),
        scale: Vec3::from(s),
        left: placement * parent,
        right,
    })
}

fn check_values(at: &str, keys: usize, values: usize, finite: bool) -> Result<(), String> {
    if values != keys {
        return Err(format!("{at}: {values} output values for {keys} key times"));
    }
    if !finite {
        return Err(format!("{at}: an output value is not finite"));
    }
    Ok(())
}

/// The global transform of the parent of node `index` in the file's default scene (identity
/// for a root node); `None` when the node is not in it.
fn parent_transform(doc: &gltf::Document, index: usize) -> Option<Mat4> {
    let scene = doc.default_scene().or_else(|| doc.scenes().next())?;
    let mut stack: Vec<(gltf::Node, Mat4)> = scene.nodes().map(|n| (n, Mat4::IDENTITY)).collect();
    while let Some((node, parent)) = stack.pop() {
        if node.index() == index {
            return Some(parent);
        }
        let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        stack.extend(node.children().map(|c| (c, world)));
    }
    None
}
