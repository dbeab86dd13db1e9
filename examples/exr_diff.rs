//! Prints where two EXR images differ (pixel count, bounding box, largest relative difference).
//! `cargo run --example exr_diff -- a.exr b.exr`
fn main() -> anyhow::Result<()> {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let (x, y) = (heliar::io::image::LinearImage::read_exr(std::path::Path::new(&a[0]))?, heliar::io::image::LinearImage::read_exr(std::path::Path::new(&a[1]))?);
    let (mut n, mut worst, mut bb) = (0usize, 0f32, (u32::MAX, u32::MAX, 0u32, 0u32));
    for (i, (p, q)) in x.data.iter().zip(&y.data).enumerate() {
        if p != q {
            n += 1;
            let (px, py) = (i as u32 % x.width, i as u32 / x.width);
            bb = (bb.0.min(px), bb.1.min(py), bb.2.max(px), bb.3.max(py));
            for c in 0..3 {
                worst = worst.max((p[c] - q[c]).abs() / p[c].abs().max(q[c].abs()).max(1e-6));
            }
        }
    }
    println!("{n} pixels differ, box {bb:?}, worst relative {worst}");
    Ok(())
}
