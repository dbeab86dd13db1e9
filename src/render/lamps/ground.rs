//! The virtual objects' lamp shadows on the real receivers (issue 16 §3, "virtual objects' lamp
//! shadows on real ground"): the composite's differential darkening extended with the lamps'
//! share of each real pixel's irradiance. Granier, Goesele, Heidrich and Seidel 2003
//! (`../shared/papers/granier-2003-complex-light-sources.txt`) §3.2 and §4 give the spots and
//! their shadow maps; the darkening is Debevec 1998's differential rendering, as today's.
//!
//! # How it works
//! - **The ratio.** At a real pixel whose proxy point `x` has normal `n`, the model of the
//!   footage is `L₀ = E_rest + Σ_j k·E_j·V_j^proxy` and with the objects standing in the scene
//!   `L₁ = E_rest,v + Σ_j k·E_j·V_j^proxy·V_j^objects`, summed over the frame's lit spots `j`:
//!   `E_j` the spot's irradiance at `x` (`I(ω) cos θ / r²`, or Eq. 14 for a filter position of a
//!   light field), `k` the lamp's scale (the estimator's, as on the objects), `E_rest` and
//!   `E_rest,v` the sun and sky terms of today's differential model (`c·Pa + (s·cos + b)·Pd`,
//!   and with `c_v`, `b_v` and the virtual sun shadow). The footage is multiplied by `L₁ / L₀`;
//!   where only a lamp is blocked this is the issue's `E_rest / (E_rest + k·E·V)`. The
//!   estimator's lamp column is the same `k·E·V^proxy` (issue 16 §3), so the two agree.
//! - **The lamps' light after a bounce** ([`super::ground_bounce`]): `L₀` also holds
//!   `Σ_i k_i·B_i` and `L₁` `Σ_i k_i·B_{v,i}`, the irradiance the lamps' light reaches `x` with
//!   off the lit ground, walls (and, in `L₁`, the objects), as the sun's `b`, `b_v` do for `Pd`.
//!   In a lamp shadow it is all the lamp light left; without it the ratio was too dark there.
//! - **Visibility from the maps the lamp term already draws.** The lamp shadow atlas holds the
//!   objects and the proxy (`V^proxy·V^objects` in one lookup); a second atlas of the same views
//!   holds the proxy alone (`V^proxy`). Both are perspective maps fitted to the objects' bounds:
//!   a receiver outside a map's frustum cannot be shadowed by the objects, and both lookups give
//!   1 there; a receiver past its far plane reads the cleared depth unless an object covers it.
//! - **One pass, in float, no read-back**: the composite fragment shader (`shaders/composite.wgsl`)
//!   loops over the lit spots for every real pixel in the differential region or under a lamp
//!   shadow of the objects, with the spots and maps bound as group 2
//!   (`shaders/common/lamp_spots.wgsl`, shared with the lamp term) and the proxy point of every
//!   footage pixel as one more composite input.
//! - **Left out, with the reason in the pass report (`lamp_ground`)**: whenever the lamp term is
//!   (no objects drawn, no lamp lit, no lamp reaching the objects' bounds: a lamp that cannot
//!   light the objects cannot cast their shadow), and when the darkening is not the differential
//!   model, the only one that knows the real pixels' irradiance. A lamp left out of the lamp term
//!   is left out of `L₀` and `L₁` too (it has no map): where it lights a shadowed pixel the
//!   darkening is too strong by its share. Scenes without `[[lights]]` bind an empty group whose
//!   spot count is zero, so the composite does what it did before lamps.
//!
//! # Measured
//! - **Against the CPU reference** (`tests/suite/render/lamp_ground.rs`: a spot over a ball and
//!   a block on the yard's ground at night, sky `Pa` = 0.3): the ratio `L₁ / L₀` per real
//!   pixel within 1e-5 on average over 3180 interior shadowed and 59622 lit pixels.
//! - **The bundled dusk scene** (`heliar bench render scenes/dusk --knob msaa --lamp-k 1`,
//!   the truth's lamp `k`, shadow classes toward the lamp; relative RMSE, MSAA 4, with the
//!   ground shadows → without): night frame 4, lamp shadow 35.7 % → 71.1 % (mean radiance
//!   0.00048 and 0.00113 against the reference's 0.00070), object 29.4 % both; dusk frame 1,
//!   shadow 12.9 % → 14.3 %; object and shadow over both frames 25.0 % → 25.5 % (worst
//!   29.5 % → 30.3 %). With the estimator's `k`: 37.8 % → 38.1 % (worst 49.2 % → 49.7 %).
//!   What was left then is light the model lacked, not the ratio: the reference's shadow at
//!   night is brighter than `c_v·Pa` by the lamp's light bounced off the lit ground and walls.
//!   With that bounce ([`super::ground_bounce`]; docs/measurements.md, "The lamp's bounced light
//!   on the real ground") the night shadow's interior mean is within 5 % (R), 0.7 % (G) and
//!   0.4 % (B) of the reference, and its column (1-px edges included, where the disc lamp's
//!   penumbra meets the maps' hard edge) 26.8 % → 24.5 % with the truth's `k`.

use crate::gpu::canvas::storage_entry;
use crate::gpu::texture::Tex;
use crate::render::frame::pass;
use crate::render::plan::{Pass, Plan};
use crate::render::vem::shadow_atlas::ATLAS_FORMAT;
use wgpu::util::DeviceExt;

/// Bind group of the lamps' data, as `shaders/common/lamp_spots.wgsl` reads it.
pub const GROUP: u32 = 2;

fn depth_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Texture { sample_type: wgpu::TextureSampleType::Depth, view_dimension: wgpu::TextureViewDimension::D2, multisampled: false },
        count: None,
    }
}

/// Layout of the lamps' data (group [`GROUP`] of the lamp term and of the composite): header,
/// spots, texels, taps, shadow views, the atlas with objects and proxy, its comparison sampler,
/// the atlas with the proxy alone.
pub fn data_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("lamp data"),
        entries: &[
            storage_entry(0),
            storage_entry(1),
            storage_entry(2),
            storage_entry(3),
            storage_entry(4),
            depth_entry(5),
            wgpu::BindGroupLayoutEntry { binding: 6, visibility: wgpu::ShaderStages::FRAGMENT, ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Comparison), count: None },
            depth_entry(7),
        ],
    })
}

/// The comparison sampler of the shadow atlases (one texel, `reference ≤ stored` is lit).
pub fn atlas_sampler(device: &wgpu::Device) -> wgpu::Sampler {
    device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some("lamp shadow atlas"),
        mag_filter: wgpu::FilterMode::Nearest,
        min_filter: wgpu::FilterMode::Nearest,
        compare: Some(wgpu::CompareFunction::LessEqual),
        ..Default::default()
    })
}

/// The buffers and atlases one data group binds.
pub struct DataBindings<'a> {
    /// Header, spots, texels, taps, views.
    pub buffers: [&'a wgpu::Buffer; 5],
    /// The atlas with objects and proxy.
    pub atlas: &'a wgpu::TextureView,
    /// The atlas with the proxy alone.
    pub proxy_atlas: &'a wgpu::TextureView,
    /// Comparison sampler.
    pub sampler: &'a wgpu::Sampler,
}

/// The data group of `b` on `layout` ([`data_layout`]).
pub fn data_bind_group(device: &wgpu::Device, layout: &wgpu::BindGroupLayout, b: &DataBindings<'_>) -> wgpu::BindGroup {
    let mut entries: Vec<wgpu::BindGroupEntry> = b.buffers.iter().enumerate().map(|(i, buf)| wgpu::BindGroupEntry { binding: i as u32, resource: buf.as_entire_binding() }).collect();
    entries.push(wgpu::BindGroupEntry { binding: 5, resource: wgpu::BindingResource::TextureView(b.atlas) });
    entries.push(wgpu::BindGroupEntry { binding: 6, resource: wgpu::BindingResource::Sampler(b.sampler) });
    entries.push(wgpu::BindGroupEntry { binding: 7, resource: wgpu::BindingResource::TextureView(b.proxy_atlas) });
    device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some("lamp data"), layout, entries: &entries })
}

/// The data group of a scene without lamps: a zero header (no spot), one zeroed element per
/// buffer and 1×1 atlases, so the composite's lamp loop never runs.
pub fn empty_data(device: &wgpu::Device, layout: &wgpu::BindGroupLayout) -> wgpu::BindGroup {
    let zeros = |label: &str, bytes: usize| device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents: &vec![0u8; bytes], usage: wgpu::BufferUsages::STORAGE });
    // The header (8 u32), one `LampSpot` (9 vec4), one texel, one tap, one `ShadowView`.
    let view = std::mem::size_of::<crate::render::vem::shadow_atlas::ShadowView>();
    let buffers = [zeros("no lamp header", 32), zeros("no lamp spots", 144), zeros("no lamp texels", 8), zeros("no lamp taps", 16), zeros("no lamp views", view)];
    let atlas = Tex::new(device, "no lamp atlas", (1, 1), ATLAS_FORMAT, 1, wgpu::TextureUsages::TEXTURE_BINDING);
    let sampler = atlas_sampler(device);
    data_bind_group(device, layout, &DataBindings { buffers: [&buffers[0], &buffers[1], &buffers[2], &buffers[3], &buffers[4]], atlas: &atlas.view, proxy_atlas: &atlas.view, sampler: &sampler })
}

/// The objects' lamp shadows on the real receivers (`lamp_ground`): runs with the lamp term,
/// under the differential darkening. `term` is the lamp term's skip reason, if any.
pub struct LampGround<'a> {
    /// Why the lamp term is left out.
    pub term: Option<&'a str>,
    /// The composite darkens by the differential model.
    pub differential: bool,
    /// Switched on ([`super::LampOptions::ground`] and the lamp shadows).
    pub enabled: bool,
}

impl<F> Pass<F> for LampGround<'_> {
    const NAME: &'static str = pass::LAMP_GROUND;

    fn plan(&self, _: &F) -> Plan {
        match self.term {
            Some(why) => Plan::skip(why.to_owned()),
            None if !self.enabled => Plan::skip("lamp shadows on real receivers are switched off"),
            None if !self.differential => Plan::skip("the darkening is not the differential model, which alone knows the real pixels' irradiance"),
            None => Plan::Run,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan(g: LampGround<'_>) -> Plan {
        <LampGround<'_> as Pass<()>>::plan(&g, &())
    }

    #[test]
    fn the_ground_pass_runs_with_the_lamp_term_under_the_differential_model_only() {
        assert_eq!(plan(LampGround { term: None, differential: true, enabled: true }), Plan::Run);
        // The lamp term's reason comes first: no lit lamp, no shadow to darken by.
        assert_eq!(plan(LampGround { term: Some("no lamp lights the objects"), differential: false, enabled: false }), Plan::skip("no lamp lights the objects"));
        let Plan::Skip(off) = plan(LampGround { term: None, differential: true, enabled: false }) else { panic!("switched off but runs") };
        assert!(off.contains("switched off"), "{off}");
        let Plan::Skip(why) = plan(LampGround { term: None, differential: false, enabled: true }) else { panic!("runs without the differential model") };
        assert!(why.contains("differential"), "{why}");
    }
}
