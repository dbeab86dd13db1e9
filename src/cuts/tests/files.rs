//! The precompute file: round trips, cache keys, damaged files; and the sweep on a small scene.

use crate::cuts::file::{PrecomputeSettings, from_bytes, inputs_hash, precompute, read, read_cached, to_bytes, write};
use crate::cuts::proxy_field::ProxyGrid;
use crate::cuts::shapes::{icosphere, wall};
use crate::cuts::svc::SvcSettings;
use crate::cuts::sweep::{SweepPoint, sweep, sweep_scene, sweep_table};
use crate::cuts::vcf::VcfSampling;
use crate::cuts::{CutsError, no_progress};
use crate::geometry::raycast::RayScene;
use glam::Vec3;
use std::path::Path;

fn settings() -> PrecomputeSettings {
    PrecomputeSettings {
        levels: 8,
        svc: SvcSettings::default(),
        vcf: VcfSampling { spheres: 2, rows: 4, cols: 6, ..VcfSampling::default() },
        proxy: Some(ProxyGrid { min: [-1.0, 0.0, 0.5], max: [1.0, 1.0, 1.5], counts: [2, 3, 2], threshold: 0.0 }),
    }
}

fn temp_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("heliar-cuts-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("a temporary folder");
    dir
}

fn expect_corrupt(result: Result<impl std::fmt::Debug, CutsError>, path: &Path, what: &str) {
    match result {
        Err(e @ CutsError::Corrupt { .. }) => {
            let msg = e.to_string();
            assert!(msg.contains(&path.display().to_string()) && msg.contains(what), "{msg}");
        }
        other => panic!("expected a corrupt-file error about {what}, got {other:?}"),
    }
}

#[test]
fn precompute_files_round_trip_and_key_their_inputs() {
    let (a, b) = (icosphere(Vec3::ZERO, 0.5, 1), icosphere(Vec3::new(0.2, 0.0, 0.0), 0.3, 0));
    let proxy = RayScene::new(wall(-2.0, 2.0, 2.0, 0.0));
    let s = settings();
    let cuts = precompute(&[("a", &a), ("b", &b)], Some(&proxy), &s, &no_progress).expect("valid inputs");
    let dir = temp_dir("round-trip");
    let path = dir.join("cuts.bin");
    let written = write(&path, &cuts).expect("writable");
    assert_eq!(written, std::fs::metadata(&path).expect("written").len());
    assert_eq!(read(&path).expect("readable"), cuts);
    // No temporary file is left beside it.
    assert_eq!(std::fs::read_dir(&dir).expect("listable").count(), 1);
    // The cache: the same inputs hit, any change misses, a missing file misses.
    let key = inputs_hash(&[("a", &a), ("b", &b)], Some(proxy.mesh()), &s);
    assert_eq!(key, cuts.inputs_hash);
    assert!(read_cached(&path, &key).expect("readable").is_some());
    let mut moved = a.clone();
    moved.positions[0].x += 1e-3;
    assert_ne!(inputs_hash(&[("a", &moved), ("b", &b)], Some(proxy.mesh()), &s), key);
    let finer = PrecomputeSettings { levels: 9, ..s.clone() };
    let other = inputs_hash(&[("a", &a), ("b", &b)], Some(proxy.mesh()), &finer);
    assert_ne!(other, key);
    assert!(read_cached(&path, &other).expect("readable").is_none());
    assert!(read_cached(&dir.join("missing.bin"), &key).expect("no file").is_none());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn damaged_files_give_errors_naming_the_file() {
    let a = icosphere(Vec3::ZERO, 0.5, 0);
    let s = PrecomputeSettings { proxy: None, ..settings() };
    let cuts = precompute(&[("a", &a)], None, &s, &no_progress).expect("valid inputs");
    let bytes = to_bytes(&cuts);
    let path = Path::new("scene/cuts.bin");
    assert_eq!(from_bytes(path, &bytes).expect("intact"), cuts);
    expect_corrupt(from_bytes(path, &bytes[..bytes.len() - 3]), path, "truncated");
    expect_corrupt(from_bytes(path, &bytes[..20]), path, "truncated in inputs hash");
    expect_corrupt(from_bytes(path, &[]), path, "magic");
    let mut flipped = bytes.clone();
    let last = flipped.len() - 1;
    flipped[last] ^= 0x40;
    expect_corrupt(from_bytes(path, &flipped), path, "body hash");
    let mut version = bytes.clone();
    version[8] = 99;
    expect_corrupt(from_bytes(path, &version), path, "format version 99");
    let mut magic = bytes;
    magic[0] = b'X';
    expect_corrupt(from_bytes(path, &magic), path, "magic");
    // Forged counts with a valid body hash: a clear error, no huge allocation. The first bank's
    // cut count sits after the header (84 bytes), levels and object count (8), 12 positions and
    // 12 normals (2 × 152) and the bank's levels and encoding (5).
    for (offset, what) in [(401, "cuts of"), (409, "cuts of")] {
        let mut forged = to_bytes(&cuts);
        forged[offset..offset + 8].copy_from_slice(&u64::MAX.to_le_bytes());
        let hash = *blake3::hash(&forged[84..]).as_bytes();
        forged[52..84].copy_from_slice(&hash);
        expect_corrupt(from_bytes(path, &forged), path, what);
    }
    // A file that cannot be opened names its path.
    let err = read(Path::new("/nonexistent/heliar/cuts.bin")).expect_err("no such file");
    assert!(err.to_string().contains("/nonexistent/heliar/cuts.bin"), "{err}");
}

#[test]
fn the_sweep_orders_its_settings_by_error() {
    // Coarse and fine field sampling and SVC thresholds on the sweep scene at S = 2^10: finer
    // sampling must lower the receivers' error, a coarse threshold must raise the vertices'.
    let scene = sweep_scene();
    let vcf = |n: u32| VcfSampling { spheres: n, rows: n, cols: n, ..VcfSampling::default() };
    let points = [
        SweepPoint { levels: 10, svc_threshold: 0.0, vcf: vcf(16) },
        SweepPoint { levels: 10, svc_threshold: 0.0, vcf: vcf(4) },
        SweepPoint { levels: 10, svc_threshold: 0.5, vcf: vcf(16) },
    ];
    let rows = sweep(&scene, &points, 1 << 12).expect("valid scene");
    let table = sweep_table(&rows);
    assert_eq!(table.rows.len(), 3);
    let [fine, coarse, blunt] = [rows[0], rows[1], rows[2]];
    assert!(fine.receiver_rel_rmse < coarse.receiver_rel_rmse, "{} vs {}", fine.receiver_rel_rmse, coarse.receiver_rel_rmse);
    assert!(fine.vertex_rel_rmse < blunt.vertex_rel_rmse, "{} vs {}", fine.vertex_rel_rmse, blunt.vertex_rel_rmse);
    assert!(blunt.mean_svc_cut < fine.mean_svc_cut);
    // At S = 2^10 with 16³ field points the vertices came within 0.6 % and the contact shadows
    // within 8.4 % of the traced reference; allow 2 % and 15 % (the example sweeps finer).
    assert!(fine.vertex_rel_rmse < 0.02, "{}", fine.vertex_rel_rmse);
    assert!(fine.receiver_rel_rmse < 0.15, "{}", fine.receiver_rel_rmse);
}
