//! The single-slot "latest frame wins" hand-off between the capture thread and the pipeline.
//!
//! The producer [`LatestSlot::put`]s every frame it captures; a frame still in the slot when the
//! next one arrives is stale and replaced, and counted as dropped. The consumer
//! [`LatestSlot::take`]s whatever is newest. When processing is slower than capture, the
//! pipeline therefore always works on the newest frame and never builds up a queue: latency
//! over completeness.

use std::sync::{Condvar, Mutex, MutexGuard};
use std::time::Duration;

#[derive(Debug)]
struct State<T> {
    item: Option<T>,
    put: u64,
    taken: u64,
    dropped: u64,
}

/// A one-item mailbox whose newest item replaces an untaken older one.
#[derive(Debug)]
pub struct LatestSlot<T> {
    state: Mutex<State<T>>,
    ready: Condvar,
}

/// Counters of a slot.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SlotCounts {
    /// Items put.
    pub put: u64,
    /// Items taken.
    pub taken: u64,
    /// Items replaced before anyone took them.
    pub dropped: u64,
}

impl<T> Default for LatestSlot<T> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T> LatestSlot<T> {
    /// An empty slot.
    pub fn new() -> Self {
        Self { state: Mutex::new(State { item: None, put: 0, taken: 0, dropped: 0 }), ready: Condvar::new() }
    }

    fn lock(&self) -> MutexGuard<'_, State<T>> {
        // A panic while holding the lock leaves consistent counters: keep going.
        self.state.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Puts the newest item; returns true when it replaced one nobody took (a dropped frame).
    pub fn put(&self, item: T) -> bool {
        let mut s = self.lock();
        let replaced = s.item.replace(item).is_some();
        s.put += 1;
        s.dropped += replaced as u64;
        drop(s);
        self.ready.notify_one();
        replaced
    }

    /// Takes the newest item, if there is one.
    pub fn take(&self) -> Option<T> {
        let mut s = self.lock();
        let item = s.item.take();
        s.taken += item.is_some() as u64;
        item
    }

    /// Takes the newest item, waiting up to `timeout` for one.
    pub fn take_timeout(&self, timeout: Duration) -> Option<T> {
        let deadline = std::time::Instant::now() + timeout;
        let mut s = self.lock();
        while s.item.is_none() {
            let now = std::time::Instant::now();
            if now >= deadline {
                return None;
            }
            s = self.ready.wait_timeout(s, deadline - now).map(|(g, _)| g).unwrap_or_else(|p| p.into_inner().0);
        }
        let item = s.item.take();
        s.taken += item.is_some() as u64;
        item
    }

    /// Removes an untaken item without counting it as taken or dropped (a source restart).
    pub fn clear(&self) {
        self.lock().item = None;
    }

    /// The counters.
    pub fn counts(&self) -> SlotCounts {
        let s = self.lock();
        SlotCounts { put: s.put, taken: s.taken, dropped: s.dropped }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;

    #[test]
    fn the_newest_item_wins_and_replaced_ones_are_counted() {
        let slot = LatestSlot::new();
        assert_eq!(slot.take(), None);
        assert!(!slot.put(1));
        assert_eq!(slot.take(), Some(1));
        assert_eq!(slot.take(), None);
        // A consumer three times slower than the producer: two of every three are dropped.
        let mut got = Vec::new();
        for i in 2..=10 {
            slot.put(i);
            if i % 3 == 1 {
                got.push(slot.take().unwrap());
            }
        }
        assert_eq!(got, vec![4, 7, 10]);
        assert_eq!(slot.counts(), SlotCounts { put: 10, taken: 4, dropped: 6 });
        // put + 0 left = taken + dropped.
        slot.put(11);
        slot.clear();
        assert_eq!(slot.take(), None);
        assert_eq!(slot.counts().dropped, 6, "clear is not a drop");
    }

    #[test]
    fn a_waiting_consumer_wakes_for_a_new_item_and_times_out_without_one() {
        let slot = Arc::new(LatestSlot::new());
        let t = std::time::Instant::now();
        assert_eq!(slot.take_timeout(Duration::from_millis(30)), None);
        assert!(t.elapsed() >= Duration::from_millis(30));
        let s = slot.clone();
        let h = std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(20));
            s.put(7u32);
        });
        assert_eq!(slot.take_timeout(Duration::from_secs(10)), Some(7));
        h.join().unwrap();
        assert_eq!(slot.counts(), SlotCounts { put: 1, taken: 1, dropped: 0 });
    }
}
