//! The receivers' `c_v`, `b_v` from the visibility cuts (issue 15 §2 and §5): set from the sky
//! visibility with the objects present instead of a trace, and, while some objects keep their
//! traced transfer (`render::compositor`'s `kept`), forgotten only where a moved object reaches.

use super::{Owed, Receivers};
use crate::geometry::proxy_light::LightLeft;

impl Receivers {
    /// Forgets `c_v` and `b_v` at `pixels` only (objects moved that can reach them, the others
    /// keep theirs: `compositor::kept`): from now on they belong to the visibility cuts
    /// ([`Self::by_cuts`]) and are not traced again with the objects. Owed in order while
    /// replayed frames owe computations, as [`Self::forget_objects`].
    pub fn forget_objects_at(&mut self, pixels: &[u32]) {
        for &p in pixels {
            let Some(b) = self.by_cuts.get_mut(p as usize) else { continue };
            *b = true;
            self.have_with[p as usize] = true;
        }
        if self.owed.is_empty() {
            self.clear_with_at(pixels);
        } else {
            self.owed.push(Owed::ForgetAt(pixels.to_vec()));
        }
    }

    pub(super) fn clear_with_at(&mut self, pixels: &[u32]) {
        for &p in pixels {
            let i = p as usize;
            if i < self.ambient_with.len() {
                self.ambient_with[i] = [1.0, 1.0, 1.0, 0.0];
                self.bounce_with[i] = [0.0; 4];
            }
        }
    }

    /// Those of `pixels` whose `c_v`, `b_v` belong to the visibility cuts
    /// ([`Self::forget_objects_at`]).
    pub fn by_cuts(&self, pixels: &[u32]) -> Vec<u32> {
        pixels.iter().copied().filter(|&p| self.by_cuts.get(p as usize).copied().unwrap_or(false)).collect()
    }

    /// Sets `c_v = c·V_c + E_c` and `b_v = b·V_b + E_b` at `pixels` from what each keeps with the
    /// objects present and what they reflect onto it, `visibility` (the visibility cuts,
    /// `crate::cuts::receivers`, `crate::cuts::receiver_light`) instead of tracing them with the
    /// objects. Pixels whose `c` is not known are left alone.
    pub fn set_with_from_visibility(&mut self, pixels: &[u32], visibility: &[LightLeft]) {
        for (&p, v) in pixels.iter().zip(visibility) {
            let i = p as usize;
            if i >= self.point.len() || !self.have_ambient[i] {
                continue;
            }
            let (c, b, (va, vb), (ca, ba)) = (self.ambient[i], self.bounce[i], (v.ambient, v.bounce), (v.ambient_add, v.bounce_add));
            self.ambient_with[i] = [c[0] * va + ca.x, c[1] * va + ca.y, c[2] * va + ca.z, 1.0];
            self.bounce_with[i] = [b[0] * vb + ba.x, b[1] * vb + ba.y, b[2] * vb + ba.z, 1.0];
            self.have_with[i] = true;
        }
    }

    /// Owes [`Self::set_with_from_visibility`] with `visibility` at `pixels` (a replayed frame's
    /// visibility cuts), after the computations owed before it.
    pub fn owe_visibility(&mut self, pixels: Vec<u32>, visibility: Vec<LightLeft>) {
        self.owed.push(Owed::Visibility { pixels, visibility });
    }
}
