//! The touch pipeline's events to the sinks, with the link's name (and the image a decision was
//! made on), and the gate's action when it changes.

use super::{Event, OverForce, Session, SessionError, Sink, send};
use crate::touch::TouchEvent;
use skin_control::hri::GateAction;
use skin_core::image::Image;

impl Session {
    /// The pipeline's events of this frame, to the sink.
    pub(super) fn emit<S: Sink + ?Sized>(&mut self, sink: &mut S) -> Result<(), SessionError> {
        let events = std::mem::take(&mut self.touch_events);
        let result = events.iter().try_for_each(|e| self.emit_one(e, sink));
        self.touch_events = events;
        result?;
        // Force changes from frame to frame within a touch: with force limits, the gate is
        // weighed at every frame, not only when a touch is decided or released (from the first
        // decision on, as without limits).
        let limits = (self.setup.options.gate.as_ref()).is_some_and(|g| !g.force_n.is_empty());
        if limits && (self.gate.is_some() || self.pipeline.open_decisions().next().is_some()) {
            self.update_gate(self.last_time, sink)?;
        }
        Ok(())
    }

    fn emit_one<S: Sink + ?Sized>(&mut self, e: &TouchEvent, sink: &mut S) -> Result<(), SessionError> {
        if let TouchEvent::Released(touch) = e {
            self.ended(touch);
            if let Some(o) = self.over_force.get_mut(touch.link)
                && *o == Some(touch.id)
            {
                *o = None;
            }
        }
        let name = |l: usize| self.setup.links[l].name.clone();
        let event = match e {
            TouchEvent::Appeared(touch) => Event::Appeared {
                link: name(touch.link),
                touch: touch.clone(),
            },
            TouchEvent::Classified(touch) => {
                let image = self
                    .pipeline
                    .last_image(touch.link)
                    .map(Image::from)
                    .unwrap_or_default();
                Event::Classified {
                    link: name(touch.link),
                    touch: touch.clone(),
                    image,
                }
            }
            TouchEvent::Released(touch) => Event::Released {
                link: name(touch.link),
                touch: touch.clone(),
            },
        };
        send(&mut self.stopped, sink, |s| s.event(&event))?;
        match e {
            TouchEvent::Classified(t) => self.update_gate(t.time, sink),
            TouchEvent::Released(t) => self.update_gate(t.time, sink),
            TouchEvent::Appeared(_) => Ok(()),
        }
    }

    /// The gate: the action of the most severe touch in progress; `stop` while a touch that
    /// pressed past its class's force limit lasts. Each touch that crosses its limit is named in
    /// a gate event, even when the gate was at `stop` already.
    fn update_gate<S: Sink + ?Sized>(&mut self, time: f64, sink: &mut S) -> Result<(), SessionError> {
        let Some(gate) = &self.setup.options.gate else {
            return Ok(());
        };
        let mut over = None;
        for (link, id, touch, saturated) in self.pipeline.open_gate_touches() {
            // A reading past saturation makes the force a lower bound, and a force that is no
            // number weighs nothing: with a limit set, either is past it as far as the gate
            // can tell.
            let unsure = saturated || touch.force_n.is_some_and(f64::is_nan);
            let crossed = gate
                .force_crossed(&touch)
                .or_else(|| gate.force_n.get(touch.class).copied().filter(|_| unsure));
            if let Some(limit_n) = crossed
                && self.over_force[link] != Some(id)
            {
                self.over_force[link] = Some(id);
                over.get_or_insert_with(|| OverForce {
                    link: self.setup.links[link].name.clone(),
                    touch: id,
                    force_n: touch.force_n.unwrap_or(f64::NAN),
                    limit_n,
                    saturated,
                });
            }
        }
        let action = match self.over_force.iter().any(Option::is_some) {
            true => GateAction::Stop,
            false => gate.decide(self.pipeline.open_gate_touches().map(|(_, _, t, _)| t)),
        };
        if self.gate != Some(action) || over.is_some() {
            self.gate = Some(action);
            let over = over.filter(|_| action == GateAction::Stop);
            send(&mut self.stopped, sink, |s| {
                s.event(&Event::Gate { time, action, over })
            })?;
        }
        Ok(())
    }
}
