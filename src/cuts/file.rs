//! The precompute file: a scene's self-visibility cuts, visibility cut fields and proxy field,
//! keyed by a hash of their inputs.
//!
//! # Layout (little-endian)
//! | bytes | field |
//! |---|---|
//! | 8 | magic `HLRCUTS\0` |
//! | 4 | format version ([`FORMAT_VERSION`]) |
//! | 32 | blake3 of the inputs ([`inputs_hash`]: meshes, settings, format) |
//! | 8 | body length |
//! | 32 | blake3 of the body |
//! | … | body: tree levels, objects (positions, normals, SVC bank, VCF geometry and bank), proxy |
//!
//! A bank is its levels, value encoding, cut and node counts, then the 4-bit heights and the
//! values ([`super::packed`]); per-cut offsets are not stored but rebuilt from the heights on
//! load, which also checks every cut. The file is written to a temporary file beside the target
//! and renamed over it, so a crash never leaves half a file under the real name. A wrong magic,
//! version, length or body hash, or any field out of range, is [`CutsError::Corrupt`] naming the
//! file and the field.

use super::eval::ObjectCuts;
use super::packed::{PackedCuts, ValueEncoding};
use super::proxy_field::{ProxyField, ProxyGrid};
use super::svc::{SelfVisibility, SvcSettings};
use super::tree::DirectionTree;
use super::vcf::{VcfSampling, VisibilityCutField};
use super::{CutsError, Progress};
use crate::geometry::Mesh;
use crate::geometry::raycast::RayScene;
use glam::Vec3;
use std::path::{Path, PathBuf};

/// File magic.
pub const MAGIC: &[u8; 8] = b"HLRCUTS\0";
/// Format version; part of the inputs hash, so a new format invalidates old caches.
pub const FORMAT_VERSION: u32 = 1;
const HEADER_BYTES: usize = 8 + 4 + 32 + 8 + 32;

/// Everything that decides a scene's cuts besides the meshes.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PrecomputeSettings {
    /// Tree depth (`S = 2^levels`).
    pub levels: u32,
    /// Self-visibility cuts.
    pub svc: SvcSettings,
    /// Visibility cut fields.
    pub vcf: VcfSampling,
    /// The proxy field's grid, if any.
    pub proxy: Option<ProxyGrid>,
}

/// A scene's precomputed cuts.
#[derive(Clone, Debug, PartialEq)]
pub struct PrecomputedCuts {
    /// blake3 of the inputs.
    pub inputs_hash: [u8; 32],
    /// Tree depth of every bank.
    pub levels: u32,
    /// Per object, in input order.
    pub objects: Vec<ObjectCuts>,
    /// The proxy field.
    pub proxy: Option<ProxyField>,
}

fn hash_mesh(h: &mut blake3::Hasher, name: &str, mesh: &Mesh) {
    h.update(&(name.len() as u64).to_le_bytes());
    h.update(name.as_bytes());
    for list in [&mesh.positions, &mesh.normals] {
        h.update(&(list.len() as u64).to_le_bytes());
        for p in list {
            for c in p.to_array() {
                h.update(&c.to_le_bytes());
            }
        }
    }
    h.update(&(mesh.triangles.len() as u64).to_le_bytes());
    for t in &mesh.triangles {
        for i in t {
            h.update(&i.to_le_bytes());
        }
    }
}

/// blake3 over the format version, each object's name and mesh bytes (positions, normals,
/// triangles), the proxy mesh and the settings.
pub fn inputs_hash(objects: &[(&str, &Mesh)], proxy: Option<&Mesh>, settings: &PrecomputeSettings) -> [u8; 32] {
    let mut h = blake3::Hasher::new();
    h.update(MAGIC);
    h.update(&FORMAT_VERSION.to_le_bytes());
    h.update(&(objects.len() as u64).to_le_bytes());
    for (name, mesh) in objects {
        hash_mesh(&mut h, name, mesh);
    }
    if let Some(p) = proxy {
        hash_mesh(&mut h, "proxy", p);
    }
    // serde_json of plain numbers and enums: a stable text for a given set of values.
    h.update(serde_json::to_string(settings).unwrap_or_default().as_bytes());
    *h.finalize().as_bytes()
}

/// Precomputes every object's SVC and VCF and the proxy field. `progress` gets `(done, total)`
/// over all vertices and sample points.
pub fn precompute(objects: &[(&str, &Mesh)], proxy: Option<&RayScene>, settings: &PrecomputeSettings, progress: Progress) -> Result<PrecomputedCuts, CutsError> {
    let tree = DirectionTree::new(settings.levels)?;
    let sizes: Vec<u64> = objects.iter().map(|(_, m)| (m.positions.len() + settings.vcf.points()) as u64).collect();
    let proxy_points = settings.proxy.map_or(0, |g| g.points() as u64);
    let total = sizes.iter().sum::<u64>() + proxy_points;
    let mut done = 0u64;
    let mut cuts = Vec::with_capacity(objects.len());
    for ((name, mesh), size) in objects.iter().zip(&sizes) {
        cuts.push(ObjectCuts::compute(name, mesh, &tree, &settings.svc, &settings.vcf, &|d, _| progress(done + d, total))?);
        done += size;
    }
    let proxy_field = match (proxy, &settings.proxy) {
        (Some(scene), Some(grid)) => Some(ProxyField::compute(scene, &tree, grid, &|d, _| progress(done + d, total))?),
        _ => None,
    };
    Ok(PrecomputedCuts { inputs_hash: inputs_hash(objects, proxy.map(RayScene::mesh), settings), levels: settings.levels, objects: cuts, proxy: proxy_field })
}

#[derive(Default)]
struct Writer(Vec<u8>);

impl Writer {
    fn u8(&mut self, v: u8) {
        self.0.push(v);
    }
    fn u32(&mut self, v: u32) {
        self.0.extend(v.to_le_bytes());
    }
    fn u64(&mut self, v: u64) {
        self.0.extend(v.to_le_bytes());
    }
    fn f32(&mut self, v: f32) {
        self.0.extend(v.to_le_bytes());
    }
    fn vec3s(&mut self, v: &[Vec3]) {
        self.u64(v.len() as u64);
        v.iter().flat_map(|p| p.to_array()).for_each(|c| self.f32(c));
    }
    fn bank(&mut self, bank: &PackedCuts) {
        let (heights, values) = bank.raw();
        self.u32(bank.levels());
        self.u8(bank.encoding().code());
        self.u64(bank.len() as u64);
        self.u64(bank.node_count() as u64);
        self.0.extend(heights);
        self.0.extend(values);
    }
}

/// Serialises `cuts` to bytes (header and body).
pub fn to_bytes(cuts: &PrecomputedCuts) -> Vec<u8> {
    let mut w = Writer::default();
    w.u32(cuts.levels);
    w.u32(cuts.objects.len() as u32);
    for obj in &cuts.objects {
        w.vec3s(&obj.positions);
        w.vec3s(&obj.svc.normals);
        w.bank(&obj.svc.cuts);
        let (f, s) = (&obj.vcf, &obj.vcf.sampling);
        f.centre.to_array().into_iter().chain([f.radius_m]).for_each(|c| w.f32(c));
        [s.spheres, s.rows, s.cols].into_iter().for_each(|n| w.u32(n));
        [s.inner_factor, s.outer_factor, s.threshold].into_iter().for_each(|c| w.f32(c));
        w.bank(&f.cuts);
    }
    match &cuts.proxy {
        Some(p) => {
            w.u8(1);
            p.grid.min.into_iter().chain(p.grid.max).for_each(|c| w.f32(c));
            p.grid.counts.into_iter().for_each(|n| w.u32(n));
            w.f32(p.grid.threshold);
            w.bank(&p.cuts);
        }
        None => w.u8(0),
    }
    let body = w.0;
    let mut out = Vec::with_capacity(HEADER_BYTES + body.len());
    out.extend(MAGIC);
    out.extend(FORMAT_VERSION.to_le_bytes());
    out.extend(cuts.inputs_hash);
    out.extend((body.len() as u64).to_le_bytes());
    out.extend(blake3::hash(&body).as_bytes());
    out.extend(body);
    out
}

/// Writes `cuts` to `path` through a temporary file and a rename; returns the bytes written.
pub fn write(path: &Path, cuts: &PrecomputedCuts) -> Result<u64, CutsError> {
    let bytes = to_bytes(cuts);
    let io = |source| CutsError::File { path: path.to_owned(), source };
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).map_err(io)?;
    }
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(format!(".tmp{}", std::process::id()));
    let tmp = PathBuf::from(tmp);
    std::fs::write(&tmp, &bytes).map_err(|source| CutsError::File { path: tmp.clone(), source })?;
    std::fs::rename(&tmp, path).map_err(|source| {
        let _ = std::fs::remove_file(&tmp);
        CutsError::File { path: path.to_owned(), source }
    })?;
    Ok(bytes.len() as u64)
}

/// Reads a precompute file.
pub fn read(path: &Path) -> Result<PrecomputedCuts, CutsError> {
    let bytes = std::fs::read(path).map_err(|source| CutsError::File { path: path.to_owned(), source })?;
    from_bytes(path, &bytes)
}

/// Reads `path` when it exists and was made from inputs hashing to `expected`; `None` when it is
/// missing or stale (recompute), an error when it is unreadable or corrupt.
pub fn read_cached(path: &Path, expected: &[u8; 32]) -> Result<Option<PrecomputedCuts>, CutsError> {
    let bytes = match std::fs::read(path) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(source) => return Err(CutsError::File { path: path.to_owned(), source }),
    };
    if bytes.len() >= 44 && bytes[..8] == MAGIC[..] && bytes[12..44] != expected[..] {
        return Ok(None);
    }
    let cuts = from_bytes(path, &bytes)?;
    Ok((cuts.inputs_hash == *expected).then_some(cuts))
}

struct Reader<'a> {
    bytes: &'a [u8],
    pos: usize,
    path: &'a Path,
}

impl<'a> Reader<'a> {
    fn corrupt(&self, reason: String) -> CutsError {
        CutsError::Corrupt { path: self.path.to_owned(), reason }
    }
    fn take(&mut self, n: usize, field: &str) -> Result<&'a [u8], CutsError> {
        let left = self.bytes.len() - self.pos;
        if n > left {
            return Err(self.corrupt(format!("truncated in {field}: needs {n} bytes at offset {}, {left} left", self.pos)));
        }
        self.pos += n;
        Ok(&self.bytes[self.pos - n..self.pos])
    }
    fn u8(&mut self, field: &str) -> Result<u8, CutsError> {
        Ok(self.take(1, field)?[0])
    }
    fn u32(&mut self, field: &str) -> Result<u32, CutsError> {
        let b = self.take(4, field)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }
    fn u64(&mut self, field: &str) -> Result<u64, CutsError> {
        let b = self.take(8, field)?;
        Ok(u64::from_le_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]]))
    }
    fn f32(&mut self, field: &str) -> Result<f32, CutsError> {
        Ok(f32::from_bits(self.u32(field)?))
    }
    fn count(&mut self, field: &str, item_bytes: usize) -> Result<usize, CutsError> {
        let n = self.u64(field)?;
        let left = (self.bytes.len() - self.pos) as u64;
        if n.saturating_mul(item_bytes as u64) > left {
            return Err(self.corrupt(format!("{field} = {n} does not fit the {left} bytes left")));
        }
        Ok(n as usize)
    }
    fn vec3s(&mut self, field: &str) -> Result<Vec<Vec3>, CutsError> {
        let n = self.count(field, 12)?;
        (0..n).map(|_| Ok(Vec3::new(self.f32(field)?, self.f32(field)?, self.f32(field)?))).collect()
    }
    fn bank(&mut self, field: &str, levels: u32) -> Result<PackedCuts, CutsError> {
        let got = self.u32(field)?;
        if got != levels {
            return Err(self.corrupt(format!("{field}: levels {got}, the file says {levels}")));
        }
        let code = self.u8(field)?;
        let encoding = ValueEncoding::from_code(code).ok_or_else(|| self.corrupt(format!("{field}: unknown value encoding {code}")))?;
        // Each node takes at least 4 bits: a node count past twice the bytes left is corrupt.
        let cuts = self.count(field, 0)?;
        let nodes = self.count(field, 0)?;
        if nodes > 2 * (self.bytes.len() - self.pos) || cuts > nodes {
            return Err(self.corrupt(format!("{field}: {cuts} cuts of {nodes} nodes do not fit the {} bytes left", self.bytes.len() - self.pos)));
        }
        let heights = self.take(nodes.div_ceil(2), field)?.to_vec();
        let values = self.take((nodes * encoding.bits()).div_ceil(8), field)?.to_vec();
        PackedCuts::from_parts(levels, encoding, cuts, nodes, heights, values).map_err(|e| self.corrupt(format!("{field}: {e}")))
    }
}

/// Parses the bytes of a precompute file (`path` names it in errors).
pub fn from_bytes(path: &Path, bytes: &[u8]) -> Result<PrecomputedCuts, CutsError> {
    let mut r = Reader { bytes, pos: 0, path };
    if r.take(8, "magic")? != MAGIC {
        return Err(r.corrupt("not a heliar cuts file (magic)".into()));
    }
    let version = r.u32("format version")?;
    if version != FORMAT_VERSION {
        return Err(r.corrupt(format!("format version {version}, this build reads {FORMAT_VERSION}")));
    }
    let mut inputs_hash = [0u8; 32];
    inputs_hash.copy_from_slice(r.take(32, "inputs hash")?);
    let body_len = r.u64("body length")?;
    let body_hash = r.take(32, "body hash")?.to_vec();
    if body_len != (bytes.len() - HEADER_BYTES) as u64 {
        return Err(r.corrupt(format!("body length {body_len} in the header, {} bytes in the file (truncated?)", bytes.len() - HEADER_BYTES)));
    }
    if blake3::hash(&bytes[HEADER_BYTES..]).as_bytes()[..] != body_hash[..] {
        return Err(r.corrupt("body hash mismatch (the file was damaged)".into()));
    }
    let levels = r.u32("levels")?;
    super::tree::check_levels(levels).map_err(|e| r.corrupt(format!("levels: {e}")))?;
    let count = r.u32("object count")? as usize;
    let mut objects = Vec::new();
    for o in 0..count {
        objects.push(read_object(&mut r, o, levels)?);
    }
    let proxy = match r.u8("proxy flag")? {
        0 => None,
        1 => Some(read_proxy(&mut r, levels)?),
        f => return Err(r.corrupt(format!("proxy flag {f}"))),
    };
    if r.pos != bytes.len() {
        return Err(r.corrupt(format!("{} bytes after the proxy field", bytes.len() - r.pos)));
    }
    Ok(PrecomputedCuts { inputs_hash, levels, objects, proxy })
}

fn read_object(r: &mut Reader, o: usize, levels: u32) -> Result<ObjectCuts, CutsError> {
    let positions = r.vec3s(&format!("object {o} positions"))?;
    let normals = r.vec3s(&format!("object {o} normals"))?;
    let svc = r.bank(&format!("object {o} svc"), levels)?;
    if normals.len() != positions.len() || svc.len() != positions.len() {
        return Err(r.corrupt(format!("object {o}: {} positions, {} normals, {} self-visibility cuts", positions.len(), normals.len(), svc.len())));
    }
    let field = format!("object {o} vcf");
    let centre = Vec3::new(r.f32(&field)?, r.f32(&field)?, r.f32(&field)?);
    let radius_m = r.f32(&field)?;
    let (spheres, rows, cols) = (r.u32(&field)?, r.u32(&field)?, r.u32(&field)?);
    let (inner_factor, outer_factor, threshold) = (r.f32(&field)?, r.f32(&field)?, r.f32(&field)?);
    let sampling = VcfSampling { spheres, rows, cols, inner_factor, outer_factor, threshold };
    sampling.check().map_err(|e| r.corrupt(format!("{field}: {e}")))?;
    if !(centre.is_finite() && radius_m > 0.0 && radius_m.is_finite()) {
        return Err(r.corrupt(format!("{field}: centre {centre} radius {radius_m}")));
    }
    let cuts = r.bank(&field, levels)?;
    if cuts.len() != sampling.points() {
        return Err(r.corrupt(format!("{field}: {} cuts for {} sample points", cuts.len(), sampling.points())));
    }
    Ok(ObjectCuts { positions, svc: SelfVisibility { normals, cuts: svc }, vcf: VisibilityCutField { centre, radius_m, sampling, cuts } })
}

fn read_proxy(r: &mut Reader, levels: u32) -> Result<ProxyField, CutsError> {
    let f = "proxy field";
    let (mut min, mut max, mut counts) = ([0.0f32; 3], [0.0f32; 3], [0u32; 3]);
    for v in min.iter_mut().chain(max.iter_mut()) {
        *v = r.f32(f)?;
    }
    for n in &mut counts {
        *n = r.u32(f)?;
    }
    let grid = ProxyGrid { min, max, counts, threshold: r.f32(f)? };
    grid.check().map_err(|e| r.corrupt(format!("{f}: {e}")))?;
    let cuts = r.bank(f, levels)?;
    if cuts.len() != grid.points() {
        return Err(r.corrupt(format!("{f}: {} cuts for {} grid points", cuts.len(), grid.points())));
    }
    Ok(ProxyField::new(grid, cuts))
}
