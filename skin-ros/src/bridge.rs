//! A session's output as ROS 2 messages: [`RosSink`] is a [`Sink`] that turns each frame and
//! event into the messages of [`crate::topics`] and hands them, as CDR, to an [`Outlet`]: an
//! MCAP file ([`crate::McapOutlet`], feature `mcap`), a live Zenoh session
//! ([`crate::ZenohOutlet`], feature `zenoh`), or anything a robot stack writes.
//!
//! Stamps: a frame's is its time on the input's clock (a candump log's or
//! the live bus's time since the epoch; a recording's time since its first frame), an event's
//! is the session's first frame plus the event's time; with [`RosTime::Rebase`] both count from
//! 0 at the first frame. A time ROS 2 cannot hold (past 2038 on the input's clock) is an error
//! of the sink, never a clamped stamp. Frame ids are [`Topics::frame_ids`].

use crate::cdr::CdrWriter;
use crate::clock::{Clock, RosTime};
use crate::messages::{
    self, Arrow, ContactMsg, EventKind, FootprintMsg, HandPartMsg, PointCloud, Stamp, TouchEventMsg,
};
use crate::topics::{PrefixError, Topics};
use skin_core::LinkSkin;
use skin_core::image::ImageView;
use skin_runtime::parts::PartContact;
use skin_runtime::session::{Description, Event, Flow, ProcessedFrame, Readings, Sink};
use skin_runtime::touch::Footprint;

/// Where a [`RosSink`]'s messages go.
pub trait Outlet {
    /// One message on `topic` (an index into the [`Topics::list`] the outlet was opened with),
    /// stamped `stamp_ns` (ns), as CDR with its encapsulation header.
    fn publish(&mut self, topic: usize, stamp_ns: u64, cdr: &[u8]) -> std::io::Result<()>;
}

/// Collects messages in memory (tests, a stack that polls): (topic, stamp ns, CDR).
impl Outlet for Vec<(usize, u64, Vec<u8>)> {
    fn publish(&mut self, topic: usize, stamp_ns: u64, cdr: &[u8]) -> std::io::Result<()> {
        self.push((topic, stamp_ns, cdr.to_vec()));
        Ok(())
    }
}

/// What a [`RosSink`] publishes beyond the defaults.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RosOptions {
    /// Topic prefix, `/skin` by default.
    pub prefix: String,
    /// Also publish each decision's pressure image (`32FC1`, counts) on
    /// `PREFIX/<link>/pressure_image`.
    pub pressure_images: bool,
}

impl RosOptions {
    /// The topics a skin with `links` (layout order) publishes under these options (what an
    /// outlet is opened with).
    pub fn topics(&self, links: &[LinkSkin]) -> Result<Topics, PrefixError> {
        let names: Vec<&str> = links.iter().map(|l| l.name.as_str()).collect();
        Topics::new(&self.prefix, &names, self.pressure_images)
    }
}

impl Default for RosOptions {
    fn default() -> Self {
        RosOptions {
            prefix: "/skin".into(),
            pressure_images: false,
        }
    }
}

/// Arrow length, m: drawn from outside the skin to the contact.
const ARROW_M: f64 = 0.03;

/// A [`Sink`] that publishes a session as ROS 2 messages: its frames and events, through an
/// [`Outlet`].
pub struct RosSink<O: Outlet> {
    outlet: O,
    topics: Topics,
    names: Vec<String>,
    ids: Vec<Vec<u32>>,
    normals: Vec<Vec<[f64; 3]>>,
    clouds: Vec<PointCloud>,
    w: CdrWriter,
    json: Vec<u8>,
    clock: Clock,
    /// Links whose decision's pressure image is still to publish.
    pending_images: Vec<bool>,
    /// Arrows are on screen (a frame without contacts clears them once).
    arrows_shown: bool,
    /// The skin described, published once at the first frame ([`RosSink::describing`]).
    description: Option<Description>,
    /// Per link, its dead taxels (layout indices).
    dead: Vec<Vec<usize>>,
}

impl<O: Outlet> std::fmt::Debug for RosSink<O> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RosSink")
            .field("topics", &self.topics.list.len())
            .finish_non_exhaustive()
    }
}

impl<O: Outlet> RosSink<O> {
    /// A sink for a session over `links` (layout order, as [`Session::links`] gives them),
    /// publishing `topics` ([`RosOptions::topics`]) to `outlet`. The point clouds are written now.
    ///
    /// [`Session::links`]: skin_runtime::session::Session::links
    pub fn new(links: &[LinkSkin], topics: Topics, outlet: O) -> RosSink<O> {
        let names: Vec<String> = links.iter().map(|l| l.name.clone()).collect();
        let ids: Vec<Vec<u32>> = links
            .iter()
            .map(|l| l.taxels.iter().map(|t| t.id.0).collect())
            .collect();
        let normals = links
            .iter()
            .map(|l| l.taxels.iter().map(|t| t.normal.into_inner().into()).collect())
            .collect();
        let clouds = links
            .iter()
            .zip(&ids)
            .enumerate()
            .map(|(k, (l, ids))| {
                let p: Vec<[f32; 3]> = l
                    .taxels
                    .iter()
                    .map(|t| [t.position.x as f32, t.position.y as f32, t.position.z as f32])
                    .collect();
                let frame_id = topics.frame_ids.get(k).map_or(l.name.as_str(), String::as_str);
                PointCloud::new(frame_id, &p, ids)
            })
            .collect();
        RosSink {
            outlet,
            pending_images: vec![false; names.len()],
            topics,
            names,
            ids,
            normals,
            clouds,
            w: CdrWriter::new(),
            json: Vec::with_capacity(512),
            clock: Clock::new(RosTime::Input),
            arrows_shown: false,
            description: None,
            dead: vec![Vec::new(); links.len()],
        }
    }

    /// Publishes `description` ([`Session::describe`]) as `skin_msgs/TactileLayout` on
    /// `PREFIX/layout` at the first frame (the first message of an MCAP file), and takes the
    /// dead taxels of the `tactile_state` topics from it. Set before the first frame.
    ///
    /// [`Session::describe`]: skin_runtime::session::Session::describe
    pub fn describing(mut self, description: Description) -> RosSink<O> {
        for (l, link) in description.links.iter().enumerate().take(self.dead.len()) {
            self.dead[l].clone_from(&link.dead);
        }
        self.description = Some(description);
        self
    }

    /// Stamps counted as `time` says (the input's clock unless told otherwise). Set before the
    /// first frame.
    pub fn ros_time(mut self, time: RosTime) -> RosSink<O> {
        self.clock = Clock::new(time);
        self
    }

    /// The outlet (its counts, its file).
    pub fn outlet(&self) -> &O {
        &self.outlet
    }

    /// The outlet, given back (to finish a file).
    pub fn into_outlet(self) -> O {
        self.outlet
    }

    /// The topics it publishes.
    pub fn topic_list(&self) -> &Topics {
        &self.topics
    }

    fn link(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n == name)
    }

    fn publish(&mut self, topic: usize, stamp_ns: u64) -> std::io::Result<()> {
        self.outlet.publish(topic, stamp_ns, self.w.bytes())
    }
}

/// The frame id of link `l` (empty for a link the topics do not know).
fn frame_id(ids: &[String], l: usize) -> &str {
    ids.get(l).map_or("", String::as_str)
}

fn footprint(f: &Footprint) -> FootprintMsg {
    FootprintMsg {
        contacts: f.contacts as u32,
        taxels: f.taxels as u32,
        area: (f.area_cm2 * 1e-4) as f32,
        mean_pressure: f.mean_pressure,
        centroid: f.centroid.coords.into(),
    }
}

/// Go on: a ROS sink never stops a run.
const GO: Flow = Flow::Continue(());

impl<O: Outlet> Sink for RosSink<O> {
    type Error = std::io::Error;

    fn origin(&mut self, origin_us: u64) -> std::io::Result<Flow> {
        self.clock.set_origin(origin_us).map_err(std::io::Error::other)?;
        if let Some(d) = &self.description {
            let (stamp_ns, stamp) = self.clock.frame(origin_us).map_err(std::io::Error::other)?;
            messages::tactile_layout(&mut self.w, stamp, d, &self.topics.frame_ids);
            self.publish(self.topics.layout, stamp_ns)?;
        }
        Ok(GO)
    }

    fn event(&mut self, event: &Event) -> std::io::Result<Flow> {
        let (stamp_ns, stamp) = self.clock.event(event.time()).map_err(std::io::Error::other)?;
        self.json.clear();
        event.write_json(&mut self.json).map_err(std::io::Error::other)?;
        let json = std::str::from_utf8(&self.json).map_err(std::io::Error::other)?;
        let m = event_message(event, json, &self.names, &self.topics.frame_ids);
        messages::touch_event(&mut self.w, stamp, &m);
        let events = self.topics.events;
        self.outlet.publish(events, stamp_ns, self.w.bytes())?;
        if let Event::Classified { link, image, .. } = event {
            self.publish_decision_image(link, image.view(), stamp, stamp_ns)?;
        }
        Ok(GO)
    }

    fn frame(&mut self, frame: &ProcessedFrame<'_>) -> std::io::Result<Flow> {
        let (stamp_ns, stamp) = self.clock.frame(frame.time_us).map_err(std::io::Error::other)?;
        for (l, pressures) in frame.pressures.iter().enumerate().take(self.clouds.len()) {
            let topic = self.topics.links[l].pressure;
            let bytes = self.clouds[l].fill(stamp, pressures);
            self.outlet.publish(topic, stamp_ns, bytes)?;
            self.publish_wrench(l, frame, stamp, stamp_ns)?;
            self.publish_state(l, frame, stamp, stamp_ns)?;
            if self.pending_images[l]
                && let (Some(topic), Some(image)) = (
                    self.topics.links[l].pressure_image,
                    frame.decision_pressure_image(l),
                )
            {
                self.pending_images[l] = false;
                let frame_id = frame_id(&self.topics.frame_ids, l);
                let size = image.size();
                messages::image_32fc1(&mut self.w, stamp, frame_id, size.rows, size.cols, image.pixels());
                self.publish(topic, stamp_ns)?;
            }
        }
        let links = self.names.len().min(frame.pressures.len());
        let count: usize = (0..links).map(|l| frame.contacts(l).len()).sum();
        if count == 0 {
            if self.arrows_shown {
                self.arrows_shown = false;
                messages::arrows(&mut self.w, stamp, std::iter::empty());
                self.publish(self.topics.markers, stamp_ns)?;
            }
            return Ok(GO);
        }
        // Each contact's normal: its taxels' normals weighted by pressure (the map has none).
        let normal = |l: usize, taxels: &[usize]| {
            let mut n = [0.0f64; 3];
            for &t in taxels {
                let p = f64::from(frame.pressures[l].get(t).copied().unwrap_or(0.0));
                let tn = self.normals[l].get(t).copied().unwrap_or_default();
                for k in 0..3 {
                    n[k] += p * tn[k];
                }
            }
            let norm = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            if norm > 0.0 { n.map(|x| x / norm) } else { [0.0; 3] }
        };
        let all = || (0..links).flat_map(move |l| frame.contacts(l).iter().map(move |c| (l, c)));
        let msgs = all().map(|(l, c)| ContactMsg {
            link: frame_id(&self.topics.frame_ids, l),
            position: c.centroid.coords.into(),
            normal: normal(l, &c.taxels),
            mean_pressure: c.mean_pressure,
            peak_pressure: c.peak_pressure,
            area: (frame.taxel_area_cm2(l).unwrap_or(0.0) * 1e-4 * c.taxels.len() as f64) as f32,
            taxels: &c.taxels,
            ids: &self.ids[l],
            force: c.force_n.unwrap_or(f64::NAN),
        });
        messages::contacts(&mut self.w, stamp, ExactSize(msgs, count));
        self.outlet
            .publish(self.topics.contacts, stamp_ns, self.w.bytes())?;
        let arrows = all().enumerate().map(|(k, (l, c))| {
            let n = normal(l, &c.taxels);
            let n = if n == [0.0; 3] { [0.0, 0.0, 1.0] } else { n };
            let end: [f64; 3] = c.centroid.coords.into();
            Arrow {
                frame_id: frame_id(&self.topics.frame_ids, l),
                id: k as i32,
                start: [0, 1, 2].map(|i| end[i] + ARROW_M * n[i]),
                end,
                color: [1.0, 0.2, 0.1, 1.0],
            }
        });
        messages::arrows(&mut self.w, stamp, ExactSize(arrows, count));
        self.outlet
            .publish(self.topics.markers, stamp_ns, self.w.bytes())?;
        self.arrows_shown = true;
        Ok(GO)
    }
}

/// An iterator whose length is known (a flattened one is not `ExactSizeIterator`).
struct ExactSize<I>(I, usize);

impl<I: Iterator> Iterator for ExactSize<I> {
    type Item = I::Item;
    fn next(&mut self) -> Option<I::Item> {
        let item = self.0.next()?;
        self.1 = self.1.saturating_sub(1);
        Some(item)
    }
    fn size_hint(&self) -> (usize, Option<usize>) {
        (self.1, Some(self.1))
    }
}

impl<I: Iterator> ExactSizeIterator for ExactSize<I> {}

impl<O: Outlet> RosSink<O> {
    /// Link `l`'s wrench in this frame, on a link with a wrench topic and a force model.
    fn publish_wrench(
        &mut self,
        l: usize,
        frame: &ProcessedFrame<'_>,
        stamp: Stamp,
        stamp_ns: u64,
    ) -> std::io::Result<()> {
        if let (Some(topic), Some(wrench)) = (self.topics.links[l].wrench, frame.wrench(l)) {
            let frame_id = frame_id(&self.topics.frame_ids, l);
            messages::wrench_stamped(
                &mut self.w,
                stamp,
                frame_id,
                wrench.force.into(),
                wrench.torque.into(),
            );
            self.publish(topic, stamp_ns)?;
        }
        Ok(())
    }

    /// Link `l`'s readings in this frame, in its unit, on `PREFIX/<link>/tactile_state`.
    fn publish_state(
        &mut self,
        l: usize,
        frame: &ProcessedFrame<'_>,
        stamp: Stamp,
        stamp_ns: u64,
    ) -> std::io::Result<()> {
        let (Some(topics), Some(readings)) = (self.topics.links.get(l), frame.readings(l)) else {
            return Ok(());
        };
        let topic = topics.state;
        let names = (
            frame_id(&self.topics.frame_ids, l),
            self.names[l].as_str(),
            readings.units().name(),
        );
        match readings {
            Readings::Counts(p) => {
                messages::tactile_state(&mut self.w, stamp, names, p.iter().copied(), &self.dead[l]);
            }
            Readings::Newtons(f) => {
                let values = f.iter().map(|&v| v as f32);
                messages::tactile_state(&mut self.w, stamp, names, values, &self.dead[l]);
            }
        }
        self.publish(topic, stamp_ns)
    }

    /// A decision's tactile image on its link's topic; its pressure image, when asked, follows
    /// with the next frame (the frame that carries it).
    fn publish_decision_image(
        &mut self,
        link: &str,
        image: ImageView<'_, u8>,
        stamp: Stamp,
        stamp_ns: u64,
    ) -> std::io::Result<()> {
        let Some(l) = self.link(link) else {
            return Ok(());
        };
        let frame_id = frame_of(&self.names, &self.topics.frame_ids, link);
        messages::image_mono8(
            &mut self.w,
            stamp,
            frame_id,
            image.size().rows,
            image.size().cols,
            image.pixels(),
        );
        let topic = self.topics.links[l].tactile_image;
        self.publish(topic, stamp_ns)?;
        self.pending_images[l] = self.topics.links[l].pressure_image.is_some();
        Ok(())
    }
}

/// A hand part's contact as `skin_msgs/HandPart` has it.
fn hand_part(p: &PartContact) -> HandPartMsg<'_> {
    HandPartMsg {
        part: p.part.name(),
        taxels: p.taxels as u32,
        mean_pressure: p.mean_pressure,
        centroid: p.centroid.map(|c| c.coords.into()),
    }
}

/// The frame id of a link named as events name it; empty for a link the topics do not know.
fn frame_of<'a>(names: &[String], frame_ids: &'a [String], link: &str) -> &'a str {
    names
        .iter()
        .position(|n| n == link)
        .and_then(|l| frame_ids.get(l))
        .map_or("", String::as_str)
}

/// The `skin_msgs/TouchEvent` of an event, its JSON line included.
fn event_message<'a>(
    event: &'a Event,
    json: &'a str,
    names: &[String],
    frame_ids: &'a [String],
) -> TouchEventMsg<'a> {
    let frame_of = |link: &str| frame_of(names, frame_ids, link);
    let mut m = TouchEventMsg {
        json,
        ..TouchEventMsg::default()
    };
    match event {
        Event::Incomplete { missing, .. } => {
            m.kind = EventKind::Incomplete;
            m.missing = missing.iter().map(|x| (x.bus.as_str(), x.address)).collect();
        }
        Event::CounterReset { bus, cycle, .. } => {
            m.kind = EventKind::CounterReset;
            m.bus = bus;
            m.cycle = *cycle;
        }
        Event::Appeared { link, touch } => {
            m.kind = EventKind::Appeared;
            m.link = link;
            m.frame_id = frame_of(link);
            m.touch = touch.id;
            m.footprint = footprint(&touch.footprint);
        }
        Event::Classified { link, touch, .. } => {
            let d = &touch.decision;
            m.kind = EventKind::Classified;
            m.link = link;
            m.frame_id = frame_of(link);
            m.touch = touch.id;
            m.revised = touch.revised;
            m.touch_class = d.class.name();
            m.probability = d.probability;
            m.parts = d.parts.iter().map(hand_part).collect();
        }
        Event::Released { link, touch } => {
            let d = touch.decision.as_ref();
            m.kind = EventKind::Released;
            m.link = link;
            m.frame_id = frame_of(link);
            m.touch = touch.id;
            m.duration = touch.duration;
            m.frames = touch.frames as u32;
            m.footprint = footprint(&touch.peak);
            m.touch_class = d.map_or("", |d| d.class.name());
            m.probability = d.map_or(f32::NAN, |d| d.probability);
        }
        Event::Gate { action, .. } => {
            m.kind = EventKind::Gate;
            m.action = action.name();
        }
        Event::AcrossJoint {
            links,
            taxels,
            centroid,
            ..
        } => {
            m.kind = EventKind::AcrossJoint;
            m.links = links.iter().map(String::as_str).collect();
            m.footprint.taxels = *taxels as u32;
            m.footprint.centroid = *centroid;
        }
        Event::AcrossJointEnd { .. } => m.kind = EventKind::AcrossJointEnd,
        Event::JointStates { .. } => m.kind = EventKind::JointStates,
        Event::Tare { frames, .. } => {
            m.kind = EventKind::Tare;
            m.frames = u32::try_from(*frames).unwrap_or(u32::MAX);
        }
        Event::BaselineCorrected {
            time,
            since,
            link,
            taxels,
        } => {
            m.kind = EventKind::BaselineCorrected;
            m.link = link;
            m.footprint.taxels = *taxels as u32;
            m.duration = time - since;
        }
    }
    m
}
