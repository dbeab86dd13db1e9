//! Prints where two EXR images differ (pixel count, bounding box, largest relative difference).
//! `cargo run --example exr_diff -- a.exr b.exr [x]`: with `x`, also per side of the column `x`
//! (left, right) the differing pixels' count and the relative RMSE of their luminance,
//! `sqrt(Σ(b − a)² / Σa²)` over them.
fn main() -> anyhow::Result<()> {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let (x, y) = (heliar::io::image::LinearImage::read_exr(std::path::Path::new(&a[0]))?, heliar::io::image::LinearImage::read_exr(std::path::Path::new(&a[1]))?);
    let split: Option<u32> = a.get(2).and_then(|s| s.parse().ok());
    let lum = |p: &[f32; 3]| 0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64;
    let (mut n, mut worst, mut bb) = (0usize, 0f32, (u32::MAX, u32::MAX, 0u32, 0u32));
    let mut sides = [(0usize, 0f64, 0f64); 2];
    for (i, (p, q)) in x.data.iter().zip(&y.data).enumerate() {
        if p != q {
            n += 1;
            let (px, py) = (i as u32 % x.width, i as u32 / x.width);
            bb = (bb.0.min(px), bb.1.min(py), bb.2.max(px), bb.3.max(py));
            for c in 0..3 {
                worst = worst.max((p[c] - q[c]).abs() / p[c].abs().max(q[c].abs()).max(1e-6));
            }
            let s = &mut sides[usize::from(split.is_some_and(|s| px >= s))];
            s.0 += 1;
            s.1 += (lum(q) - lum(p)).powi(2);
            s.2 += lum(p).powi(2);
        }
    }
    println!("{n} pixels differ, box {bb:?}, worst relative {worst}");
    if let Some(s) = split {
        for (name, (k, d, r)) in [("left", sides[0]), ("right", sides[1])] {
            println!("{name} of x = {s}: {k} differ, relative RMSE over them {:.5}", (d / r.max(1e-30)).sqrt());
        }
    }
    Ok(())
}
