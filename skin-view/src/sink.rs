//! [`ViewSink`]: a session's frames, events and images on their way to the page. On the frame
//! path it encodes the frame into a buffer it keeps and swaps it into the hub: a few
//! microseconds, no allocation, and never a wait on a browser.

use crate::hub::{Hub, writable};
use crate::scene::{GATE_ACTIONS, Scene};
use crate::wire::{self, FrameHead, STITCHED, WireContact, WirePlacement};
use skin_core::image::ImageView;
use skin_runtime::session::{Event, Flow, FrameView, ProcessedFrame, Sink};
use std::collections::HashMap;
use std::sync::Arc;

/// What the sink needs of the scene on the frame path.
#[derive(Debug)]
pub(crate) struct Geometry {
    /// Each link's taxels on its map, mm.
    pub uv_mm: Vec<Vec<[f32; 2]>>,
    /// Module index by bus, then address.
    pub modules: HashMap<String, HashMap<u32, u32>>,
    /// Link index by name.
    pub links: HashMap<String, u32>,
}

impl Geometry {
    pub fn of(scene: &Scene) -> Geometry {
        Geometry {
            uv_mm: scene.links.iter().map(|l| l.uv_mm.clone()).collect(),
            modules: scene.modules.iter().enumerate().fold(
                HashMap::new(),
                |mut by_bus: HashMap<String, HashMap<u32, u32>>, (k, m)| {
                    by_bus
                        .entry(m.bus.clone())
                        .or_default()
                        .insert(m.address, k as u32);
                    by_bus
                },
            ),
            links: scene
                .links
                .iter()
                .enumerate()
                .map(|(k, l)| (l.name.clone(), k as u32))
                .collect(),
        }
    }

    /// The pressure-weighted centroid on `link`'s map of `taxels` (mm); the plain mean when
    /// none is pressed.
    pub fn centroid(&self, link: usize, taxels: &[usize], pressures: &[f32]) -> [f32; 2] {
        let Some(uv) = self.uv_mm.get(link) else {
            return [0.0, 0.0];
        };
        let (mut sw, mut su, mut sv, mut n, mut pu, mut pv) = (0f64, 0f64, 0f64, 0f64, 0f64, 0f64);
        for &i in taxels {
            let Some(p) = uv.get(i) else { continue };
            let w = f64::from(pressures.get(i).copied().unwrap_or(0.0).max(0.0));
            sw += w;
            su += w * f64::from(p[0]);
            sv += w * f64::from(p[1]);
            n += 1.0;
            pu += f64::from(p[0]);
            pv += f64::from(p[1]);
        }
        if sw > 0.0 {
            [(su / sw) as f32, (sv / sw) as f32]
        } else if n > 0.0 {
            [(pu / n) as f32, (pv / n) as f32]
        } else {
            [0.0, 0.0]
        }
    }
}

/// Hands frames and events to the page. Implements [`Sink`]: pass it to a session's `push`,
/// `push_can`, `run_log` or `run_recording`, alone or beside other sinks (a tuple of sinks is a
/// sink). Made by [`Viewer::sink`](crate::Viewer::sink).
pub struct ViewSink {
    hub: Arc<Hub>,
    geometry: Arc<Geometry>,
    /// The frame being encoded (swapped with the hub's latest: see [`crate::hub::writable`]).
    buffer: Arc<Vec<u8>>,
    image: Arc<Vec<u8>>,
    /// An event's JSON line, being written.
    line: Vec<u8>,
    contacts: Vec<WireContact>,
    placements: Vec<WirePlacement>,
    /// Modules missing from the frame at hand (its `incomplete` event comes before it).
    missing: Vec<u32>,
    head: FrameHead,
    /// Links: the image slots before the stitched arm's.
    links: usize,
}

impl std::fmt::Debug for ViewSink {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ViewSink")
            .field("head", &self.head)
            .finish_non_exhaustive()
    }
}

/// Milliseconds since the Unix epoch, now.
pub(crate) fn now_ms() -> f64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64() * 1e3)
}

impl ViewSink {
    pub(crate) fn new(hub: Arc<Hub>, geometry: Arc<Geometry>) -> ViewSink {
        let links = geometry.uv_mm.len();
        ViewSink {
            hub,
            geometry,
            buffer: Arc::new(Vec::new()),
            image: Arc::new(Vec::new()),
            line: Vec::new(),
            contacts: Vec::new(),
            placements: Vec::new(),
            missing: Vec::new(),
            head: FrameHead::default(),
            links,
        }
    }

    /// Publishes a frame: `pressures` per link (scene order), `contacts` as `(link, taxels,
    /// mean, peak, force in N or NaN)`, the links' placements in the stitched plane (empty: not
    /// stitched).
    pub(crate) fn publish<'a>(
        &mut self,
        time: f64,
        cycle: u64,
        pressures: &[impl AsRef<[f32]>],
        contacts: impl Iterator<Item = (usize, &'a [usize], f32, f32, f32)>,
        placements: &[skin_geom::Placement],
    ) {
        self.placements.clear();
        self.placements.extend(placements.iter().map(|p| WirePlacement {
            angle: p.angle as f32,
            offset_mm: [(p.offset.x * 1e3) as f32, (p.offset.y * 1e3) as f32],
        }));
        self.contacts.clear();
        for (link, taxels, mean, peak, force_n) in contacts {
            let p = pressures.get(link).map_or(&[][..], AsRef::as_ref);
            self.contacts.push(WireContact {
                link: link as u32,
                uv_mm: self.geometry.centroid(link, taxels, p),
                taxels: taxels.len() as u32,
                mean,
                peak,
                force_n,
            });
        }
        self.head.number = self.head.number.wrapping_add(1);
        self.head.frames = self.head.frames.saturating_add(1);
        self.head.time = time;
        self.head.cycle = cycle;
        self.head.handed_ms = now_ms();
        wire::encode_frame(
            writable(&mut self.buffer),
            &self.head,
            &self.missing,
            &self.contacts,
            &self.placements,
            pressures.iter().map(AsRef::as_ref),
        );
        self.missing.clear();
        self.hub.put_frame(&mut self.buffer);
    }

    /// Counts and marks what an event says about the frame (missing modules, counter resets,
    /// the gate), and passes it on as its events.jsonl line.
    pub(crate) fn note(&mut self, event: &Event, line: &str) {
        match event {
            Event::Incomplete { missing, .. } => {
                self.head.incomplete = self.head.incomplete.saturating_add(1);
                self.missing.clear();
                for m in missing {
                    if let Some(&k) = self.geometry.modules.get(&m.bus).and_then(|b| b.get(&m.address)) {
                        self.missing.push(k);
                    }
                }
                // Counted and shown with the frame; kept out of the events a browser is sent
                // (a module that stays dead would push the touches out of the last 4,096).
                return;
            }
            Event::CounterReset { .. } => self.head.resets = self.head.resets.saturating_add(1),
            Event::Gate { action, .. } => {
                self.head.gate = GATE_ACTIONS
                    .iter()
                    .position(|a| *a == action.name())
                    .map_or(0, |k| k as u32 + 1);
            }
            Event::Classified {
                link, image, touch, ..
            } => {
                if let Some(&k) = self.geometry.links.get(link) {
                    self.put_image(k, true, touch.time, image.view());
                }
            }
            _ => {}
        }
        self.hub.put_event(Arc::from(line));
    }

    fn put_image(&mut self, view: u32, decision: bool, time: f64, image: ImageView<'_, u8>) {
        wire::encode_image(
            writable(&mut self.image),
            view,
            decision,
            time,
            image.size().rows,
            image.size().cols,
            image.pixels(),
        );
        let slot = if view == STITCHED {
            self.links
        } else {
            view as usize
        };
        self.hub.put_image(slot, &mut self.image);
    }
}

impl Sink for ViewSink {
    type Error = std::convert::Infallible;

    fn event(&mut self, event: &Event) -> Result<Flow, Self::Error> {
        let mut line = std::mem::take(&mut self.line);
        line.clear();
        // Events are plain fields: writing one as JSON does not fail (if it did, the event would
        // still be counted, with an empty line).
        let _ = event.write_json(&mut line);
        self.note(event, std::str::from_utf8(&line).unwrap_or(""));
        self.line = line;
        Ok(Flow::Continue(()))
    }

    fn frame_image(
        &mut self,
        view: FrameView<'_>,
        cycle: u64,
        image: ImageView<'_, u8>,
    ) -> Result<Flow, Self::Error> {
        let _ = cycle;
        let v = match view {
            FrameView::Link(name) => match self.geometry.links.get(name) {
                Some(&k) => k,
                None => return Ok(Flow::Continue(())),
            },
            FrameView::Stitched => STITCHED,
        };
        let time = self.head.time;
        self.put_image(v, false, time, image);
        Ok(Flow::Continue(()))
    }

    fn frame(&mut self, frame: &ProcessedFrame<'_>) -> Result<Flow, Self::Error> {
        let links = frame.pressures.len();
        let contacts = (0..links).flat_map(|k| {
            frame.contacts(k).iter().map(move |c| {
                let force = c.force_n.map_or(f32::NAN, |f| f as f32);
                (k, c.taxels.as_slice(), c.mean_pressure, c.peak_pressure, force)
            })
        });
        self.publish(
            frame.time,
            frame.cycle,
            frame.pressures,
            contacts,
            frame.stitched_placements(),
        );
        Ok(Flow::Continue(()))
    }
}
