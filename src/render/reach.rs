//! Which real occluders can cast a shadow that matters to the virtual objects.
//!
//! A real occluder matters when its shadow can reach a virtual object (the sun term there must
//! be zeroed) or a real surface where a virtual object's shadow can also fall (Jensen §3.2
//! step 2: the virtual shadow must not darken what is already in real shadow). Only the parts
//! of the proxy that pass this test get a real shadow volume; when none does, the real-volume
//! pass is skipped.
//!
//! # How it works
//! Everything is projected along the sun direction `l`: a point becomes `(x, d)` with `x` its
//! 2D position in a plane perpendicular to `l` and `d = p·l` its height toward the sun. A
//! triangle `T` that is not parallel to `l` covers a 2D triangle `P_T` with a linear height
//! `d_T(x)`; its shadow is `{(x, d): x ∈ P_T, d < d_T(x)}`. A virtual object's bounding box `V`
//! covers the convex hull `H_V` of its projected corners, between a lower envelope (the maximum
//! of its faces turned away from the sun) and an upper one (the minimum of its faces turned
//! toward it). Then, with a small tolerance `ε`:
//!
//! - `T` shadows `V` if some `x ∈ P_T ∩ H_V` has every lower face of `V` below `d_T(x) − ε`;
//! - `T` shadows a real receiver triangle `R ≠ T` where `V`'s shadow can fall if some
//!   `x ∈ P_T ∩ H_V ∩ P_R` has `d_R(x) < d_T(x) − ε` and `d_R(x)` below every upper face of `V`.
//!
//! Every condition is a half-plane in `x`, so each test is a convex polygon clipped by a few
//! half-planes and checked for area. The test is conservative: it can keep an occluder whose
//! shadow only grazes the region, never drop one whose shadow reaches it.

use super::occluder::Occluder;
use glam::{DVec2, DVec3, Vec3};

/// Height tolerance (metres): a receiver must lie this far below an occluder along the sun to
/// count as shadowed by it. Larger than float noise on coplanar faces, far below any real gap.
const HEIGHT_EPS_M: f64 = 1e-3;
/// Smallest overlap area (m², perpendicular to the sun) that counts.
const AREA_EPS_M2: f64 = 1e-6;

type Poly = Vec<DVec2>;

/// Coordinates perpendicular to the sun and along it.
struct LightFrame {
    u: DVec3,
    w: DVec3,
    l: DVec3,
}

impl LightFrame {
    fn new(l: DVec3) -> Self {
        let helper = if l.x.abs() < 0.9 { DVec3::X } else { DVec3::Y };
        let u = l.cross(helper).normalize();
        Self { u, w: l.cross(u), l }
    }
    fn project(&self, p: DVec3) -> (DVec2, f64) {
        (DVec2::new(p.dot(self.u), p.dot(self.w)), p.dot(self.l))
    }
}

/// A linear height `d(x) = g·x + h`.
#[derive(Clone, Copy, Debug)]
struct Height {
    g: DVec2,
    h: f64,
}

/// Keeps the part of `poly` where `a·x ≤ c` (Sutherland–Hodgman, one edge).
fn clip(poly: &[DVec2], a: DVec2, c: f64) -> Poly {
    let mut out = Vec::with_capacity(poly.len() + 1);
    for i in 0..poly.len() {
        let (p, q) = (poly[i], poly[(i + 1) % poly.len()]);
        let (fp, fq) = (a.dot(p) - c, a.dot(q) - c);
        if fp <= 0.0 {
            out.push(p);
        }
        if (fp < 0.0) != (fq < 0.0) && fp != fq {
            out.push(p + (q - p) * (fp / (fp - fq)));
        }
    }
    out
}

/// `poly` clipped by `d_a(x) ≤ d_b(x) − margin`.
fn clip_below(poly: &[DVec2], a: Height, b: Height, margin: f64) -> Poly {
    clip(poly, a.g - b.g, b.h - a.h - margin)
}

/// `poly` clipped to the convex counter-clockwise polygon `by`.
fn clip_convex(poly: &[DVec2], by: &[DVec2]) -> Poly {
    let mut out = poly.to_vec();
    for i in 0..by.len() {
        if out.is_empty() {
            break;
        }
        let (p, q) = (by[i], by[(i + 1) % by.len()]);
        let e = q - p;
        // Inside: cross(e, x − p) ≥ 0  ⇔  (e.y, −e.x)·x ≤ (e.y, −e.x)·p.
        let a = DVec2::new(e.y, -e.x);
        out = clip(&out, a, a.dot(p));
    }
    out
}

fn area(poly: &[DVec2]) -> f64 {
    let mut s = 0.0;
    for i in 0..poly.len() {
        s += poly[i].perp_dot(poly[(i + 1) % poly.len()]);
    }
    0.5 * s
}

/// A triangle seen along the sun: counter-clockwise 2D corners and its height; `None` when it
/// is parallel to the sun.
fn project_triangle(f: &LightFrame, corners: [Vec3; 3]) -> Option<(Poly, Height)> {
    let p = corners.map(|c| f.project(c.as_dvec3()));
    let (e1, e2) = (p[1].0 - p[0].0, p[2].0 - p[0].0);
    let det = e1.perp_dot(e2);
    if det.abs() < 1e-12 {
        return None;
    }
    let (dd1, dd2) = (p[1].1 - p[0].1, p[2].1 - p[0].1);
    // Solve g·e1 = dd1, g·e2 = dd2.
    let g = DVec2::new(dd1 * e2.y - dd2 * e1.y, dd2 * e1.x - dd1 * e2.x) / det;
    let h = p[0].1 - g.dot(p[0].0);
    let poly = if det > 0.0 { vec![p[0].0, p[1].0, p[2].0] } else { vec![p[0].0, p[2].0, p[1].0] };
    Some((poly, Height { g, h }))
}

/// A virtual object's box seen along the sun.
struct BoxShadow {
    hull: Poly,
    lower: Vec<Height>,
    upper: Vec<Height>,
}

fn convex_hull(mut pts: Vec<DVec2>) -> Poly {
    pts.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    pts.dedup();
    if pts.len() < 3 {
        return pts;
    }
    let mut hull: Vec<DVec2> = Vec::with_capacity(2 * pts.len());
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &DVec2>> = if pass == 0 { Box::new(pts.iter()) } else { Box::new(pts.iter().rev()) };
        for &p in iter {
            while hull.len() >= start + 2 && (hull[hull.len() - 1] - hull[hull.len() - 2]).perp_dot(p - hull[hull.len() - 2]) <= 0.0 {
                hull.pop();
            }
            hull.push(p);
        }
        hull.pop();
    }
    hull
}

impl BoxShadow {
    fn new(f: &LightFrame, lo: DVec3, hi: DVec3) -> Self {
        let corners: Vec<DVec3> = (0..8).map(|i| DVec3::new([lo.x, hi.x][i & 1], [lo.y, hi.y][(i >> 1) & 1], [lo.z, hi.z][(i >> 2) & 1])).collect();
        let hull = convex_hull(corners.iter().map(|&c| f.project(c).0).collect());
        let (mut lower, mut upper) = (Vec::new(), Vec::new());
        for axis in 0..3 {
            for (sign, p0) in [(-1.0, lo), (1.0, hi)] {
                let mut n = DVec3::ZERO;
                n[axis] = sign;
                let nl = n.dot(f.l);
                if nl.abs() < 1e-12 {
                    continue;
                }
                // n·p = n·p0 with p = x1·u + x2·w + d·l.
                let hgt = Height { g: -DVec2::new(n.dot(f.u), n.dot(f.w)) / nl, h: n.dot(p0) / nl };
                if nl > 0.0 { upper.push(hgt) } else { lower.push(hgt) }
            }
        }
        Self { hull, lower, upper }
    }
}

fn bbox(poly: &[DVec2]) -> (DVec2, DVec2) {
    poly.iter().fold((DVec2::splat(f64::MAX), DVec2::splat(f64::MIN)), |(a, b), p| (a.min(*p), b.max(*p)))
}

fn overlap(a: (DVec2, DVec2), b: (DVec2, DVec2)) -> bool {
    a.0.x <= b.1.x && b.0.x <= a.1.x && a.0.y <= b.1.y && b.0.y <= a.1.y
}

/// Indices of the components of the real proxy `proxy` whose shadow can matter to a virtual
/// object with one of the bounding boxes `virtual_bounds`, for the sun direction `sun` (unit,
/// toward the sun). Empty when none can.
pub fn relevant_components(proxy: &Occluder, virtual_bounds: &[(Vec3, Vec3)], sun: Vec3) -> Vec<usize> {
    if virtual_bounds.is_empty() || proxy.faces.is_empty() {
        return Vec::new();
    }
    let f = LightFrame::new(sun.as_dvec3().normalize());
    let tris: Vec<Option<(Poly, Height, (DVec2, DVec2))>> = proxy
        .faces
        .iter()
        .map(|face| {
            let corners = face.map(|i| proxy.positions[i as usize]);
            project_triangle(&f, corners).map(|(p, h)| {
                let b = bbox(&p);
                (p, h, b)
            })
        })
        .collect();
    let boxes: Vec<(BoxShadow, (DVec2, DVec2))> = virtual_bounds
        .iter()
        .map(|(lo, hi)| {
            let b = BoxShadow::new(&f, lo.as_dvec3(), hi.as_dvec3());
            let bb = bbox(&b.hull);
            (b, bb)
        })
        .collect();
    let mut out = Vec::new();
    for (ci, comp) in proxy.components.iter().enumerate() {
        let matters = comp.faces.clone().any(|t| {
            let Some((pt, ht, bt)) = &tris[t] else { return false };
            boxes.iter().any(|(v, bv)| {
                if !overlap(*bt, *bv) {
                    return false;
                }
                let base = clip_convex(pt, &v.hull);
                if area(&base) <= AREA_EPS_M2 {
                    return false;
                }
                // T shadows the box.
                let mut a = base.clone();
                for low in &v.lower {
                    a = clip_below(&a, *low, *ht, HEIGHT_EPS_M);
                }
                if area(&a) > AREA_EPS_M2 {
                    return true;
                }
                // T shadows a real receiver where the box's shadow can fall.
                let bb = bbox(&base);
                tris.iter().enumerate().any(|(r, rt)| {
                    let Some((pr, hr, br)) = rt else { return false };
                    if r == t || !overlap(bb, *br) {
                        return false;
                    }
                    let mut q = clip_convex(&base, pr);
                    q = clip_below(&q, *hr, *ht, HEIGHT_EPS_M);
                    for up in &v.upper {
                        q = clip_below(&q, *hr, *up, 0.0);
                    }
                    area(&q) > AREA_EPS_M2
                })
            })
        });
        if matters {
            out.push(ci);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Material, Mesh};

    /// Ground, a free-standing wall (closed box) and nothing else.
    fn yard() -> Occluder {
        let mut m = Mesh::default();
        let mat = m.add_material(Material::diffuse("g", [0.5; 3]));
        let g = m.add_node("ground", true);
        let w = m.add_node("wall", false);
        m.push_quad(Vec3::new(-20.0, 0.0, -20.0), Vec3::Z * 40.0, Vec3::X * 40.0, g, mat);
        m.push_box(Vec3::new(-3.2, 0.0, -1.5), Vec3::new(-2.8, 2.4, 1.5), w, mat, false);
        Occluder::new(&m, "yard")
    }

    fn sun() -> Vec3 {
        Vec3::new(-0.486, 0.756, 0.437).normalize()
    }

    fn wall_component(o: &Occluder) -> usize {
        o.components.iter().position(|c| c.nodes.contains(&"wall".to_string())).unwrap()
    }

    #[test]
    fn wall_matters_when_its_shadow_reaches_the_object_or_the_object_shadow() {
        let o = yard();
        let wall = wall_component(&o);
        // In the wall's shadow (east of it, the sun is to the west).
        let near = (Vec3::new(-2.3, 0.0, -0.5), Vec3::new(-1.9, 0.8, -0.1));
        assert_eq!(relevant_components(&o, &[near], sun()), vec![wall]);
        // Far out in the open, to the south-west (toward the sun): neither its shadow nor the
        // object reach each other; the ground never matters (nothing is below it).
        let open = (Vec3::new(-8.0, 0.0, 8.0), Vec3::new(-7.5, 1.0, 8.5));
        assert!(relevant_components(&o, &[open], sun()).is_empty());
        // Beside the wall on the sunny side, but its own shadow (going north-east) crosses the
        // wall's shadow on the ground: the wall matters for the overlap.
        let west = (Vec3::new(-4.5, 0.0, -0.2), Vec3::new(-4.0, 2.0, 0.3));
        assert_eq!(relevant_components(&o, &[west], sun()), vec![wall]);
    }

    #[test]
    fn sun_parallel_to_wall_faces_and_no_objects() {
        let o = yard();
        assert!(relevant_components(&o, &[], sun()).is_empty());
        // Sun straight overhead: the wall shadows only its own footprint; an object beside it
        // is untouched.
        let beside = (Vec3::new(-2.0, 0.0, -0.5), Vec3::new(-1.5, 1.0, 0.5));
        assert!(relevant_components(&o, &[beside], Vec3::Y).is_empty());
    }
}
