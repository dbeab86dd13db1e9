//! `heliar live` (feature `opencv`): the outdoor pipeline over a camera, a stream or a file
//! played as one, in a window (eframe: winit + egui + egui-wgpu).
//!
//! # How it works
//! - **Capture** ([`source`]): a thread reads the camera (or paces a file at its frame rate) and
//!   hands each frame to a single-slot, latest-frame-wins mailbox ([`slot`]). When processing is
//!   slower than capture, stale frames are replaced and counted as dropped: latency over
//!   completeness. A lost camera (read error, no frames, cannot open) is reopened every second;
//!   a read that blocks is abandoned after a stall timeout.
//! - **Processing** ([`app`]): on the window's thread, each repaint takes the newest frame and
//!   runs the outdoor session ([`crate::run::session::OutdoorSession::process`]): estimate →
//!   (relight → probes) → composite; with the VEM panel's compositing on, the objects are lit by
//!   the VEM's lights instead ([`crate::run::vem::VemOverlay`]).
//!   The compositor renders **offscreen on its own headless wgpu device** and reads the frame
//!   back ([`crate::render::Compositor::render`]); the app encodes it through the camera's
//!   response ([`crate::render::output::encode_rgb8`]) and uploads it as an egui texture.
//!   That costs one read-back and one upload per frame (≈ 1–2 ms at 320×240), but keeps the
//!   compositor independent of eframe's device (which could be a GL one while the compositor
//!   prefers Vulkan/lavapipe), gives the window the exact pixels `augment` writes (camera
//!   response, untouched pixels keeping their codes), and is what the tests check headless.
//!   Rendering straight into eframe's surface through `Compositor::render_to` is left for a
//!   real GPU, where the read-back would matter.
//! - **Window**: the feed; switches for the passes ([`crate::render::PassSwitches`]: a pass
//!   switched off is reported as skipped, "turned off in the live view"), the darkening model
//!   and the ambient source; the estimator's status, fallback, condition number, `Pd`/`Pa`,
//!   relight, frame rate and dropped frames; plots of `Pd`, `Pa` and the residual over the last
//!   five minutes (egui_plot). The objects can be dragged over the real ground with the mouse,
//!   turned with the scroll wheel and reset (issue 15 §1): a move by hand is rigid, so the
//!   visibility cuts (`crate::run::motion_cuts`) serve it without a re-trace, and the pass
//!   report lists the objects that moved.
//! - **VEM** ([`vem`], `--vem-input`): a captured video environment map sequence decomposed
//!   into lights, drawn on a polar plot, with a slider for the light count and a switch that
//!   lights and shadows the virtual objects with those lights over the feed (the VEM renderer).
//!   The objects follow their motions and the moves by hand there too: the overlay poses them
//!   itself (`VemPanel::pose_objects`; each light's shadow map is drawn every frame, so nothing
//!   is re-traced), picking and dragging follow where it shows them, and the outdoor compositor
//!   catches up when the switch is turned off.

pub mod app;
pub mod slot;
pub mod source;
pub mod vem;

pub use crate::run::clock::FrameClock;
pub use app::{AmbientChoice, FEED_ALT_TEXT, LiveApp, TURNED_OFF};
pub use slot::LatestSlot;
pub use source::{Capture, CaptureOptions, Captured, FrameSource, Opener, SourceState};
