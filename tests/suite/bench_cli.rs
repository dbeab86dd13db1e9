//! `heliar bench cuts` (issue 15 §4) and `heliar bench lamps` (issue 16 §5) on their smallest
//! settings: the CSV's header, finite errors, and the errors ordered by the knob where theory
//! orders them.

use crate::common::{heliar_status as heliar, s};
use std::path::PathBuf;

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("heliar-benchcli-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The CSV's header and rows.
fn read_csv(path: &std::path::Path) -> (Vec<String>, Vec<Vec<String>>) {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut lines = text.lines().map(|l| l.split(',').map(str::to_owned).collect::<Vec<_>>());
    let header = lines.next().expect("a header");
    (header, lines.collect())
}

/// Column `name` of `rows` as numbers (panics on a missing column or a non-number).
fn column(header: &[String], rows: &[Vec<String>], name: &str) -> Vec<f64> {
    let i = header.iter().position(|h| h == name).unwrap_or_else(|| panic!("no column {name} in {header:?}"));
    rows.iter().map(|r| r[i].parse::<f64>().unwrap_or_else(|e| panic!("{name} = '{}': {e}", r[i]))).collect()
}

fn finite(v: &[f64], what: &str) {
    assert!(v.iter().all(|x| x.is_finite() && *x >= 0.0), "{what}: {v:?}");
}

#[test]
fn bench_cuts_errors_fall_with_the_field_sampling_and_rise_with_the_threshold() {
    let dir = temp_dir("cuts");
    let header_want = [
        "S", "svc_threshold", "vcf", "vertex_rel_rmse", "receiver_rel_rmse", "precompute_ms", "svc_bytes", "vcf_bytes", "mean_svc_cut", "mean_vcf_cut", "us_per_vertex",
        "us_per_receiver", "frame_ms", "svc_mb_at_27k_vertices",
    ];
    // Field sampling 4 × 4² against 16 × 16² at S = 2^10: the finer field interpolates the
    // sphere's occlusion between fewer metres, so the receivers' error must fall (the library's
    // sweep test measured 8.4 % at 16³; the coarse field misses the contact shadows).
    let csv = dir.join("vcf.csv");
    let plot = dir.join("vcf.svg");
    let (ok, err) = heliar(&["bench", "cuts", "--knob", "vcf", "--values", "4,16", "--levels", "10", "--reference-dirs", "4096", "--csv", s(&csv), "--plot", s(&plot)]);
    assert!(ok, "{err}");
    let (header, rows) = read_csv(&csv);
    assert_eq!(header, header_want);
    assert_eq!(rows.len(), 2);
    assert_eq!(rows[0][2], "4x4x4");
    let receiver = column(&header, &rows, "receiver_rel_rmse");
    finite(&receiver, "receiver error");
    finite(&column(&header, &rows, "vertex_rel_rmse"), "vertex error");
    assert!(receiver[1] < receiver[0], "16³ field {} against 4³ {}", receiver[1], receiver[0]);
    assert!(std::fs::read_to_string(&plot).unwrap().contains("<svg"));
    // Threshold 0 against 0.5: a blunter threshold stops the cuts higher in the tree, so the
    // cuts are smaller and the vertices' error cannot fall.
    let csv = dir.join("threshold.csv");
    let (ok, err) = heliar(&["bench", "cuts", "--knob", "threshold", "--values", "0,0.5", "--levels", "10", "--vcf", "4", "--reference-dirs", "4096", "--csv", s(&csv)]);
    assert!(ok, "{err}");
    let (header, rows) = read_csv(&csv);
    let vertex = column(&header, &rows, "vertex_rel_rmse");
    let cut = column(&header, &rows, "mean_svc_cut");
    finite(&vertex, "vertex error");
    assert!(vertex[1] > vertex[0], "threshold 0.5: {} against 0: {}", vertex[1], vertex[0]);
    assert!(cut[1] < cut[0], "{cut:?}");
    // Bad knob values are refused with the flag named.
    let (ok, err) = heliar(&["bench", "cuts", "--knob", "directions", "--values", "10.5", "--csv", s(&csv)]);
    assert!(!ok && err.contains("--values"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bench_lamps_field_errors_fall_with_the_grid_and_frame_times_are_measured() {
    let dir = temp_dir("lamps");
    // 3×3 against 5×5 filters: below five positions the dual filters do not sum to one over the
    // torch's rim (`curves::spacing_for`), so the exact reconstruction (Eq. 5) of the 3×3 grid
    // must be farther from the true emitter.
    let csv = dir.join("field.csv");
    let (ok, err) = heliar(&["bench", "lamps", "scenes/dusk", "--knob", "field", "--filters", "3,5", "--texels", "16", "--formats", "f32,half", "--emitter-points", "16", "--csv", s(&csv)]);
    assert!(ok, "{err}");
    let (header, rows) = read_csv(&csv);
    assert_eq!(header, ["filters", "texels", "format", "bytes", "exact_rel_rms", "spots_rel_rms", "acquire_ms", "exact_ms", "spots_ms", "gpu_frame_ms", "gpu_lamp_ms"]);
    assert_eq!(rows.len(), 4);
    let exact = column(&header, &rows, "exact_rel_rms");
    finite(&exact, "exact error");
    finite(&column(&header, &rows, "spots_rel_rms"), "spots error");
    finite(&column(&header, &rows, "gpu_frame_ms"), "frame time");
    // rows: 3×3 f32, 3×3 half, 5×5 f32, 5×5 half
    assert!(exact[2] < exact[0], "5x5 {} against 3x3 {}", exact[2], exact[0]);
    // Half floats (2⁻¹¹ relative) move the error by far less than the reconstruction's own.
    assert!((exact[1] - exact[0]).abs() < 0.05 * exact[0], "{exact:?}");
    // 5×5 stores 25/9 as many bytes as 3×3, half floats half as many as f32.
    let bytes = column(&header, &rows, "bytes");
    assert_eq!(bytes, [9.0 * 256.0 * 16.0, 9.0 * 256.0 * 8.0, 25.0 * 256.0 * 16.0, 25.0 * 256.0 * 8.0]);

    // Frame time against far-field lamps: the lamp term runs exactly when there are lamps.
    let csv = dir.join("count.csv");
    let (ok, err) = heliar(&["bench", "lamps", "scenes/dusk", "--knob", "lamp-count", "--lamps", "0,2", "--csv", s(&csv)]);
    assert!(ok, "{err}");
    let (header, rows) = read_csv(&csv);
    assert_eq!(header, ["lamps", "frame_ms", "lamp_ms", "ms_per_lamp", "lamp_term"]);
    finite(&column(&header, &rows, "frame_ms"), "frame time");
    assert_eq!(rows.iter().map(|r| r[4].as_str()).collect::<Vec<_>>(), ["false", "true"]);

    // Frame size: the scene's statue and a generated torus, four lamp sets each.
    let csv = dir.join("size.csv");
    let (ok, err) = heliar(&["bench", "lamps", "scenes/dusk", "--knob", "frame-size", "--sizes", "160x120", "--triangles", "2000", "--csv", s(&csv)]);
    assert!(ok, "{err}");
    let (header, rows) = read_csv(&csv);
    assert_eq!(header, ["object", "triangles", "size", "lamps", "frame_ms", "fps", "lamp_ms", "lamp_term"]);
    assert_eq!(rows.len(), 8);
    finite(&column(&header, &rows, "frame_ms"), "frame time");
    let tris = column(&header, &rows, "triangles");
    assert!((1900.0..=2100.0).contains(&tris[4]), "torus of {} triangles", tris[4]);
    assert!(rows.iter().all(|r| (r[3] == "none") != (r[7] == "true")), "{rows:?}");
    let (ok, err) = heliar(&["bench", "lamps", "scenes/dusk", "--knob", "frame-size", "--sizes", "160by120", "--csv", s(&csv), "--force"]);
    assert!(!ok && err.contains("--sizes"), "{err}");

    // Shadow-map size against the path-traced references: a 32² map misplaces the lamp's shadow
    // edges over the statue and the paving by several centimetres, which shows above the spread
    // of 64²…2048² (25.90–25.98 %, the error being the bounce light the compositor leaves out):
    // measured 26.13 % against 25.91 % for 256²; the rendering is deterministic.
    let csv = dir.join("maps.csv");
    let (ok, err) = heliar(&["bench", "lamps", "scenes/dusk", "--knob", "shadow-map", "--tiles", "32,256", "--csv", s(&csv)]);
    assert!(ok, "{err}");
    let (header, rows) = read_csv(&csv);
    assert_eq!(header, ["tile", "mean_pct", "worst_pct", "object_pct", "shadow_pct", "frame_ms"]);
    let mean = column(&header, &rows, "mean_pct");
    finite(&mean, "composite error");
    assert!(mean[0] >= mean[1], "32² maps {} against 256² {}", mean[0], mean[1]);
    std::fs::remove_dir_all(&dir).ok();
}
