//! Per-frame evaluation of a scene of translated rigid objects (cyberworlds §V-A.4 and §V-B).
//!
//! # How it works
//! For a vertex of object `a` at `x` (its object-frame position plus `a`'s translation) with
//! normal `n`, the visibility is the product (Eq. 4) of
//! - `a`'s self-visibility cut at the vertex (cosine folded in),
//! - for every other object `b`, `b`'s field interpolated at `x − t_b` (§V-A.4), unless `b`'s
//!   bounding sphere lies wholly below the vertex's tangent plane (the paper's culling, §V-B),
//! - the proxy field interpolated at `x`, when there is one;
//!
//! and the radiance is the cut sum of Eq. 3 ([`super::lighting::shade`]). A real receiver point
//! multiplies only the objects' fields, weighted by its lighting
//! ([`super::lighting::sky_visibility`]): the factor by which the objects darken its sky light,
//! which follows them as they move. Vertices run in parallel with rayon; every vertex depends
//! only on its inputs, so the result does not depend on the thread count.

use super::lighting::{ClusteredLighting, ReceiverWeights, Reflectance, shade, sky_visibility};
use super::proxy_field::ProxyField;
use super::svc::{SelfVisibility, SvcSettings, self_visibility_cuts};
use super::tree::DirectionTree;
use super::vcf::{FieldRegion, VcfSampling, VisibilityCutField};
use super::{Cut, CutsError, Progress};
use crate::geometry::Mesh;
use glam::Vec3;
use rayon::prelude::*;

/// The precomputed cuts of one rigid object, in its own frame.
#[derive(Clone, Debug, PartialEq)]
pub struct ObjectCuts {
    /// Vertex positions, object frame.
    pub positions: Vec<Vec3>,
    /// Self-visibility cuts of the vertices.
    pub svc: SelfVisibility,
    /// Visibility cut field of the object.
    pub vcf: VisibilityCutField,
}

impl ObjectCuts {
    /// Precomputes the SVC and the VCF of `mesh` (`what` names it in errors). `progress` gets
    /// `(done, total)` over the vertices and then the field's points.
    pub fn compute(what: &str, mesh: &Mesh, tree: &DirectionTree, svc: &SvcSettings, vcf: &VcfSampling, progress: Progress) -> Result<Self, CutsError> {
        let total = (mesh.positions.len() + vcf.points()) as u64;
        let n = mesh.positions.len() as u64;
        let svc = self_visibility_cuts(what, mesh, tree, svc, &|d, _| progress(d, total))?;
        let vcf = VisibilityCutField::compute(what, mesh, tree, vcf, &|d, _| progress(n + d, total))?;
        Ok(Self { positions: mesh.positions.clone(), svc, vcf })
    }

    /// Bytes of the stored cuts (SVC and VCF).
    pub fn stored_bytes(&self) -> usize {
        self.svc.cuts.stored_bytes() + self.vcf.cuts.stored_bytes()
    }
}

/// One frame's scene: the objects' cuts and translations, the proxy field, the lighting.
#[derive(Clone, Copy, Debug)]
pub struct CutScene<'a> {
    /// The direction tree every cut is over.
    pub tree: &'a DirectionTree,
    /// The environment on the tree.
    pub lighting: &'a ClusteredLighting,
    /// The objects.
    pub objects: &'a [ObjectCuts],
    /// Each object's translation this frame, world frame (object frame + translation = world).
    pub translations: &'a [Vec3],
    /// The static proxy's field, if any.
    pub proxy: Option<&'a ProxyField>,
}

/// A shaded vertex.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VertexShading {
    /// Outgoing radiance toward the viewer (RGB).
    pub radiance: Vec3,
    /// The vertex lay outside the proxy field's box (its lookup was clamped; warn).
    pub outside_proxy_box: bool,
    /// Objects whose fields entered the product (the others were culled).
    pub occluders: usize,
}

/// A real receiver point's sky visibility with the objects present.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReceiverVisibility {
    /// Share of the receiver's sky light the objects leave, in `[0, 1]`.
    pub visibility: f32,
    /// Objects whose fields entered the product.
    pub occluders: usize,
}

impl CutScene<'_> {
    fn check(&self) -> Result<(), CutsError> {
        if self.translations.len() != self.objects.len() {
            return Err(CutsError::Operands(format!("{} objects but {} translations", self.objects.len(), self.translations.len())));
        }
        if let Some(i) = self.translations.iter().position(|t| !t.is_finite()) {
            return Err(CutsError::NonFinitePoint(self.translations[i].to_array()));
        }
        Ok(())
    }

    /// The interpolated fields of every object but `skip` that can reach the point `x` with
    /// normal `n` (bounding sphere not wholly below the tangent plane, §V-B). An object beyond its
    /// field's outermost sphere is left out (its field exactly 1 there), as `super::frame`'s
    /// occluders and the receivers do, instead of clamping to that sphere's cuts.
    pub(crate) fn occluder_cuts(&self, x: Vec3, n: Vec3, skip: Option<usize>) -> Result<Vec<Cut>, CutsError> {
        let mut cuts = Vec::new();
        for (b, obj) in self.objects.iter().enumerate() {
            if Some(b) == skip {
                continue;
            }
            let t = self.translations[b];
            let centre = obj.vcf.centre + t;
            if n != Vec3::ZERO && n.dot(centre - x) < -obj.vcf.radius_m {
                continue;
            }
            if obj.vcf.beyond_reach(x - t) {
                continue;
            }
            let (cut, _region): (Cut, FieldRegion) = obj.vcf.lookup(x - t)?;
            cuts.push(cut);
        }
        Ok(cuts)
    }

    /// The radiance of vertex `vertex` of object `object` seen from direction `view_dir`
    /// (unit, from the vertex toward the viewer).
    pub fn vertex_radiance(&self, object: usize, vertex: usize, surface: &Reflectance, view_dir: Vec3) -> Result<VertexShading, CutsError> {
        self.check()?;
        let obj = self.objects.get(object).ok_or_else(|| CutsError::Operands(format!("object {object} of {}", self.objects.len())))?;
        if vertex >= obj.positions.len() || vertex >= obj.svc.cuts.len() {
            return Err(CutsError::Operands(format!("vertex {vertex} of {}", obj.positions.len())));
        }
        let x = obj.positions[vertex] + self.translations[object];
        let n = obj.svc.normals[vertex];
        let others = self.occluder_cuts(x, n, Some(object))?;
        let mut outside_proxy_box = false;
        let proxy = match self.proxy {
            Some(field) => {
                let (cut, region) = field.lookup(x)?;
                outside_proxy_box = region == FieldRegion::OutsideBox;
                Some(cut)
            }
            None => None,
        };
        let mut views = vec![obj.svc.cuts.view(vertex)];
        views.extend(others.iter().map(Cut::view));
        views.extend(proxy.iter().map(Cut::view));
        let radiance = shade(self.tree, self.lighting, &views, surface, n, view_dir)?;
        Ok(VertexShading { radiance, outside_proxy_box, occluders: others.len() })
    }

    /// Radiances of every vertex of `object` seen from the eye at `eye` (world frame), with the
    /// reflectance of each vertex from `surface`; in parallel.
    pub fn object_radiance(&self, object: usize, surface: &(dyn Fn(usize) -> Reflectance + Sync), eye: Vec3) -> Result<Vec<VertexShading>, CutsError> {
        self.check()?;
        let obj = self.objects.get(object).ok_or_else(|| CutsError::Operands(format!("object {object} of {}", self.objects.len())))?;
        let t = self.translations[object];
        (0..obj.positions.len())
            .into_par_iter()
            .map(|v| {
                let view = (eye - (obj.positions[v] + t)).normalize_or(Vec3::Y);
                self.vertex_radiance(object, v, &surface(v), view)
            })
            .collect()
    }

    /// The sky visibility at a real receiver point `x` (world frame) with the objects present.
    pub fn receiver_visibility(&self, weights: &ReceiverWeights, x: Vec3, n: Vec3) -> Result<ReceiverVisibility, CutsError> {
        self.check()?;
        let cuts = self.occluder_cuts(x, n, None)?;
        let views: Vec<_> = cuts.iter().map(Cut::view).collect();
        Ok(ReceiverVisibility { visibility: sky_visibility(weights, &views)?, occluders: cuts.len() })
    }
}
