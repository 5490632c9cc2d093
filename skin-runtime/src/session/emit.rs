//! The touch pipeline's events to the sinks, with the link's name (and the image a decision was
//! made on), and the gate's action when it changes.

use super::{Event, Session, SessionError, Sink, send};
use crate::touch::TouchEvent;
use skin_core::image::Image;

impl Session {
    /// The pipeline's events of this frame, to the sink.
    pub(super) fn emit<S: Sink + ?Sized>(&mut self, sink: &mut S) -> Result<(), SessionError> {
        let events = std::mem::take(&mut self.touch_events);
        let result = events.iter().try_for_each(|e| self.emit_one(e, sink));
        self.touch_events = events;
        result
    }

    fn emit_one<S: Sink + ?Sized>(&mut self, e: &TouchEvent, sink: &mut S) -> Result<(), SessionError> {
        if let TouchEvent::Released(touch) = e {
            self.ended(touch);
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

    /// The gate: the action of the most severe touch in progress.
    fn update_gate<S: Sink + ?Sized>(&mut self, time: f64, sink: &mut S) -> Result<(), SessionError> {
        let Some(gate) = &self.setup.options.gate else {
            return Ok(());
        };
        let action = gate.decide(
            self.pipeline
                .open_decisions()
                .map(crate::touch::Decision::gate_touch),
        );
        if self.gate != Some(action) {
            self.gate = Some(action);
            send(&mut self.stopped, sink, |s| {
                s.event(&Event::Gate { time, action })
            })?;
        }
        Ok(())
    }
}
