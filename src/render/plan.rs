//! Passes as units: what every pass of both renderers answers before it records anything.
//!
//! # How it works
//! A pass is a unit that owns its pipelines and whatever it keeps between frames (a stored
//! stencil, a traced transfer). Each frame it first answers [`Pass::plan`] from plain values
//! that describe the frame (the outdoor compositor's [`FrameContext`](super::compositor::FrameContext),
//! the VEM renderer's [`VemFrame`](super::vem::frame::VemFrame)): [`Plan::Run`], or
//! [`Plan::Skip`] with the reason the report gives. Only then does it record, with a method of
//! its own: what a pass records differs too much (a CPU trace and an upload, draws into a
//! render pass it shares with its neighbours, a whole render pass) for one signature to fit
//! them all, so the trait holds the part every renderer reads the same way. A renderer's frame
//! is then a list of units in order, each one asked, reported ([`enter`]) and recorded.
//!
//! The split borrows from rerun's `re_renderer` (a renderer owns pipelines, a frame's draw data
//! is built separately and drawn into a pass) and kajiya (`renderers/*.rs` composed in one
//! readable function, `world_render_passes.rs`).

use super::frame::Skipped;

/// Whether a pass runs this frame.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Plan {
    /// It runs.
    Run,
    /// It is left out, for this reason (the report's text).
    Skip(String),
}

impl Plan {
    /// A skip for `reason`.
    pub fn skip(reason: impl Into<String>) -> Self {
        Plan::Skip(reason.into())
    }
}

/// A pass of a renderer whose frames are described by `F`.
pub trait Pass<F> {
    /// The pass's name in the report.
    const NAME: &'static str;
    /// Whether the pass runs for `frame`, and why not.
    fn plan(&self, frame: &F) -> Plan;
}

/// Puts `plan` of the pass `name` into a report's lists (`ran`, or `skipped` with the reason);
/// true when the pass runs.
pub fn enter(ran: &mut Vec<&'static str>, skipped: &mut Vec<Skipped>, name: &'static str, plan: Plan) -> bool {
    match plan {
        Plan::Run => {
            ran.push(name);
            true
        }
        Plan::Skip(reason) => {
            skipped.push(Skipped { pass: name, reason });
            false
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entering_a_plan_fills_the_list_it_belongs_to() {
        let (mut ran, mut skipped) = (Vec::new(), Vec::new());
        assert!(enter(&mut ran, &mut skipped, "a", Plan::Run));
        assert!(!enter(&mut ran, &mut skipped, "b", Plan::skip("why")));
        assert_eq!(ran, ["a"]);
        assert_eq!(skipped, [Skipped { pass: "b", reason: "why".into() }]);
    }
}
