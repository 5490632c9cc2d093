//! One frame through the whole path: readings, baseline, touch pipeline, events out.

use super::{CORRECTION_QUIET_FRAMES, Event, Flow, FrameView, ProcessedFrame, Session, SessionError, Sink};
use super::{flow, send};
use std::time::Instant;

impl Session {
    /// One frame from any source: `readings[link][taxel]` in layout order, at `time_us`
    /// (microseconds, any origin: times in events count from the first frame); `cycle` numbers
    /// the frame (image names). Every taxel must have a reading. [`Flow::Break`] once a sink
    /// has said stop (the frame is then not taken).
    pub fn push<S: Sink + ?Sized>(
        &mut self,
        time_us: u64,
        cycle: u64,
        readings: &[impl AsRef<[f32]>],
        sink: &mut S,
    ) -> Result<Flow, SessionError> {
        if self.stopped {
            return Ok(flow(true));
        }
        let time = self.time(time_us, sink)?;
        let length = |what, got, expected| SessionError::Frame {
            time,
            source: skin_core::Error::Length { what, got, expected },
        };
        if readings.len() != self.raw.len() {
            return Err(length("links' readings", readings.len(), self.raw.len()));
        }
        for (dst, src) in self.raw.iter_mut().zip(readings) {
            let src = src.as_ref();
            if src.len() != dst.len() {
                return Err(length("readings of a link", src.len(), dst.len()));
            }
            dst.copy_from_slice(src);
        }
        self.step(time_us, time, cycle, true, sink)?;
        Ok(flow(self.stopped))
    }

    /// Seconds from the first frame (whose stamp the sink is told).
    pub(super) fn time<S: Sink + ?Sized>(&mut self, time_us: u64, sink: &mut S) -> Result<f64, SessionError> {
        let t0 = match self.t0_us {
            Some(t0) => t0,
            None => {
                self.t0_us = Some(time_us);
                send(&mut self.stopped, sink, |s| s.origin(time_us))?;
                time_us
            }
        };
        Ok(time_us.saturating_sub(t0) as f64 * 1e-6)
    }

    /// The frame in `self.raw` through the whole path; then what a tare asked for from another
    /// thread is judged by (the gate, the baseline), or refused from now on once the session
    /// stopped or failed.
    pub(super) fn step<S: Sink + ?Sized>(
        &mut self,
        time_us: u64,
        time: f64,
        cycle: u64,
        complete: bool,
        sink: &mut S,
    ) -> Result<(), SessionError> {
        let raw = super::RawFrame {
            time_us,
            time,
            cycle,
            complete,
            readings: &self.raw,
        };
        send(&mut self.stopped, sink, |s| s.raw_frame(&raw))?;
        let result = self.step_frame(time_us, time, cycle, complete, sink);
        let stops = self.gate == Some(skin_control::hri::GateAction::Stop);
        self.tares.set_state(stops, self.base.baselines.is_empty());
        if self.stopped || result.is_err() {
            self.tares.stop();
        }
        result
    }

    fn step_frame<S: Sink + ?Sized>(
        &mut self,
        time_us: u64,
        time: f64,
        cycle: u64,
        complete: bool,
        sink: &mut S,
    ) -> Result<(), SessionError> {
        let started = Instant::now();
        self.stats.frames += 1;
        self.last_time = time;
        self.start_tare(time, sink)?;
        if self.base.baselines.is_empty() {
            if complete {
                self.learn(started)?;
            }
            return Ok(());
        }
        self.apply_baseline(time)?;
        self.stats.baseline += started.elapsed();
        self.end_corrections(time, CORRECTION_QUIET_FRAMES, sink)?;
        self.touch_events.clear();
        self.place_links(time_us, time);
        self.pipeline
            .process(time, &self.pressures, &mut self.touch_events)?;
        let t = Instant::now();
        self.emit(sink)?;
        self.report_joint_faults(time, sink)?;
        self.across_joints(time, sink)?;
        let frame = ProcessedFrame {
            time_us,
            time,
            cycle,
            pressures: &self.pressures,
            pipeline: &self.pipeline,
            stitched: self
                .setup
                .stitching
                .as_ref()
                .map_or(&[], |s| s.placements_at(time)),
        };
        send(&mut self.stopped, sink, |s| s.frame(&frame))?;
        if self.setup.options.frame_images {
            for l in 0..self.setup.links.len() {
                if self.pipeline.touching(l) {
                    let image = self.pipeline.frame_image(l, &self.pressures[l])?;
                    let view = FrameView::Link(&self.setup.links[l].name);
                    send(&mut self.stopped, sink, |s| s.frame_image(view, cycle, image))?;
                }
            }
        }
        self.stitched_image(cycle, sink)?;
        self.stats.output += t.elapsed();
        self.tares.set_touches(self.pipeline.open_touches());
        Ok(())
    }

    /// A complete frame before the baseline is learned: it learns it.
    fn learn(&mut self, started: Instant) -> Result<(), SessionError> {
        let b = &mut self.base;
        b.learner.push(&self.raw)?;
        if b.learner.is_done() {
            for (baseline, health) in b.learner.finish(&self.setup.source)? {
                b.baselines.push(baseline);
                b.health.push(health);
            }
            self.learned = true;
        }
        self.stats.baseline += started.elapsed();
        Ok(())
    }

    /// Pressures of the frame in `self.raw`, and the baseline corrections it makes.
    fn apply_baseline(&mut self, time: f64) -> Result<(), SessionError> {
        let b = &mut self.base;
        for (l, ((baseline, raw), p)) in b
            .baselines
            .iter_mut()
            .zip(&self.raw)
            .zip(&mut self.pressures)
            .enumerate()
        {
            let reset = baseline
                .apply(raw, p)
                .map_err(|source| SessionError::Frame { time, source })?;
            let c = &mut b.correcting[l];
            if reset > 0 {
                c.since.get_or_insert(time);
                c.quiet = 0;
            } else if c.since.is_some() {
                c.quiet += 1;
            }
        }
        Ok(())
    }

    /// Contacts across joints: an event when one begins and when none is left. Before the
    /// frame goes to the sinks, as every event of the frame does: a consumer that waits for a
    /// frame has its events by then.
    fn across_joints<S: Sink + ?Sized>(&mut self, time: f64, sink: &mut S) -> Result<(), SessionError> {
        let Some(st) = &mut self.setup.stitching else {
            return Ok(());
        };
        let options = self.pipeline.options();
        let spans = st.spanning(&self.pressures, options.threshold, time, options.min_taxels)?;
        let links = &self.setup.links;
        if !spans.is_empty() && !st.joined {
            self.stats.across_joints += 1;
            for s in &spans {
                let event = Event::AcrossJoint {
                    time,
                    links: s.links.iter().map(|&l| links[l].name.clone()).collect(),
                    taxels: s.taxels,
                    centroid: s.centroid,
                };
                send(&mut self.stopped, sink, |s| s.event(&event))?;
            }
        } else if spans.is_empty() && st.joined {
            send(&mut self.stopped, sink, |s| {
                s.event(&Event::AcrossJointEnd { time })
            })?;
        }
        st.joined = !spans.is_empty();
        Ok(())
    }

    /// The stitched image of a frame with a touch (with frame images asked for).
    fn stitched_image<S: Sink + ?Sized>(&mut self, cycle: u64, sink: &mut S) -> Result<(), SessionError> {
        let Some(st) = &mut self.setup.stitching else {
            return Ok(());
        };
        let links = self.setup.links.len();
        if self.setup.options.frame_images && (0..links).any(|l| self.pipeline.touching(l)) {
            let image = st.image()?;
            send(&mut self.stopped, sink, |s| {
                s.frame_image(FrameView::Stitched, cycle, image)
            })?;
        }
        Ok(())
    }

    /// Baseline corrections quiet for `quiet` frames are over: an event each.
    pub(super) fn end_corrections<S: Sink + ?Sized>(
        &mut self,
        time: f64,
        quiet: u32,
        sink: &mut S,
    ) -> Result<(), SessionError> {
        let b = &mut self.base;
        for (l, (c, baseline)) in b.correcting.iter_mut().zip(&mut b.baselines).enumerate() {
            let Some(since) = c.since.filter(|_| c.quiet >= quiet) else {
                continue;
            };
            let taxels = baseline.take_corrected();
            c.since = None;
            c.events += 1;
            c.taxels += taxels as u64;
            let event = Event::BaselineCorrected {
                time,
                since,
                link: self.setup.links[l].name.clone(),
                taxels,
            };
            send(&mut self.stopped, sink, |s| s.event(&event))?;
        }
        Ok(())
    }

    /// The end of the input: touches still open are released. Fails if the baseline was never
    /// learned. [`Flow::Break`] if a sink has said stop (nothing is then released).
    pub fn finish<S: Sink + ?Sized>(&mut self, sink: &mut S) -> Result<Flow, SessionError> {
        // No frame comes after: a tare asked for from now on is refused.
        self.tares.stop();
        if self.stopped {
            return Ok(flow(true));
        }
        if !self.learned {
            return Err(super::InputError::TooShort {
                frames: self.stats.frames,
                needed: self.setup.options.baseline_frames,
            }
            .into());
        }
        if self.base.baselines.is_empty() {
            // A tare still learning: nothing is open (it released every touch).
            return Ok(flow(self.stopped));
        }
        self.end_corrections(self.last_time, 0, sink)?;
        self.touch_events.clear();
        self.pipeline.finish(self.last_time, &mut self.touch_events)?;
        self.emit(sink)?;
        Ok(flow(self.stopped))
    }
}
