//! Error against cost of the visibility cuts (`heliar::cuts::sweep`): prints the table, writes
//! `cuts_sweep.csv` to the folder given as the first argument (default: the current one), and
//! sizes the paper's setting for comparison with cyberworlds §VI (27,000 vertices → 270 MB;
//! mean cut sizes 428 SVC, 710 VCF).
//!
//! `cargo run --release --example cuts_sweep -- target/cuts`

use heliar::cuts::no_progress;
use heliar::cuts::sweep::{default_sweep_points, sweep_point, sweep_scene, sweep_table, trace_reference};
use heliar::cuts::tree::DirectionTree;
use heliar::cuts::vcf::{VcfSampling, VisibilityCutField};

/// Directions of the traced reference (2^17: its own quadrature error is far below the cuts').
const REFERENCE_DIRS: usize = 1 << 17;
/// The paper's scene size (§VI).
const PAPER_VERTICES: f64 = 27_000.0;

fn main() -> anyhow::Result<()> {
    let out = std::path::PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| ".".into()));
    let scene = sweep_scene();
    println!("sweep scene: torus of {} vertices beside a sphere of {} vertices, {} receivers", scene.a.positions.len(), scene.b.positions.len(), scene.receivers.len());
    let started = std::time::Instant::now();
    let reference = trace_reference(&scene, REFERENCE_DIRS);
    println!("reference: {REFERENCE_DIRS} directions, {:.1} s", started.elapsed().as_secs_f64());
    let mut rows = Vec::new();
    for point in default_sweep_points() {
        let row = sweep_point(&scene, &point, &reference)?;
        println!("{}", sweep_table(&[row]).rows[0].join("  "));
        rows.push(row);
    }
    let table = sweep_table(&rows);
    println!("\n{table}");
    let csv = out.join("cuts_sweep.csv");
    table.write_csv(&csv)?;
    println!("wrote {}", csv.display());

    // The paper's setting: SVC bytes per vertex scaled to 27,000 vertices, and the field of the
    // torus (a more intricate occluder than the sphere).
    let tree = DirectionTree::new(15)?;
    let started = std::time::Instant::now();
    let field = VisibilityCutField::compute("torus", &scene.a, &tree, &VcfSampling::default(), &no_progress)?;
    println!(
        "torus VCF, S = 2^15, 32 × 32²: mean cut {:.1} nodes, {:.2} MB (4-bit heights + 1-bit values; {:.2} MB with 2-byte indices), {:.1} s",
        field.cuts.mean_cut_size(),
        field.cuts.stored_bytes() as f64 / 1e6,
        field.cuts.index_representation_bytes() as f64 / 1e6,
        started.elapsed().as_secs_f64()
    );
    for r in rows.iter().filter(|r| r.point.levels == 15 && r.point.vcf.spheres == 32) {
        let per_vertex = r.svc_bytes as f64 / scene.a.positions.len() as f64;
        println!(
            "SVC threshold {}: mean cut {:.1} nodes, {:.0} bytes per vertex → {:.1} MB for {PAPER_VERTICES} vertices",
            r.point.svc_threshold,
            r.mean_svc_cut,
            per_vertex,
            per_vertex * PAPER_VERTICES / 1e6
        );
    }
    Ok(())
}
