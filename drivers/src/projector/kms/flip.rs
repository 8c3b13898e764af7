//! Double-buffered showing of patterns, over a small [`Scanout`] trait so
//! the rule is tested without a GPU.
//!
//! The rule `show` keeps: when it returns, the projector emits the new
//! pattern, so a camera frame started after it sees that pattern and
//! nothing else. It renders into the back buffer, flips (a modeset the
//! first time, when nothing of ours is on screen), waits for the kernel's
//! flip-complete event (the buffer is being scanned out from that vblank),
//! then waits the projector's own latency (its scaler, DLP colour-wheel
//! sequencing and frame buffering: typically one to three frames, 100 ms by
//! default) counted from the event's timestamp. Showing what is already
//! shown does nothing.

use crate::error::DriverError;
use crate::projector::kms::raster::{render, Gamma};
use crate::traits::{monotonic_now, ProjectorPattern};
use std::io;
use std::time::Duration;

/// Two framebuffers on one CRTC. Buffer indices are 0 and 1.
pub trait Scanout {
    /// The output's name for errors, e.g. `/dev/dri/card0:HDMI-A-1`.
    fn name(&self) -> &str;
    /// Width and height in pixels.
    fn size(&self) -> (u32, u32);
    /// Bytes per row of both buffers.
    fn stride(&self) -> usize;
    /// Lets `draw` write buffer `index` (mapped for the call).
    fn with_buffer(
        &mut self,
        index: usize,
        draw: &mut dyn FnMut(&mut [u8]),
    ) -> Result<(), DriverError>;
    /// Sets the mode and shows buffer `index`; synchronous.
    fn set_crtc(&mut self, index: usize) -> Result<(), DriverError>;
    /// Queues a flip to buffer `index` at the next vblank, asking for an
    /// event.
    fn page_flip(&mut self, index: usize) -> Result<(), DriverError>;
    /// Waits up to `timeout` for the flip-complete event; its time on the
    /// monotonic clock, or `None` when none came.
    fn wait_flip(&mut self, timeout: Duration) -> Result<Option<Duration>, DriverError>;
    /// Now, on the monotonic clock.
    fn now(&self) -> Duration {
        monotonic_now()
    }
    fn sleep(&mut self, duration: Duration) {
        std::thread::sleep(duration)
    }
}

/// Timing of [`FlipChain::show`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlipTiming {
    /// From the flip event to the projector emitting the new frame.
    pub latency: Duration,
    /// Longest wait for a flip-complete event (a few frames at any rate).
    pub flip_timeout: Duration,
    /// Extra wait after a modeset, for the projector to lock onto the new
    /// signal (HDMI sinks take up to a few seconds).
    pub modeset_settle: Duration,
}

impl Default for FlipTiming {
    fn default() -> Self {
        FlipTiming {
            latency: Duration::from_millis(100),
            flip_timeout: Duration::from_secs(1),
            modeset_settle: Duration::from_secs(2),
        }
    }
}

/// The state machine: which buffer is on screen and with what.
pub struct FlipChain<S: Scanout> {
    scanout: S,
    gamma: Gamma,
    timing: FlipTiming,
    /// The buffer being scanned out.
    front: usize,
    /// What is on screen; `None` before the first modeset and after a
    /// failed show (the next show modesets again).
    shown: Option<ProjectorPattern>,
}

impl<S: Scanout> FlipChain<S> {
    /// Nothing is shown until the first [`FlipChain::show`].
    pub fn new(scanout: S, gamma: Gamma, timing: FlipTiming) -> FlipChain<S> {
        FlipChain {
            scanout,
            gamma,
            timing,
            // So the first modeset shows buffer 0.
            front: 1,
            shown: None,
        }
    }

    pub fn scanout(&self) -> &S {
        &self.scanout
    }

    pub fn scanout_mut(&mut self) -> &mut S {
        &mut self.scanout
    }

    /// What is on screen (black before the first show or after a failed
    /// one, when it is unknown).
    pub fn pattern(&self) -> ProjectorPattern {
        self.shown.unwrap_or_default()
    }

    /// True once a show succeeded and none failed since.
    pub fn is_showing(&self) -> bool {
        self.shown.is_some()
    }

    /// Puts `pattern` on screen; returns once the projector emits it.
    pub fn show(&mut self, pattern: ProjectorPattern) -> Result<(), DriverError> {
        if self.shown == Some(pattern) {
            return Ok(());
        }
        let modeset = self.shown.is_none();
        // Unknown until this show completes: a failure below leaves the
        // screen in doubt and the next show modesets.
        self.shown = None;
        // A recovery modeset also draws the buffer not last shown: the
        // failed flip may still land on the other.
        let back = 1 - self.front;
        let (w, h) = self.scanout.size();
        let stride = self.scanout.stride();
        let gamma = self.gamma;
        let mut drawn = Ok(());
        self.scanout.with_buffer(back, &mut |buf| {
            drawn = render(&pattern, gamma, w, h, stride, buf);
        })?;
        drawn.map_err(|e| DriverError::InvalidSetting {
            device: self.scanout.name().to_string(),
            reason: format!("the scanout buffer does not fit the mode: {e}"),
        })?;
        let deadline = if modeset {
            self.scanout.set_crtc(back)?;
            self.scanout.now() + self.timing.modeset_settle + self.timing.latency
        } else {
            self.scanout.page_flip(back)?;
            let Some(at) = self.scanout.wait_flip(self.timing.flip_timeout)? else {
                return Err(DriverError::Io {
                    device: self.scanout.name().to_string(),
                    action: "waiting for the page flip",
                    source: io::Error::new(
                        io::ErrorKind::TimedOut,
                        format!(
                            "no flip-complete event within {:?} (is the output still \
                             enabled and the cable connected?)",
                            self.timing.flip_timeout
                        ),
                    ),
                });
            };
            at + self.timing.latency
        };
        let now = self.scanout.now();
        if deadline > now {
            self.scanout.sleep(deadline - now);
        }
        self.front = back;
        self.shown = Some(pattern);
        Ok(())
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::traits::{Checker, Level};
    use std::num::NonZeroU32;

    /// What the fake saw, in order.
    #[derive(Debug, Clone, PartialEq)]
    pub enum Call {
        Draw(usize),
        SetCrtc(usize),
        Flip(usize),
        WaitFlip(Duration),
        Sleep(Duration),
    }

    /// A scanout on a virtual clock: a flip completes `flip_delay` after it
    /// is queued, unless `drop_flips`.
    pub struct FakeScanout {
        pub buffers: [Vec<u8>; 2],
        pub on_screen: Option<usize>,
        pub pending: Option<usize>,
        pub calls: Vec<Call>,
        pub clock: Duration,
        pub flip_delay: Duration,
        pub drop_flips: bool,
        pub flip_event_at: Option<Duration>,
        /// How long after the event the waiter wakes.
        pub wake_delay: Duration,
    }

    pub const W: u32 = 8;
    pub const H: u32 = 4;
    const STRIDE: usize = W as usize * 4 + 16;

    impl FakeScanout {
        pub fn new() -> FakeScanout {
            FakeScanout {
                buffers: [vec![0; STRIDE * H as usize], vec![0; STRIDE * H as usize]],
                on_screen: None,
                pending: None,
                calls: Vec::new(),
                clock: Duration::from_secs(1000),
                flip_delay: Duration::from_millis(10),
                drop_flips: false,
                flip_event_at: None,
                wake_delay: Duration::ZERO,
            }
        }

        /// The code of pixel (u, v) of what is scanned out.
        pub fn screen_code(&self, u: usize, v: usize) -> Option<u8> {
            self.on_screen.map(|b| self.buffers[b][v * STRIDE + u * 4])
        }
    }

    impl Scanout for FakeScanout {
        fn name(&self) -> &str {
            "fake:HDMI-A-1"
        }
        fn size(&self) -> (u32, u32) {
            (W, H)
        }
        fn stride(&self) -> usize {
            STRIDE
        }
        fn with_buffer(
            &mut self,
            index: usize,
            draw: &mut dyn FnMut(&mut [u8]),
        ) -> Result<(), DriverError> {
            assert_ne!(self.on_screen, Some(index), "drawing into the front buffer");
            self.calls.push(Call::Draw(index));
            draw(&mut self.buffers[index]);
            Ok(())
        }
        fn set_crtc(&mut self, index: usize) -> Result<(), DriverError> {
            self.calls.push(Call::SetCrtc(index));
            self.on_screen = Some(index);
            self.pending = None;
            Ok(())
        }
        fn page_flip(&mut self, index: usize) -> Result<(), DriverError> {
            assert!(self.on_screen.is_some(), "flip before modeset");
            assert!(self.pending.is_none(), "flip while one is pending (EBUSY)");
            self.calls.push(Call::Flip(index));
            self.pending = Some(index);
            Ok(())
        }
        fn wait_flip(&mut self, timeout: Duration) -> Result<Option<Duration>, DriverError> {
            self.calls.push(Call::WaitFlip(timeout));
            if self.drop_flips || self.flip_delay > timeout {
                self.clock += timeout;
                return Ok(None);
            }
            self.clock += self.flip_delay;
            self.on_screen = self.pending.take();
            let event = self.clock;
            self.flip_event_at = Some(event);
            self.clock += self.wake_delay;
            Ok(Some(event))
        }
        fn now(&self) -> Duration {
            self.clock
        }
        fn sleep(&mut self, duration: Duration) {
            self.calls.push(Call::Sleep(duration));
            self.clock += duration;
        }
    }

    fn timing() -> FlipTiming {
        FlipTiming {
            latency: Duration::from_millis(100),
            flip_timeout: Duration::from_millis(500),
            modeset_settle: Duration::from_secs(2),
        }
    }

    fn chain() -> FlipChain<FakeScanout> {
        FlipChain::new(FakeScanout::new(), Gamma::new(1.0).unwrap(), timing())
    }

    fn uniform(level: f32) -> ProjectorPattern {
        ProjectorPattern::Uniform(Level::new(level).unwrap())
    }

    #[test]
    fn first_show_modesets_and_waits_settle_plus_latency() {
        let mut c = chain();
        assert!(!c.is_showing());
        let t0 = c.scanout().clock;
        c.show(ProjectorPattern::Black).unwrap();
        let s = c.scanout();
        assert_eq!(
            s.calls,
            [
                Call::Draw(0),
                Call::SetCrtc(0),
                Call::Sleep(Duration::from_millis(2100))
            ]
        );
        assert_eq!(s.clock - t0, Duration::from_millis(2100));
        assert_eq!(s.screen_code(0, 0), Some(0));
        assert_eq!(c.pattern(), ProjectorPattern::Black);
    }

    #[test]
    fn later_shows_draw_the_back_buffer_flip_and_wait_latency_from_the_event() {
        let mut c = chain();
        c.show(ProjectorPattern::Black).unwrap();
        c.scanout_mut().calls.clear();
        c.show(uniform(1.0)).unwrap();
        let s = c.scanout();
        assert_eq!(
            s.calls,
            [
                Call::Draw(1),
                Call::Flip(1),
                Call::WaitFlip(Duration::from_millis(500)),
                Call::Sleep(Duration::from_millis(100)),
            ]
        );
        // Returned exactly `latency` after the flip event.
        assert_eq!(
            s.clock,
            s.flip_event_at.unwrap() + Duration::from_millis(100)
        );
        assert_eq!(s.on_screen, Some(1));
        assert_eq!(s.screen_code(3, 2), Some(255));
        assert_eq!(c.pattern(), uniform(1.0));

        c.scanout_mut().calls.clear();
        c.show(uniform(0.2)).unwrap();
        assert_eq!(c.scanout().calls[..2], [Call::Draw(0), Call::Flip(0)]);
        assert_eq!(c.scanout().screen_code(0, 0), Some(51));
    }

    #[test]
    fn latency_is_counted_from_the_event_not_from_a_late_wake_up() {
        let mut c = chain();
        c.show(ProjectorPattern::Black).unwrap();
        // The event is stamped at the vblank; the process reads it 30 ms
        // later, so only 70 ms are left to wait.
        c.scanout_mut().wake_delay = Duration::from_millis(30);
        c.scanout_mut().calls.clear();
        c.show(uniform(0.5)).unwrap();
        let s = c.scanout();
        assert_eq!(s.calls[3], Call::Sleep(Duration::from_millis(70)));
        assert_eq!(
            s.clock - s.flip_event_at.unwrap(),
            Duration::from_millis(100)
        );

        // Woken after more than the latency: no sleep at all.
        c.scanout_mut().wake_delay = Duration::from_millis(150);
        c.scanout_mut().calls.clear();
        c.show(uniform(0.7)).unwrap();
        assert_eq!(c.scanout().calls.len(), 3, "{:?}", c.scanout().calls);
        assert!(!c
            .scanout()
            .calls
            .iter()
            .any(|k| matches!(k, Call::Sleep(_))));
    }

    #[test]
    fn showing_the_same_pattern_again_does_not_flip() {
        let mut c = chain();
        let p = ProjectorPattern::Checker(Checker {
            period_px: NonZeroU32::new(4).unwrap(),
            phase_px: [0, 0],
            low: Level::ZERO,
            high: Level::FULL,
        });
        c.show(p).unwrap();
        c.scanout_mut().calls.clear();
        let t = c.scanout().clock;
        c.show(p).unwrap();
        assert!(c.scanout().calls.is_empty());
        assert_eq!(c.scanout().clock, t);
        // The checker is on screen: (0,0) high, (2,0) low.
        assert_eq!(c.scanout().screen_code(0, 0), Some(255));
        assert_eq!(c.scanout().screen_code(2, 0), Some(0));
        assert_eq!(c.scanout().screen_code(2, 2), Some(255));
    }

    #[test]
    fn missing_flip_event_is_a_timeout_naming_the_output_and_next_show_modesets() {
        let mut c = chain();
        c.show(ProjectorPattern::Black).unwrap();
        c.scanout_mut().drop_flips = true;
        let err = c.show(uniform(1.0)).unwrap_err();
        let text = err.to_string();
        assert!(text.contains("fake:HDMI-A-1"), "{text}");
        assert!(text.contains("waiting for the page flip"), "{text}");
        assert!(text.contains("500ms"), "{text}");
        assert!(
            matches!(&err, DriverError::Io { source, .. } if source.kind() == io::ErrorKind::TimedOut)
        );
        assert!(!c.is_showing());
        assert_eq!(c.pattern(), ProjectorPattern::Black);

        // Recovery: the same pattern is shown again, by a modeset into the
        // buffer that was not on screen.
        let s = c.scanout_mut();
        s.drop_flips = false;
        s.pending = None;
        s.calls.clear();
        c.show(uniform(1.0)).unwrap();
        assert_eq!(c.scanout().calls[..2], [Call::Draw(1), Call::SetCrtc(1)]);
        assert_eq!(c.scanout().screen_code(0, 0), Some(255));
        assert_eq!(c.pattern(), uniform(1.0));
    }

    #[test]
    fn render_error_names_the_output() {
        struct Tiny(FakeScanout);
        impl Scanout for Tiny {
            fn name(&self) -> &str {
                "fake:DP-2"
            }
            fn size(&self) -> (u32, u32) {
                (1000, 1000)
            }
            fn stride(&self) -> usize {
                4000
            }
            fn with_buffer(
                &mut self,
                index: usize,
                draw: &mut dyn FnMut(&mut [u8]),
            ) -> Result<(), DriverError> {
                self.0.with_buffer(index, draw)
            }
            fn set_crtc(&mut self, index: usize) -> Result<(), DriverError> {
                self.0.set_crtc(index)
            }
            fn page_flip(&mut self, index: usize) -> Result<(), DriverError> {
                self.0.page_flip(index)
            }
            fn wait_flip(&mut self, t: Duration) -> Result<Option<Duration>, DriverError> {
                self.0.wait_flip(t)
            }
        }
        let mut c = FlipChain::new(Tiny(FakeScanout::new()), Gamma::DEFAULT, timing());
        let err = c.show(ProjectorPattern::Black).unwrap_err().to_string();
        assert!(err.contains("fake:DP-2"), "{err}");
        assert!(err.contains("too small"), "{err}");
        assert!(c
            .scanout()
            .0
            .calls
            .iter()
            .all(|c| !matches!(c, Call::SetCrtc(_))));
    }
}
