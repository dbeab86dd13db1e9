//! The receivers' sky visibility from the visibility cuts, kept per pixel between frames so that
//! a move evaluates only the receivers the moved objects can change (issue 15 §4, "what to
//! leave out"; cyberworlds §V-B, `../shared/papers/cyberworlds-captured-lighting-cuts.txt`).
//!
//! # How it works
//! A receiver's value `V(x) = Σ_k w_k Π_b V_b(x, ω_k) / Σ_k w_k` (per `c` and `b`, with the light
//! the objects reflect onto it, `crate::cuts::receiver_light`) depends on its own point and
//! normal, the lighting's weights, and the fields of the objects that reach it: an object is left
//! out beyond its field's outermost sphere (`crate::cuts::receivers`, where this is exact: the
//! field is 1 there), and each receiver's weights depend on its own normal only. So when a new
//! frame's field ([`ReceiverField`]) has the same lighting as the one the stored values were
//! evaluated with, a receiver keeps its value unless some object whose pose changed reaches it
//! at its old pose (the value held it; the pixels it left are restored) or at its new one
//! ([`ReceiverField::reaches`]). Objects that did not move count for nothing. Every other case
//! (new lighting, another object count, a field that cannot say) evaluates every receiver asked
//! for. The values kept are those the full evaluation would give, bit for bit, with one
//! exception: the light an unmoved object reflects onto a receiver
//! (`crate::cuts::receiver_light::ObjectsSeen`) can change when another object moves (its shadow
//! on it); a receiver the moved object does not reach keeps the old light until it is evaluated.

pub use crate::geometry::proxy_light::LightLeft;
pub use crate::render::frame::CutReceiverCounts;
use glam::Vec3;
use std::sync::Arc;

/// The receivers' sky visibility with the objects present at one frame's poses, from the
/// objects' visibility cut fields (`run::motion_cuts`; a closure `Fn(&[(Vec3, Vec3)]) -> Vec<f32>`
/// is one that cannot say what it depends on, so every receiver is evaluated each time).
pub trait ReceiverField: Send + Sync {
    /// The share of its light (`c` and `b`) left at `surfaces[i]` (point, normal; world frame),
    /// in `[0, 1]`, for each `i` of `which`, in that order. A receiver's value must not depend
    /// on which others are asked for.
    fn visibility(&self, surfaces: &[(Vec3, Vec3)], which: &[usize]) -> Vec<LightLeft>;

    /// Per object, its pose this frame as bits (equal bits: the same field in the same place);
    /// `None`: not known, nothing is kept.
    fn pose_keys(&self) -> Option<Vec<[u32; 12]>> {
        None
    }

    /// A key of the lighting the weights come from (equal keys: the same weights while both
    /// fields are alive).
    fn lighting_key(&self) -> usize {
        0
    }

    /// True when object `b`'s field can change the value at `x` (world frame); false only where
    /// its field is exactly 1.
    fn reaches(&self, _b: usize, _x: Vec3) -> bool {
        true
    }
}

impl<F> ReceiverField for F
where
    F: Fn(&[(Vec3, Vec3)]) -> Vec<f32> + Send + Sync,
{
    fn visibility(&self, surfaces: &[(Vec3, Vec3)], which: &[usize]) -> Vec<LightLeft> {
        let all = self(surfaces);
        which.iter().map(|&i| LightLeft::both(all.get(i).copied().unwrap_or(1.0))).collect()
    }
}

/// The stored values and the field they were evaluated with (module docs).
#[derive(Default)]
pub(super) struct CutCache {
    basis: Option<Arc<dyn ReceiverField>>,
    /// Per pixel, its stored visibility (NaN: none).
    values: Vec<LightLeft>,
}

fn same(a: &Arc<dyn ReceiverField>, b: &Arc<dyn ReceiverField>) -> bool {
    std::ptr::eq(Arc::as_ptr(a) as *const (), Arc::as_ptr(b) as *const ())
}

impl CutCache {
    /// Forgets every stored value (the cuts stopped serving).
    pub(super) fn clear(&mut self) {
        self.basis = None;
        self.values.clear();
    }

    /// The objects whose field may differ between the stored values' field and `field`;
    /// `None`: everything may (module docs).
    fn changed(&self, field: &Arc<dyn ReceiverField>) -> Option<Vec<usize>> {
        let basis = self.basis.as_ref()?;
        if same(basis, field) {
            return Some(Vec::new());
        }
        let (old, new) = (basis.pose_keys()?, field.pose_keys()?);
        if old.len() != new.len() || basis.lighting_key() != field.lighting_key() {
            return None;
        }
        Some((0..new.len()).filter(|&b| old[b] != new[b]).collect())
    }

    /// `field`'s visibility at `pixels`, whose surfaces are `surfaces`: evaluated where a moved
    /// object reaches at its old or new pose or nothing is stored, the stored value elsewhere.
    pub(super) fn visibility(&mut self, field: &Arc<dyn ReceiverField>, pixels: &[u32], surfaces: &[(Vec3, Vec3)]) -> (Vec<LightLeft>, CutReceiverCounts) {
        let changed = self.changed(field);
        if changed.is_none() {
            self.values.clear();
        }
        if let Some(&top) = pixels.iter().max()
            && self.values.len() <= top as usize
        {
            self.values.resize(top as usize + 1, LightLeft::both(f32::NAN));
        }
        let basis = self.basis.clone();
        let moved = changed.unwrap_or_default();
        let reached = |x: Vec3| moved.iter().any(|&b| basis.as_ref().is_some_and(|o| o.reaches(b, x)) || field.reaches(b, x));
        let need: Vec<usize> = pixels.iter().zip(surfaces).enumerate().filter(|(_, (p, (x, _)))| self.values[**p as usize].ambient.is_nan() || reached(*x)).map(|(i, _)| i).collect();
        let fresh = field.visibility(surfaces, &need);
        for (&i, v) in need.iter().zip(fresh) {
            self.values[pixels[i] as usize] = v;
        }
        self.basis = Some(field.clone());
        let counts = CutReceiverCounts { evaluated: need.len(), reused: pixels.len() - need.len() };
        (pixels.iter().map(|&p| self.values[p as usize]).collect(), counts)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicUsize, Ordering};

    /// One disc-shaped "object" of radius 1 m at `at` on the x axis: visibility 0.5 inside, 1
    /// beyond; counts the receivers it evaluates.
    struct Disc {
        at: f32,
        light: usize,
        asked: AtomicUsize,
    }

    impl ReceiverField for Disc {
        fn visibility(&self, surfaces: &[(Vec3, Vec3)], which: &[usize]) -> Vec<LightLeft> {
            self.asked.fetch_add(which.len(), Ordering::Relaxed);
            which.iter().map(|&i| LightLeft::both(if self.reaches(0, surfaces[i].0) { 0.5 } else { 1.0 })).collect()
        }
        fn pose_keys(&self) -> Option<Vec<[u32; 12]>> {
            let mut k = [0; 12];
            k[9] = self.at.to_bits();
            Some(vec![k])
        }
        fn lighting_key(&self) -> usize {
            self.light
        }
        fn reaches(&self, _b: usize, x: Vec3) -> bool {
            (x.x - self.at).abs() <= 1.0
        }
    }

    fn disc(at: f32, light: usize) -> Arc<dyn ReceiverField> {
        Arc::new(Disc { at, light, asked: AtomicUsize::new(0) })
    }

    /// A move evaluates the receivers within reach at the old and the new place only (the ones
    /// left are restored to 1), the rest keep their values; the same field again evaluates
    /// nothing; new lighting evaluates all. Values always equal a full evaluation.
    #[test]
    fn a_move_evaluates_only_what_the_object_reaches_then_and_now() {
        // Receivers every 0.5 m from x = 0 to 10.
        let surfaces: Vec<(Vec3, Vec3)> = (0..21).map(|i| (Vec3::new(i as f32 * 0.5, 0.0, 0.0), Vec3::Y)).collect();
        let pixels: Vec<u32> = (0..21).map(|i| 100 + 3 * i).collect();
        let full = |f: &Arc<dyn ReceiverField>| f.visibility(&surfaces, &(0..21).collect::<Vec<_>>());
        let mut cache = CutCache::default();
        let a = disc(2.0, 1);
        let (v, n) = cache.visibility(&a, &pixels, &surfaces);
        assert_eq!((v, n), (full(&a), CutReceiverCounts { evaluated: 21, reused: 0 }));
        // Moved 0.5 m: reach then 1..3 m, now 1.5..3.5 m: 6 receivers (1, 1.5, …, 3.5 m).
        let b = disc(2.5, 1);
        let (v, n) = cache.visibility(&b, &pixels, &surfaces);
        assert_eq!((v, n), (full(&b), CutReceiverCounts { evaluated: 6, reused: 15 }));
        let (_, n) = cache.visibility(&b, &pixels, &surfaces);
        assert_eq!(n, CutReceiverCounts { evaluated: 0, reused: 21 });
        // Jumped 5 m: both reaches, 5 + 5 receivers; the old place is restored to 1.
        let c = disc(7.5, 1);
        let (v, n) = cache.visibility(&c, &pixels, &surfaces);
        assert_eq!((v, n), (full(&c), CutReceiverCounts { evaluated: 10, reused: 11 }));
        // New lighting: every receiver.
        let d = disc(7.5, 2);
        let (_, n) = cache.visibility(&d, &pixels, &surfaces);
        assert_eq!(n.evaluated, 21);
        // A closure cannot say what it depends on: every receiver when it arrives (asked again,
        // the same field keeps its values).
        let e: Arc<dyn ReceiverField> = Arc::new(|s: &[(Vec3, Vec3)]| vec![0.25; s.len()]);
        let (v, n) = cache.visibility(&e, &pixels, &surfaces);
        assert_eq!((v, n.evaluated), (vec![LightLeft::both(0.25); 21], 21));
        let f: Arc<dyn ReceiverField> = Arc::new(|s: &[(Vec3, Vec3)]| vec![0.75; s.len()]);
        let (v, n) = cache.visibility(&f, &pixels, &surfaces);
        assert_eq!((v, n.evaluated), (vec![LightLeft::both(0.75); 21], 21));
    }
}
