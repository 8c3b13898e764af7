//! Which frames to drop after a change (a control, a light, the
//! projector).
//!
//! A camera streaming with N buffers may hand out up to N frames exposed
//! before the change, and a light or an auto-exposure loop takes a moment to
//! settle. A frame is fresh when its timestamp is past the change plus the
//! settle time **and** at least N frames were dropped since the change.
//! Boundaries: the decision only; the stream is the camera driver's.

use std::time::Duration;

/// The stale-frame rule of one stream.
#[derive(Debug, Clone, PartialEq)]
pub struct StaleFrames {
    settle: Duration,
    buffers: u32,
    fresh_after: Option<Duration>,
    dropped: u32,
}

impl StaleFrames {
    /// `buffers`: the stream's buffer count; `settle`: how long after a change
    /// the scene is steady.
    pub fn new(settle: Duration, buffers: u32) -> StaleFrames {
        StaleFrames {
            settle,
            buffers,
            fresh_after: None,
            dropped: 0,
        }
    }

    /// Something changed at `at` (monotonic clock). Overlapping changes keep
    /// the later deadline.
    pub fn changed(&mut self, at: Duration) {
        let deadline = at + self.settle;
        self.fresh_after = Some(self.fresh_after.map_or(deadline, |d| d.max(deadline)));
        self.dropped = 0;
    }

    /// True when a frame stamped `timestamp` may be used; a stale frame is
    /// counted as dropped.
    pub fn accept(&mut self, timestamp: Duration) -> bool {
        match self.fresh_after {
            None => true,
            Some(deadline) => {
                if timestamp > deadline && self.dropped >= self.buffers {
                    self.fresh_after = None;
                    true
                } else {
                    self.dropped += 1;
                    false
                }
            }
        }
    }

    /// Frames dropped since the last change.
    pub fn dropped(&self) -> u32 {
        self.dropped
    }

    pub fn settle(&self) -> Duration {
        self.settle
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ms(v: u64) -> Duration {
        Duration::from_millis(v)
    }

    #[test]
    fn drops_until_past_settle_and_at_least_the_buffer_count() {
        let mut s = StaleFrames::new(ms(100), 4);
        assert!(s.accept(ms(10)), "no change yet: every frame is fresh");
        s.changed(ms(1000));
        // Old buffered frames, then frames within the settle time.
        for t in [990, 1020, 1050, 1080, 1100] {
            assert!(!s.accept(ms(t)), "{t}");
        }
        assert!(s.accept(ms(1101)));
        assert!(s.accept(ms(1130)), "stays fresh until the next change");
    }

    #[test]
    fn late_timestamps_still_wait_for_the_buffers_to_drain() {
        let mut s = StaleFrames::new(ms(0), 3);
        s.changed(ms(1000));
        // Timestamps already past the change (a driver stamping at dequeue)
        // but the first three frames were queued before it.
        assert!(!s.accept(ms(2000)));
        assert!(!s.accept(ms(2001)));
        assert!(!s.accept(ms(2002)));
        assert!(s.accept(ms(2003)));
        assert_eq!(s.dropped(), 3);
    }

    #[test]
    fn a_second_change_restarts_the_count_and_keeps_the_later_deadline() {
        let mut s = StaleFrames::new(ms(50), 1);
        s.changed(ms(1000));
        assert!(!s.accept(ms(1010)));
        s.changed(ms(1020));
        assert!(!s.accept(ms(1060)));
        assert!(!s.accept(ms(1070)), "deadline is 1070, exclusive");
        assert!(s.accept(ms(1071)));
    }
}
