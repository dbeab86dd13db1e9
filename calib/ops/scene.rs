//! New scene folders: the manifest written for a proxy, a camera file and a place.

use anyhow::{Context, Result, bail};
use heliar::scene::Scene;
use std::path::{Path, PathBuf};

/// What a new scene is made of.
#[derive(Clone, Debug, PartialEq)]
pub struct NewScene {
    /// Proxy glTF (copied to `proxy.glb`).
    pub proxy: PathBuf,
    /// Camera file (copied to `calib/camera.toml`).
    pub camera: PathBuf,
    /// Latitude, degrees north.
    pub latitude_deg: f64,
    /// Longitude, degrees east.
    pub longitude_deg: f64,
    /// Height above sea level, metres.
    pub elevation_m: f64,
    /// World direction of north.
    pub north: [f64; 3],
    /// Nodes marked as diffuse estimation surfaces.
    pub diffuse: Vec<String>,
}

/// Three comma-separated numbers.
pub fn parse_vec3(s: &str, what: &str) -> Result<[f64; 3]> {
    let v: Vec<f64> = s.split(',').map(|x| x.trim().parse::<f64>()).collect::<Result<_, _>>().with_context(|| format!("{what} '{s}': three numbers x,y,z"))?;
    match v.as_slice() {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok([*x, *y, *z]),
        _ => bail!("{what} '{s}': three finite numbers x,y,z"),
    }
}

/// The manifest of a new scene called `name`.
pub fn manifest(name: &str, n: &NewScene) -> String {
    let mut doc = toml_edit::DocumentMut::new();
    doc["name"] = toml_edit::value(name);
    let mut place = toml_edit::Table::new();
    place["latitude_deg"] = toml_edit::value(n.latitude_deg);
    place["longitude_deg"] = toml_edit::value(n.longitude_deg);
    place["elevation_m"] = toml_edit::value(n.elevation_m);
    place["north"] = super::toml_array(n.north);
    doc["place"] = toml_edit::Item::Table(place);
    let mut proxy = toml_edit::Table::new();
    proxy["file"] = toml_edit::value("proxy.glb");
    proxy["diffuse_nodes"] = super::toml_array(n.diffuse.iter().map(String::as_str));
    doc["proxy"] = toml_edit::Item::Table(proxy);
    let mut camera = toml_edit::Table::new();
    camera["file"] = toml_edit::value("calib/camera.toml");
    doc["camera"] = toml_edit::Item::Table(camera);
    doc.to_string()
}

/// Creates the scene folder `out` (which must not exist), validated before it appears.
pub fn create(out: &Path, n: &NewScene) -> Result<Scene> {
    use crate::edit::FileSource;
    let name = out.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "scene".into());
    crate::edit::create_scene(
        out,
        &[
            (PathBuf::from("scene.toml"), FileSource::Bytes(manifest(&name, n).into_bytes())),
            (PathBuf::from("proxy.glb"), FileSource::Copy(n.proxy.clone())),
            (PathBuf::from("calib/camera.toml"), FileSource::Copy(n.camera.clone())),
        ],
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_manifest_parses_and_quotes_names() {
        let n = NewScene {
            proxy: "p.glb".into(),
            camera: "c.toml".into(),
            latitude_deg: 57.0488,
            longitude_deg: -9.5,
            elevation_m: 8.0,
            north: [0.0, 0.0, -1.0],
            diffuse: vec!["ground".into(), "say \"hi\"".into()],
        };
        let m: heliar::scene::Manifest = toml::from_str(&manifest("yard", &n)).unwrap();
        assert_eq!(m.proxy.diffuse_nodes, n.diffuse);
        assert_eq!((m.place.latitude_deg, m.place.longitude_deg), (57.0488, -9.5));
        assert_eq!(parse_vec3("0, 0,-1", "--north").unwrap(), [0.0, 0.0, -1.0]);
        assert!(parse_vec3("0,1", "--north").is_err() && parse_vec3("0,a,1", "--north").is_err());
    }
}
