//! # heliar
//!
//! heliar puts virtual objects into real outdoor video so that they are lit by the same sun and
//! sky, receive shadows from real things and cast shadows onto the real ground. This crate is the
//! library behind the `heliar` command.
//!
//! The outdoor pipeline follows Jensen, Andersen and Madsen, *Real-time image based lighting for
//! outdoor augmented reality under dynamically changing illumination conditions*
//! (`../shared/papers/jensen-outdoor-ar-ibl.txt`, "Jensen" below): a sun position model plus a
//! robust fit over a few hundred pixels of known diffuse surfaces gives the direct (sun) and
//! ambient (sky) intensities of every frame (Jensen §3.1), which later stages use to relight the
//! environment and shade virtual objects.
//!
//! # Conventions
//!
//! These are fixed once here. Every module, every file format and every external check relies on
//! them; `scenes/README.md` repeats the ones a scene author needs.
//!
//! ## Frames and units
//! - **World (scene) frame**: right-handed, metres, **+Y up**. Which horizontal direction is
//!   geographic north is stated by the scene manifest (`place.north`, default `-Z`); east is
//!   `north × up` (so with the default north, east is `+X` and south is `+Z`).
//! - **Camera frame** (OpenCV): `+X` right, `+Y` down, `+Z` forward (the viewing direction).
//!   Transforms are named `a_from_b`: `world_from_camera` maps camera coordinates to world
//!   coordinates.
//! - **Pixel coordinates** (OpenCV): `(u, v)` with `u` to the right and `v` down; the centre of the
//!   top-left pixel is `(0, 0)`, so pixel `(col, row)` covers `[col - ½, col + ½]`.
//! - **Angles** are radians inside the code and degrees at the user's edge (CLI, files), always with
//!   the unit in the name (`zenith_deg`). Solar azimuth is measured **clockwise from north**
//!   (north 0°, east 90°).
//! - **Equirectangular maps** (environment maps): for a unit direction `d` in the world frame,
//!   `φ = atan2(d.x, −d.z)` and `θ = acos(d.y)`; column coordinate `x = (φ / 2π + ½) · W` and row
//!   coordinate `y = θ / π · H`, texel centres at `+½`. Row 0 is the zenith, the centre column
//!   looks along `−Z` (north by default) and columns grow toward `+X` (east by default). One pair of
//!   functions, [`geometry::equirect::texel_from_dir`] and [`geometry::equirect::dir_from_texel`], implements this; all
//!   other code calls them.
//!
//! ## Radiometry
//! All estimation and shading happen in **linear light**, in the units of the input images
//! ("scaled radiance"). LDR frames are linearised with the camera response and exposure first.
//!
//! - `Pd` (RGB) is the **sun's irradiance on a surface facing the sun**.
//! - `Pa` (RGB) is the **sky's irradiance on an unoccluded horizontal surface** (the sun excluded).
//! - A Lambertian surface point of albedo `ρ` and normal `n`, sun direction `l` (unit, toward the
//!   sun), has outgoing radiance
//!
//!   `L = ρ/π · (c·Pa + s·Pd·max(n·l, 0))`   (Jensen §4.2)
//!
//!   where `s ∈ {0, 1}` is the sun visibility of the point and `c` (RGB) is its **weighted-ambient
//!   factor**: the irradiance it receives under a uniform white sky of unit horizontal irradiance,
//!   including the interreflection of that sky light between the proxy's surfaces. `c = 1` on an
//!   unoccluded horizontal surface. See [`geometry::ambient`].
//! - The estimator may add a sun-bounce term `b·Pd` (light from sunlit proxy surfaces reaching the
//!   point, per unit `Pd`), which Jensen ignores: `L = ρ/π · (c·Pa + (s·max(n·l,0) + b)·Pd)`.
//!
//! Proxy surfaces are two-sided: a surface seen from either side has its normal facing the viewer.

pub mod camera;
pub mod cuts;
pub mod envmap;
pub mod estimate;
pub mod geometry;
pub mod gpu;
pub mod io;
pub mod irradiance;
pub mod lamps;
pub mod lighting;
#[cfg(feature = "opencv")]
pub mod live;
#[cfg(feature = "opencv")]
pub mod opencv_calib;
pub mod render;
pub mod report;
pub mod run;
pub mod scene;
pub mod sky;
pub mod sun;
pub mod vem;
