//! The time of every frame: one clock for every front end.
//!
//! A frame's time drives the sun position model, so it must be the capture time. Three sources
//! of it exist:
//! - [`FrameClock::List`]: a scene sequence's own times (`[[sequences]]` in `scene.toml`), by
//!   frame index;
//! - [`FrameClock::Start`]: a start time plus the container's timestamps (video files), or the
//!   frame index over the frame rate when there are none (folders, containers without them);
//! - [`FrameClock::Wall`]: the wall clock at capture, shifted (cameras).

use chrono::{DateTime, FixedOffset};
use std::time::Instant;

/// Errors of the clock.
#[derive(Debug, thiserror::Error)]
pub enum ClockError {
    /// A frame past the end of a sequence's list of times.
    #[error("frame {index}: the sequence lists only {count} times")]
    PastList {
        /// The frame.
        index: usize,
        /// Times in the list.
        count: usize,
    },
}

/// The time of each frame.
#[derive(Clone, Debug)]
pub enum FrameClock {
    /// A scene sequence's times by frame index; `looped` plays them again from the start (a
    /// file played in a loop), otherwise a frame past the end is an error.
    List {
        /// One time per frame.
        times: Vec<DateTime<FixedOffset>>,
        /// Wrap around at the end.
        looped: bool,
    },
    /// A start time plus the source's timestamps, or the frame index over `fps`.
    Start {
        /// Time of the first frame.
        t0: DateTime<FixedOffset>,
        /// Frame rate for frames without a timestamp.
        fps: f64,
    },
    /// The wall clock at capture plus an offset (cameras; `--start` or `--time-offset` set it).
    Wall {
        /// Added to the wall clock.
        offset: chrono::Duration,
    },
}

impl FrameClock {
    /// A wall clock whose first reading is `start` (when given), shifted by `offset_secs`.
    pub fn wall(start: Option<DateTime<FixedOffset>>, offset_secs: f64) -> Self {
        let now = chrono::Utc::now().fixed_offset();
        let base = start.map(|s| s - now).unwrap_or_else(chrono::Duration::zero);
        Self::Wall { offset: base + chrono::Duration::microseconds((offset_secs * 1e6).round() as i64) }
    }

    /// The time of frame `index`, whose source timestamp (ms from the start of the source) is
    /// `ts_ms` when it has one, captured at `captured_at` (for the wall clock; `None`: now).
    pub fn time(&self, index: usize, ts_ms: Option<f64>, captured_at: Option<Instant>) -> Result<DateTime<FixedOffset>, ClockError> {
        match self {
            FrameClock::List { times, looped } => match (times.get(index), looped) {
                (Some(t), _) => Ok(*t),
                (None, true) if !times.is_empty() => Ok(times[index % times.len()]),
                _ => Err(ClockError::PastList { index, count: times.len() }),
            },
            FrameClock::Start { t0, fps } => {
                let ms = ts_ms.filter(|v| v.is_finite() && *v >= 0.0).unwrap_or(index as f64 * 1e3 / fps);
                Ok(*t0 + chrono::Duration::microseconds((ms * 1e3).round() as i64))
            }
            FrameClock::Wall { offset } => {
                let age = captured_at.map(|a| chrono::Duration::from_std(a.elapsed()).unwrap_or_else(|_| chrono::Duration::zero())).unwrap_or_else(chrono::Duration::zero);
                Ok(chrono::Utc::now().fixed_offset() - age + *offset)
            }
        }
    }

    /// Frames per second of the clock's spacing (the second minus the first time of a list, the
    /// start clock's rate); `None` for the wall clock and lists of one time.
    pub fn nominal_fps(&self) -> Option<f64> {
        match self {
            FrameClock::List { times, .. } if times.len() > 1 => {
                Some(1e6 / (times[1] - times[0]).num_microseconds().unwrap_or(1_000_000).max(1) as f64)
            }
            FrameClock::Start { fps, .. } => Some(*fps),
            _ => None,
        }
    }
}

/// Watches that frame times increase. A clock that stands still (every frame stamped with the
/// same time) or runs backwards silently breaks the estimator's smoother, so the frames whose
/// time does not increase are collected and reported by number.
#[derive(Clone, Debug, Default)]
pub struct ClockCheck {
    last: Option<(usize, DateTime<FixedOffset>)>,
    stuck: Vec<usize>,
}

impl ClockCheck {
    /// Records frame `index` at `time`; false when the time does not increase over the previous
    /// frame's.
    pub fn check(&mut self, index: usize, time: DateTime<FixedOffset>) -> bool {
        let ok = self.last.is_none_or(|(_, t)| time > t);
        if !ok {
            self.stuck.push(index);
        }
        self.last = Some((index, time));
        ok
    }

    /// Frames whose time did not increase.
    pub fn stuck(&self) -> &[usize] {
        &self.stuck
    }

    /// The warning for `label`'s frames, when some time did not increase: the frames as ranges
    /// ("frames 3–11, 14").
    pub fn warning(&self, label: &str) -> Option<String> {
        if self.stuck.is_empty() {
            return None;
        }
        Some(format!(
            "warning: {label}: the time of {} does not increase over the frame before (the estimator's smoother uses the nominal frame interval there); check the frame times (--strict makes this an error)",
            frame_ranges(&self.stuck)
        ))
    }
}

/// "frame 3", "frames 3–11, 14".
pub fn frame_ranges(frames: &[usize]) -> String {
    let mut parts: Vec<String> = Vec::new();
    let mut i = 0;
    while i < frames.len() {
        let mut j = i;
        while j + 1 < frames.len() && frames[j + 1] == frames[j] + 1 {
            j += 1;
        }
        parts.push(if j > i { format!("{}–{}", frames[i], frames[j]) } else { frames[i].to_string() });
        i = j + 1;
    }
    let word = if frames.len() == 1 { "frame" } else { "frames" };
    format!("{word} {}", parts.join(", "))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn t(s: &str) -> DateTime<FixedOffset> {
        DateTime::parse_from_rfc3339(s).unwrap()
    }

    #[test]
    fn list_start_and_wall_clocks() {
        let times = vec![t("2024-06-21T12:00:00+02:00"), t("2024-06-21T12:00:10+02:00")];
        let list = FrameClock::List { times: times.clone(), looped: false };
        assert_eq!(list.time(1, Some(5.0), None).unwrap(), times[1]);
        assert!(matches!(list.time(2, None, None), Err(ClockError::PastList { index: 2, count: 2 })));
        assert!((list.nominal_fps().unwrap() - 0.1).abs() < 1e-12);
        let looped = FrameClock::List { times: times.clone(), looped: true };
        assert_eq!(looped.time(3, None, None).unwrap(), times[1]);
        // Container timestamps win over index / fps; invalid ones fall back.
        let start = FrameClock::Start { t0: times[0], fps: 25.0 };
        assert_eq!(start.time(7, Some(1500.0), None).unwrap(), t("2024-06-21T12:00:01.5+02:00"));
        assert_eq!(start.time(50, None, None).unwrap(), t("2024-06-21T12:00:02+02:00"));
        assert_eq!(start.time(50, Some(f64::NAN), None).unwrap(), t("2024-06-21T12:00:02+02:00"));
    }

    #[test]
    fn times_that_do_not_increase_are_named_by_frame() {
        let t0 = t("2024-06-21T12:00:00+02:00");
        let mut c = ClockCheck::default();
        let times = [0, 1, 1, 1, 2, 3, 2, 4];
        let ok: Vec<bool> = times.iter().enumerate().map(|(i, s)| c.check(i, t0 + chrono::Duration::seconds(*s))).collect();
        assert_eq!(ok, [true, true, false, false, true, true, false, true]);
        assert_eq!(c.stuck(), [2, 3, 6]);
        let w = c.warning("clip.mp4").unwrap();
        assert!(w.contains("clip.mp4") && w.contains("frames 2–3, 6"), "{w}");
        assert_eq!(frame_ranges(&[5]), "frame 5");
        assert!(ClockCheck::default().warning("x").is_none());
    }

    #[test]
    fn the_wall_clock_is_shifted_to_the_start_and_by_the_offset() {
        // A camera with --start: a frame captured now is at the start; one captured 2 s ago,
        // 2 s before it; --time-offset shifts both.
        let start = t("2024-06-21T15:30:00+02:00");
        for offset_s in [0.0, 90.0] {
            let clock = FrameClock::wall(Some(start), offset_s);
            for age_s in [0.0, 2.0] {
                let at = Instant::now() - std::time::Duration::from_secs_f64(age_s);
                let got = clock.time(0, None, Some(at)).unwrap();
                let want = start + chrono::Duration::milliseconds(((offset_s - age_s) * 1e3) as i64);
                assert!((got - want).num_milliseconds().abs() < 500, "offset {offset_s}, age {age_s}: {got} vs {want}");
            }
        }
        // Without --start: the wall clock itself.
        let got = FrameClock::wall(None, 0.0).time(0, None, Some(Instant::now())).unwrap();
        assert!((got - chrono::Utc::now().fixed_offset()).num_milliseconds().abs() < 500);
    }
}
