//! Error against cost of the visibility cuts (`heliar::cuts::sweep`): prints the table and
//! writes `cuts_sweep.csv` to the folder given as the first argument (default: the current one).
//!
//! `cargo run --release --example cuts_sweep -- target/cuts`

use heliar::cuts::sweep::{default_sweep_points, sweep_point, sweep_scene, sweep_table, trace_reference};

/// Directions of the traced reference (2^17: its own quadrature error is far below the cuts').
const REFERENCE_DIRS: usize = 1 << 17;

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
    Ok(())
}
