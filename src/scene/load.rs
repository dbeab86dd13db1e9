//! The steps of [`Scene::load_with`](super::Scene::load_with), each checking one part of the
//! manifest and naming the file and field of what it refuses.

use super::gltf::{self, LoadNotes};
use super::limits;
use super::motion::ObjectMotion;
use super::paths::Within;
use super::settings::BakeConfig;
use super::{AlbedoSource, Manifest, ResponseSpec, SceneError, Sequence, VirtualObject, finite3, invalid, load_truth, parse_time};
use crate::geometry::{Mesh, subdivide};
use crate::io::frames::{Photometry, ReadNoise, Response, list_frame_files};
use super::manifest::{READ_NOISE_AUTO, ReadNoiseSpec};
use crate::sun::{GeoFrame, Observer};
use glam::{DVec3, Mat4, Quat, Vec3};
use std::path::Path;

/// `[place]`: the observer and the world's geographic frame.
pub(super) fn place(m: &Path, manifest: &Manifest) -> Result<(Observer, GeoFrame), SceneError> {
    let pl = &manifest.place;
    let observer = Observer {
        latitude_deg: pl.latitude_deg,
        longitude_deg: pl.longitude_deg,
        elevation_m: pl.elevation_m,
        pressure_mbar: pl.pressure_mbar,
        temperature_c: pl.temperature_c,
        delta_t_s: pl.delta_t_s,
    };
    observer.validate().map_err(|(f, msg)| invalid(m, &format!("place.{f}"), msg))?;
    let geo = GeoFrame::from_north(finite3(m, "place.north", pl.north)?)
        .ok_or_else(|| invalid(m, "place.north", "must have a horizontal (x/z) component"))?;
    Ok((observer, geo))
}

/// The camera file's `[response]` values.
pub(super) fn check_response(camera_path: &Path, rs: &ResponseSpec) -> Result<(), SceneError> {
    if !(rs.exposure.is_finite() && rs.exposure > 0.0) {
        return Err(invalid(camera_path, "response.exposure", "must be positive"));
    }
    if !(rs.saturation > 0.0 && rs.saturation <= 1.0) {
        return Err(invalid(camera_path, "response.saturation", "must be in (0, 1]"));
    }
    if rs.hdr_clip.is_some_and(|c| !(c > 0.0)) {
        return Err(invalid(camera_path, "response.hdr_clip", "must be positive"));
    }
    match &rs.read_noise {
        Some(ReadNoiseSpec::Value(v)) if !(v.is_finite() && *v >= 0.0) => {
            return Err(invalid(camera_path, "response.read_noise", format!("{v} is not a finite standard deviation ≥ 0 (linear camera units)")));
        }
        Some(ReadNoiseSpec::Word(w)) if w != READ_NOISE_AUTO => {
            return Err(invalid(camera_path, "response.read_noise", format!("'{w}' is neither a standard deviation ≥ 0 (linear camera units) nor \"{READ_NOISE_AUTO}\"")));
        }
        _ => {}
    }
    Ok(())
}

/// `[proxy]`: the proxy glTF with its diffuse marks (at least one).
pub(super) fn proxy(within: &Within, m: &Path, manifest: &Manifest) -> Result<(Mesh, LoadNotes), SceneError> {
    let proxy_path = within.join(m, "proxy.file", &manifest.proxy.file)?;
    if !proxy_path.exists() {
        return Err(invalid(m, "proxy.file", format!("{} does not exist", proxy_path.display())));
    }
    if let Some(n) = manifest.proxy.not_diffuse_nodes.iter().find(|n| manifest.proxy.diffuse_nodes.contains(n)) {
        return Err(invalid(m, "proxy.not_diffuse_nodes", format!("'{n}' is also in proxy.diffuse_nodes; a node is either marked or not")));
    }
    let (proxy, proxy_notes) =
        gltf::load_gltf_with(&proxy_path, Mat4::IDENTITY, &manifest.proxy.diffuse_nodes, &manifest.proxy.not_diffuse_nodes, within.confine())?;
    if !proxy.nodes.iter().any(|n| n.diffuse) {
        return Err(invalid(
            &proxy_path,
            "extras.heliar.diffuse",
            "no node is marked as a diffuse estimation surface (set it in the node's extras or list it in proxy.diffuse_nodes)",
        ));
    }
    Ok((proxy, proxy_notes))
}

/// `[[virtual_objects]]`: each glTF placed in the world, its edges longer than
/// [`subdivide::CUTS_EDGE_FRACTION`] of its bounding radius split (`crate::geometry::subdivide`:
/// the visibility cuts shade it per vertex; the surface is unchanged).
pub(super) fn virtual_objects(within: &Within, m: &Path, manifest: &Manifest) -> Result<Vec<VirtualObject>, SceneError> {
    let mut virtual_objects = Vec::new();
    for (i, v) in manifest.virtual_objects.iter().enumerate() {
        let field = |f: &str| format!("virtual_objects[{i}].{f}");
        let path = within.join(m, &field("file"), &v.file)?;
        if !path.exists() {
            return Err(invalid(m, &field("file"), format!("{} does not exist", path.display())));
        }
        if !(v.scale.is_finite() && v.scale > 0.0) {
            return Err(invalid(m, &field("scale"), "must be positive"));
        }
        let t = finite3(m, &field("translation"), v.translation)?.as_vec3();
        let placement = Mat4::from_scale_rotation_translation(
            Vec3::splat(v.scale as f32),
            Quat::from_rotation_y((v.rotation_y_deg as f32).to_radians()),
            t,
        );
        // Its long edges are split for the visibility cuts (`split`), planned on the object in
        // its own frame, so that a static and a moving object get the same triangles.
        let (rest, _) = gltf::load_gltf_within(&path, Mat4::IDENTITY, &[], within.confine())?;
        let split = subdivide::plan(&rest, subdivide::CUTS_EDGE_FRACTION * subdivide::bounding_radius(&rest));
        let split = |mesh: Mesh| match &split {
            Some(p) => subdivide::apply(&mesh, p),
            None => mesh,
        };
        let Some(spec) = &v.motion else {
            let (mesh, _) = gltf::load_gltf_within(&path, placement, &[], within.confine())?;
            virtual_objects.push(VirtualObject { path, mesh: split(mesh), motion: None });
            continue;
        };
        let motion = super::motion_load::motion(within, m, i, spec, placement, v.scale)?;
        // Where it stands at the first key, loaded as a static object is (so a motion that
        // starts at the manifest's placement starts bit for bit where the static object stands).
        let (mesh, _) = gltf::load_gltf_within(&path, motion.world_from_rest(motion.start_seconds()), &[], within.confine())?;
        let (mesh, rest) = (split(mesh), split(rest));
        let moving = ObjectMotion { rest, motion };
        virtual_objects.push(VirtualObject { path, mesh, motion: Some(moving) });
    }
    Ok(virtual_objects)
}

/// `[envmap]` and `[irradiance]`: checked here, used by the bake.
pub(super) fn check_envmap_and_grid(within: &Within, m: &Path, manifest: &Manifest) -> Result<(), SceneError> {
    if let Some(env) = &manifest.envmap {
        match (&env.file, env.albedo) {
            (Some(f), _) => {
                let p = within.join(m, "envmap.file", f)?;
                if !p.exists() {
                    return Err(invalid(m, "envmap.file", format!("{} does not exist", p.display())));
                }
            }
            (None, AlbedoSource::Inverse) => {
                return Err(invalid(m, "envmap.file", "an environment map file is needed unless albedo = \"gltf\""));
            }
            (None, AlbedoSource::Gltf) => {}
        }
        if let Some([w, h]) = env.resolution
            && (w < 8 || h < 4 || w > 16384 || h > 8192)
        {
            return Err(invalid(m, "envmap.resolution", format!("{w}×{h} is not a usable map size")));
        }
        finite3(m, "envmap.capture_center", env.capture_center)?;
        parse_time(m, "envmap.capture_time", &env.capture_time.to_string())?;
        match (env.capture_pd, env.capture_pa) {
            (Some(pd), Some(pa)) => {
                for (f, v) in [("envmap.capture_pd", pd), ("envmap.capture_pa", pa)] {
                    if v.iter().any(|x| !(x.is_finite() && *x >= 0.0)) {
                        return Err(invalid(m, f, "must be three finite non-negative numbers"));
                    }
                }
            }
            (None, None) => {}
            _ => return Err(invalid(m, "envmap.capture_pd/capture_pa", "give both or neither")),
        }
    }
    if let Some(g) = &manifest.irradiance {
        let (lo, hi) = (finite3(m, "irradiance.min", g.min)?, finite3(m, "irradiance.max", g.max)?);
        if !(lo.cmplt(hi).all()) {
            return Err(invalid(m, "irradiance.min/max", "min must be below max on every axis (empty or inverted bounds)"));
        }
        if !(g.spacing_m.is_finite() && g.spacing_m > 0.0) {
            return Err(invalid(m, "irradiance.spacing_m", "must be positive"));
        }
    }
    Ok(())
}

/// `[[sequences]]`: frame files inside the scene, times, exposure and truth.
pub(super) fn sequences(within: &Within, m: &Path, manifest: &Manifest, response: &Response, rs: &ResponseSpec) -> Result<Vec<Sequence>, SceneError> {
    let mut sequences = Vec::new();
    for (i, s) in manifest.sequences.iter().enumerate() {
        let field = |f: &str| format!("sequences[{i}].{f}");
        let dir = within.join(m, &field("dir"), &s.dir)?;
        if !dir.is_dir() {
            return Err(invalid(m, &field("dir"), format!("{} is not a folder", dir.display())));
        }
        let files = list_frame_files(&dir)?;
        for f in &files {
            within.check(m, &field("dir"), f)?;
        }
        if files.is_empty() {
            return Err(invalid(m, &field("dir"), format!("{} holds no .exr or .png frames", dir.display())));
        }
        let times = s.time_spec().frame_times(m, &field("times"), files.len())?;
        let exposure = s.exposure.unwrap_or(rs.exposure);
        if !(exposure.is_finite() && exposure > 0.0) {
            return Err(invalid(m, &field("exposure"), "must be positive"));
        }
        let truth = match &s.truth {
            Some(t) => Some(load_truth(&within.join(m, &field("truth"), t)?, files.len())?),
            None => None,
        };
        sequences.push(Sequence {
            name: s.name.clone(),
            files,
            times,
            photometry: Photometry { response: response.clone(), exposure, saturation: rs.saturation, hdr_clip: rs.hdr_clip, read_noise: rs.read_noise_setting().unwrap_or(ReadNoise::Unknown) },
            truth,
        });
    }
    Ok(sequences)
}

/// The probe grid's size, before the bake or a probe source allocates it: the manifest's grid,
/// or the default one around the virtual objects (`irradiance::sources`).
pub(super) fn check_probe_budget(m: &Path, manifest: &Manifest, virtual_objects: &[VirtualObject], bake: &BakeConfig) -> Result<(), SceneError> {
    // The probe grid's size, before the bake or a probe source allocates it: the manifest's
    // grid, or the default one around the virtual objects (`irradiance::sources`).
    match &manifest.irradiance {
        Some(g) => limits::check_probe_grid(m, "irradiance.spacing_m", g.min.into(), g.max.into(), g.spacing_m, bake.probe_directions)?,
        None => {
            let b = virtual_objects.iter().filter_map(|o| o.mesh.bounds()).reduce(|(a, b), (c, d)| (a.min(c), b.max(d)));
            if let Some((lo, hi)) = b {
                let (lo, hi) = (lo.as_dvec3() - DVec3::ONE, hi.as_dvec3() + DVec3::ONE);
                limits::check_probe_grid(m, "virtual_objects (the default probe grid around them, at 1 m)", lo, hi, 1.0, bake.probe_directions)?;
            }
        }
    }
    Ok(())
}
