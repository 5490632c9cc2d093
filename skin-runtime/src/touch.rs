//! Touches, frame by frame: the per-frame path from pressures to decisions.
//!
//! For every link, each frame's pressures (after the baseline) go through [`ContactFinder`]; a
//! touch begins with the first frame holding a contact and ends after
//! [`TouchOptions::release_frames`] frames without one. While it lasts, the frame of largest total
//! pressure so far is kept; after [`TouchOptions::decide_frames`] frames of contact that frame is
//! imaged (map -> 1 mm grid -> contact-max grey -> erosion/dilation -> model size, thesis Ch. 4.5)
//! and classified by the [`Models`]' [`HandClassifier`](crate::model::HandClassifier), and a touch
//! of the hand class is segmented into its parts (Fig. 4.9). Without a classifier touches are
//! tracked (appeared, released) and not decided. The touch is classified
//! again whenever its total pressure has grown by [`TouchOptions::reclassify_growth`] since the
//! image last classified, so the final decision is that of the touch at its fullest, at a bounded
//! cost: a touch costs a few model runs, not one per frame.
//!
//! Frames without contact cost one contact search per link. The buffers are sized when the
//! pipeline is built; a frame allocates only when a model runs or an event is emitted.

mod records;
mod weigh;

pub use records::{Appeared, Classified, Decision, Footprint, Released, StageTimes, TouchEvent};

use crate::model::{Class, Classes, ModelError, Models};
use crate::parts::part_contacts;
use nalgebra::Point3;
use skin_core::image::{ImageSize, ImageView};
use skin_core::{Contact, ContactFinder, Separation};
use skin_geom::{TactileImager, TactileMap};
use std::path::Path;
use std::time::Instant;
use weigh::LinkForce;

/// What can go wrong building or running a [`TouchPipeline`].
#[derive(Debug, thiserror::Error)]
pub enum TouchError {
    /// A model failed to run or does not fit.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// The classifier or the segmenter failed on a touch's image: the frame, link and touch it
    /// was deciding, and the model's error.
    #[error("frame at {time:.3} s, link {link}, touch {touch}: {source}")]
    Decide {
        /// Frame time, s.
        time: f64,
        /// The link's name.
        link: String,
        /// The touch's number.
        touch: u64,
        /// What the model said.
        #[source]
        source: ModelError,
    },
    /// A link's map cannot be imaged.
    #[error("link {link}: {source}")]
    Map {
        /// The link.
        link: String,
        /// Why.
        source: skin_geom::Error,
    },
    /// A link's mesh is not usable for contact search.
    #[error("link {link}: {source}")]
    Mesh {
        /// The link.
        link: String,
        /// Why.
        source: skin_core::Error,
    },
    /// A link index beyond the skin's links.
    #[error("no link {link}: the skin has {links}")]
    NoLink {
        /// The index asked for.
        link: usize,
        /// Links of the skin.
        links: usize,
    },
    /// A force model that does not fit its link.
    #[error("link {link}: the force model: {source}")]
    Force {
        /// The link.
        link: String,
        /// What does not fit.
        source: skin_core::force::ForceError,
    },
    /// A frame does not have one pressure slice per link, or one pressure per taxel.
    #[error("frame at {time} s: {why}")]
    Frame {
        /// Frame time, seconds.
        time: f64,
        /// What is wrong.
        why: String,
    },
}

/// Thresholds and timing of touch tracking. [`Default`] is run.toml's `[touch]` when it sets
/// nothing ([`TouchConfig`](crate::session::TouchConfig) takes its defaults from here).
#[derive(Debug, Clone, PartialEq)]
pub struct TouchOptions {
    /// A taxel is pressed above this pressure (frame units, after the baseline; default 5
    /// counts, as the fixture sessions, the README and Python's sessions use).
    pub threshold: f32,
    /// Patches of fewer taxels are noise, not contacts.
    pub min_taxels: usize,
    /// Frames of contact before the first decision (3 = 150 ms at 20 Hz: past the first
    /// brush of the touch, well within the thesis' 70 ms + acquisition).
    pub decide_frames: usize,
    /// Frames without contact that end a touch.
    pub release_frames: usize,
    /// Classify again when the touch's total pressure exceeds this multiple of the image last
    /// classified.
    pub reclassify_growth: f32,
    /// Image grid step on the map, millimetres (thesis: 1 mm).
    pub step_mm: f64,
    /// How a patch of pressed taxels becomes contacts (default [`Separation::FINGERS`]: split
    /// between pressure peaks, so fingers side by side are separate contacts).
    pub separation: Separation,
}

impl Default for TouchOptions {
    fn default() -> Self {
        TouchOptions {
            threshold: 5.0,
            min_taxels: 2,
            decide_frames: 3,
            release_frames: 2,
            reclassify_growth: 1.25,
            step_mm: 1.0,
            separation: Separation::FINGERS,
        }
    }
}

struct Touch {
    id: u64,
    start: f64,
    last: f64,
    frames: usize,
    quiet: usize,
    peak_total: f64,
    peak: Footprint,
    classified_total: f64,
    decision: Option<Decision>,
}

impl Touch {
    /// A touch that appeared at `time` with this first footprint; its frames are counted after.
    fn new(id: u64, time: f64, footprint: Footprint) -> Self {
        Touch {
            id,
            start: time,
            last: time,
            frames: 0,
            quiet: 0,
            peak_total: 0.0,
            peak: footprint,
            classified_total: 0.0,
            decision: None,
        }
    }
}

/// The footprint of one link's contacts in a frame, with its total pressure (the sum over its
/// taxels, which picks a touch's fullest frame); `None` when no taxel is in contact.
fn footprint_of(contacts: &[Contact], area_per_taxel_cm2: f64) -> Option<(Footprint, f64)> {
    let mut taxels = 0usize;
    let mut total = 0.0f64;
    let mut moment = nalgebra::Vector3::zeros();
    let mut force_n = Some(0.0);
    for c in contacts {
        force_n = force_n.zip(c.force_n).map(|(a, b)| a + b);
        let sum = f64::from(c.mean_pressure) * c.taxels.len() as f64;
        taxels += c.taxels.len();
        total += sum;
        moment += c.centroid.coords * sum;
    }
    if taxels == 0 {
        return None;
    }
    let footprint = Footprint {
        contacts: contacts.len(),
        taxels,
        area_cm2: taxels as f64 * area_per_taxel_cm2,
        mean_pressure: (total / taxels as f64) as f32,
        force_n,
        centroid: Point3::from(moment / total),
        centroid_base: None,
    };
    Some((footprint, total))
}

/// The most likely class and its probability; a classifier that scores another number of
/// classes than its card names is an error, not a guess.
fn most_likely(probabilities: &[f32], classes: &Classes) -> Result<(Class, f32), ModelError> {
    let (best, probability) =
        probabilities
            .iter()
            .copied()
            .enumerate()
            .fold(
                (0, f32::NEG_INFINITY),
                |best, (c, p)| if p > best.1 { (c, p) } else { best },
            );
    match classes.get(best) {
        Some(c) if probabilities.len() == classes.len() => Ok((c.clone(), probability)),
        _ => Err(ModelError::Run(
            format!(
                "{} class scores from the classifier, for {} classes",
                probabilities.len(),
                classes.len()
            )
            .into(),
        )),
    }
}

struct Link {
    name: String,
    map: TactileMap,
    finder: ContactFinder,
    imager: TactileImager,
    area_per_taxel_cm2: f64,
    /// Pressures of the touch's fullest frame so far, thresholded.
    peak_pressures: Vec<f32>,
    /// Thresholded pressures of a frame imaged for output.
    scratch: Vec<f32>,
    touch: Option<Touch>,
    /// Taxels without readings, bridged by the finder's and imager's triangles.
    dead: Vec<usize>,
    /// Each taxel's distance from the skin's border on the map (as built), millimetres.
    border_mm: Vec<f32>,
    /// The force model, with a force calibration.
    force: Option<LinkForce>,
    /// The link's pose in the chain's base frame at this frame, when known
    /// ([`TouchPipeline::set_pose`]).
    pose: Option<nalgebra::Isometry3<f64>>,
}

impl Link {
    /// How near the taxels of the touch's image (its contacts at their fullest) come to the
    /// skin's border, millimetres; infinite with none.
    fn image_border_mm(&self) -> f32 {
        self.peak_pressures
            .iter()
            .zip(&self.border_mm)
            .filter(|&(&p, _)| p > 0.0)
            .map(|(_, &d)| d)
            .fold(f32::INFINITY, f32::min)
    }
}

/// The contact search and the imager of a link's map (`map.name` names it in errors). A tactile
/// map carries no normals: contacts get none (`Contact::normal` is None).
fn search_and_image(
    map: &TactileMap,
    options: &TouchOptions,
    size: ImageSize,
) -> Result<(ContactFinder, TactileImager), TouchError> {
    let finder = ContactFinder::new(&map.positions, &[], &map.faces, Path::new(&map.name))
        .map_err(|source| TouchError::Mesh {
            link: map.name.clone(),
            source,
        })?
        .with_separation(options.separation);
    let imager = TactileImager::for_model(map, options.step_mm, size).map_err(|source| TouchError::Map {
        link: map.name.clone(),
        source,
    })?;
    Ok((finder, imager))
}

/// The per-frame path of a whole skin: contacts, touches, images, decisions.
pub struct TouchPipeline {
    links: Vec<Link>,
    models: Models,
    options: TouchOptions,
    next_touch: u64,
    times: StageTimes,
}

impl std::fmt::Debug for TouchPipeline {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TouchPipeline")
            .field("links", &self.links.iter().map(|l| &l.name).collect::<Vec<_>>())
            .field("options", &self.options)
            .finish_non_exhaustive()
    }
}

impl TouchPipeline {
    /// A pipeline over the tactile maps of a skin's links, with its models ([`Models::none`]:
    /// tracking only). Images are made at the models' input size (68 x 100 without a model).
    pub fn new(
        maps: Vec<TactileMap>,
        models: Models,
        options: TouchOptions,
    ) -> Result<TouchPipeline, TouchError> {
        let size = models.input_size()?;
        let mut links = Vec::with_capacity(maps.len());
        for map in maps {
            let name = map.name.clone();
            let (finder, imager) = search_and_image(&map, &options, size)?;
            let area: f64 = map
                .faces
                .iter()
                .filter_map(|f| {
                    let p = |i: usize| map.positions.get(i);
                    Some((p(f[1])? - p(f[0])?).cross(&(p(f[2])? - p(f[0])?)).norm() / 2.0)
                })
                .sum();
            let n = map.ids.len();
            let border_mm = map.border_distances().iter().map(|&d| (d * 1e3) as f32).collect();
            links.push(Link {
                area_per_taxel_cm2: area * 1e4 / n.max(1) as f64,
                peak_pressures: vec![0.0; n],
                scratch: vec![0.0; n],
                name,
                map,
                finder,
                imager,
                touch: None,
                dead: Vec::new(),
                border_mm,
                force: None,
                pose: None,
            });
        }
        Ok(TouchPipeline {
            links,
            models,
            options,
            next_touch: 0,
            times: StageTimes::default(),
        })
    }

    /// Declares the taxels of `link` (indices, layout order) that have no readings: they are
    /// handled as the thesis' Test B handles removed taxels, the link's triangles made again
    /// without them ([`skin_geom::DeadTaxels::bridge_in`]), so a press over a dead taxel stays one
    /// contact and its image has no hole. Frames still give one pressure per taxel (a dead one's
    /// is ignored). An empty list restores the whole mesh. Costs a triangulation: call it when the
    /// input changes, not per frame.
    pub fn set_dead(&mut self, link: usize, dead: &[usize]) -> Result<(), TouchError> {
        let links = self.links.len();
        let Some(l) = self.links.get_mut(link) else {
            return Err(TouchError::NoLink { link, links });
        };
        let dead = skin_geom::DeadTaxels::new(dead, l.map.ids.len());
        if dead.indices() == l.dead {
            return Ok(());
        }
        let map = dead.bridge_in(&l.map).map_err(|source| TouchError::Map {
            link: l.name.clone(),
            source,
        })?;
        let size = l.imager.output_size();
        (l.finder, l.imager) = search_and_image(&map, &self.options, size)?;
        l.dead = dead.indices().to_vec();
        // The bridged triangles cover the dead taxels' skin: their neighbours now stand for it,
        // so a press over a dead taxel keeps its force.
        if let Some(force) = &mut l.force {
            let areas = skin_core::force::taxel_areas(&map.positions, &map.faces);
            areas
                .and_then(|a| force.set_areas(a))
                .map_err(|source| TouchError::Force {
                    link: l.name.clone(),
                    source,
                })?;
        }
        Ok(())
    }

    /// The same pipeline (maps, models, options, dead taxels) with no touch seen and no time
    /// spent: for the next input of a batch, built from what it holds (no file is read).
    pub fn restarted(self) -> Result<TouchPipeline, TouchError> {
        let TouchPipeline {
            links,
            models,
            options,
            ..
        } = self;
        let dead: Vec<Vec<usize>> = links.iter().map(|l| l.dead.clone()).collect();
        let mut forces: Vec<Option<LinkForce>> = links.iter().map(|l| l.force.clone()).collect();
        let maps = links.into_iter().map(|l| l.map).collect();
        let mut fresh = TouchPipeline::new(maps, models, options)?;
        for (k, d) in dead.iter().enumerate() {
            fresh.set_dead(k, d)?;
            fresh.links[k].force = forces[k].take().map(LinkForce::restarted);
        }
        Ok(fresh)
    }

    /// Gives `link` a force model ([`skin_core::force`]): from then on its contacts carry
    /// their force ([`Contact::force_n`], [`Footprint::force_n`]) and the link a
    /// [`wrench`](Self::wrench). `normals` are its taxels' outward normals (layout order).
    pub fn set_force(
        &mut self,
        link: usize,
        model: skin_core::force::ForceModel,
        normals: Vec<nalgebra::Vector3<f64>>,
    ) -> Result<(), TouchError> {
        let links = self.links.len();
        let l = self
            .links
            .get_mut(link)
            .ok_or(TouchError::NoLink { link, links })?;
        let force = LinkForce::new(model, normals, l.map.ids.len()).map_err(|source| TouchError::Force {
            link: l.name.clone(),
            source,
        })?;
        l.force = Some(force);
        Ok(())
    }

    /// The force model of `link`, with its taxels' normals; none without a force calibration.
    pub fn force_model(
        &self,
        link: usize,
    ) -> Option<(&skin_core::force::ForceModel, &[nalgebra::Vector3<f64>])> {
        let f = self.links.get(link)?.force.as_ref()?;
        Some((f.model(), f.normals()))
    }

    /// What the contacts of `link`'s last frame press on it with, in the link's frame (zero
    /// without contact), and how many of their taxels read past saturation (the wrench is then
    /// a lower bound); none on a link without a force model.
    pub fn wrench(&self, link: usize) -> Option<(skin_core::force::Wrench, usize)> {
        let f = self.links.get(link)?.force.as_ref()?;
        Some((f.wrench, f.saturated))
    }

    /// Each taxel's force in the last frame, N (layout order): its share of the contact it is
    /// in, zero outside contacts; none on a link without a force model.
    pub fn taxel_forces(&self, link: usize) -> Option<&[f64]> {
        Some(self.links.get(link)?.force.as_ref()?.forces())
    }

    /// Link names, in the order frames give their pressures.
    pub fn link_names(&self) -> impl Iterator<Item = &str> {
        self.links.iter().map(|l| l.name.as_str())
    }

    /// The tactile image last classified on `link` (model size, row-major grey); none before
    /// the first.
    pub fn last_image(&self, link: usize) -> Option<ImageView<'_, u8>> {
        let l = self.links.get(link)?;
        view(l.imager.last_output(), l.imager.output_size())
    }

    /// The tactile image of `pressures` on `link` (readings at or below the threshold count as
    /// none), at model size: what `--frames` writes. Not used by the decisions.
    pub fn frame_image(&mut self, link: usize, pressures: &[f32]) -> Result<ImageView<'_, u8>, TouchError> {
        let threshold = self.options.threshold;
        let links = self.links.len();
        let Some(l) = self.links.get_mut(link) else {
            return Err(TouchError::NoLink { link, links });
        };
        for (dst, &p) in l.scratch.iter_mut().zip(pressures) {
            *dst = if p > threshold { p } else { 0.0 };
        }
        let size = l.imager.output_size();
        let grey = l.imager.process(&l.scratch).map_err(|source| TouchError::Map {
            link: l.name.clone(),
            source,
        })?;
        let pixels = grey.len();
        view(grey, size).ok_or_else(|| TouchError::Frame {
            time: 0.0,
            why: format!(
                "link {}: an image of {pixels} pixels is not {} x {}",
                l.name, size.rows, size.cols
            ),
        })
    }

    /// The pressure image (real pressures, counts; row-major at the map's raster size, before
    /// grey conversion and resizing) behind [`Self::last_image`] or the last
    /// [`Self::frame_image`] of `link`; none before the first.
    pub fn last_pressure_image(&self, link: usize) -> Option<ImageView<'_, f32>> {
        let l = self.links.get(link)?;
        let raster = l.imager.raster();
        let size = ImageSize {
            rows: raster.rows(),
            cols: raster.cols(),
        };
        view(l.imager.pressure_image(), size)
    }

    /// The contacts of `link` in the last frame processed, largest total pressure first.
    /// Their taxels index the link's layout; the map carries no normals, so `normal` is none.
    pub fn contacts(&self, link: usize) -> &[skin_core::Contact] {
        self.links.get(link).map_or(&[], |l| l.finder.last())
    }

    /// Skin area per taxel of `link`, cm² (the map's triangle area over its taxels).
    pub fn taxel_area_cm2(&self, link: usize) -> Option<f64> {
        self.links.get(link).map(|l| l.area_per_taxel_cm2)
    }

    /// Link `link`'s pose in the chain's base frame (link frame to base frame) for the frames
    /// from now on, or None when it is not known: footprints give their centroid in the base
    /// frame too ([`Footprint::centroid_base`]) while it is. A link out of range is ignored.
    pub fn set_pose(&mut self, link: usize, pose: Option<nalgebra::Isometry3<f64>>) {
        if let Some(l) = self.links.get_mut(link) {
            l.pose = pose;
        }
    }

    /// A touch is in progress on `link`.
    pub fn touching(&self, link: usize) -> bool {
        self.links.get(link).is_some_and(|l| l.touch.is_some())
    }

    /// Touches open now, over every link.
    pub fn open_touches(&self) -> usize {
        self.links.iter().filter(|l| l.touch.is_some()).count()
    }

    /// The decisions of the touches in progress that have been decided, one per link at most.
    pub fn open_decisions(&self) -> impl Iterator<Item = &Decision> + '_ {
        self.links
            .iter()
            .filter_map(|l| l.touch.as_ref()?.decision.as_ref())
    }

    /// What the gate weighs of each decided touch in progress, with its link and number: its
    /// decision and, on a link with a force model, the force its contacts press with now (the
    /// last frame's), and whether a taxel of them read past saturation (the force is then a
    /// lower bound).
    pub fn open_gate_touches(
        &self,
    ) -> impl Iterator<Item = (usize, u64, skin_control::hri::GateTouch<'_>, bool)> + '_ {
        self.links.iter().enumerate().filter_map(|(k, l)| {
            let touch = l.touch.as_ref()?;
            let gate = touch.decision.as_ref()?.gate_touch();
            let force_n = l.force.as_ref().map(|f| f.wrench.magnitude);
            let saturated = l.force.as_ref().is_some_and(|f| f.saturated > 0);
            Some((
                k,
                touch.id,
                skin_control::hri::GateTouch { force_n, ..gate },
                saturated,
            ))
        })
    }

    /// The tactile map of `link` as built (every taxel, before dead ones are bridged): where
    /// each taxel sits on the flattened skin, for a viewer or a plot.
    pub fn map(&self, link: usize) -> Option<&TactileMap> {
        self.links.get(link).map(|l| &l.map)
    }

    /// The taxels of `link` declared dead ([`Self::set_dead`]): layout indices, increasing.
    pub fn dead(&self, link: usize) -> &[usize] {
        self.links.get(link).map_or(&[], |l| &l.dead)
    }

    /// Taxels of `link`'s map.
    pub fn taxels(&self, link: usize) -> Option<usize> {
        self.links.get(link).map(|l| l.map.ids.len())
    }

    /// The classifier's classes, in output order.
    pub fn classes(&self) -> &Classes {
        self.models.classes()
    }

    /// A classifier decides the touches.
    pub fn classifies(&self) -> bool {
        self.models.classifies()
    }

    /// The options it was built with.
    pub fn options(&self) -> &TouchOptions {
        &self.options
    }

    /// Time per stage so far.
    pub fn times(&self) -> &StageTimes {
        &self.times
    }

    /// Processes one frame: `pressures[link]` holds one pressure per taxel of that link's map
    /// (after the baseline), at `time` seconds. Events go to `events`.
    pub fn process(
        &mut self,
        time: f64,
        pressures: &[impl AsRef<[f32]>],
        events: &mut Vec<TouchEvent>,
    ) -> Result<(), TouchError> {
        let started = Instant::now();
        if pressures.len() != self.links.len() {
            return Err(TouchError::Frame {
                time,
                why: format!(
                    "{} links' pressures, the skin has {} links",
                    pressures.len(),
                    self.links.len()
                ),
            });
        }
        for (k, p) in pressures.iter().enumerate() {
            self.link_frame(k, time, p.as_ref(), events)?;
        }
        let spent = started.elapsed();
        self.times.frames += 1;
        self.times.total += spent;
        self.times.worst_frame = self.times.worst_frame.max(spent);
        Ok(())
    }

    /// Ends every touch still open (the end of a recording), as of `time`.
    pub fn finish(&mut self, time: f64, events: &mut Vec<TouchEvent>) -> Result<(), TouchError> {
        for k in 0..self.links.len() {
            if self.links[k].touch.is_some() {
                self.release(k, time, events)?;
            }
        }
        Ok(())
    }

    fn link_frame(
        &mut self,
        k: usize,
        time: f64,
        pressures: &[f32],
        events: &mut Vec<TouchEvent>,
    ) -> Result<(), TouchError> {
        let t0 = Instant::now();
        let o = &self.options;
        let link = &mut self.links[k];
        let frame_error = |e: skin_core::Error| TouchError::Frame {
            time,
            why: format!("link {}: {e}", link.name),
        };
        link.finder
            .find(pressures, o.threshold, o.min_taxels)
            .map_err(frame_error)?;
        if let Some(force) = &mut link.force {
            force
                .frame(pressures, &mut link.finder, &link.map.positions)
                .map_err(frame_error)?;
        }
        let contacts = link.finder.last();
        let Some((mut footprint, total)) = footprint_of(contacts, link.area_per_taxel_cm2) else {
            self.times.contacts += t0.elapsed();
            if let Some(t) = &mut link.touch {
                t.quiet += 1;
                if t.quiet >= o.release_frames.max(1) {
                    self.release(k, time, events)?;
                }
            }
            return Ok(());
        };
        self.times.contacts += t0.elapsed();
        footprint.centroid_base = link.pose.map(|pose| pose * footprint.centroid);
        let touch = match &mut link.touch {
            Some(t) => t,
            None => {
                let id = self.next_touch;
                self.next_touch += 1;
                events.push(TouchEvent::Appeared(Appeared {
                    link: k,
                    id,
                    time,
                    footprint,
                }));
                link.touch.insert(Touch::new(id, time, footprint))
            }
        };
        touch.frames += 1;
        touch.quiet = 0;
        touch.last = time;
        if total > touch.peak_total {
            touch.peak_total = total;
            touch.peak = footprint;
            let threshold = o.threshold;
            // Only the contacts' taxels: noise elsewhere must not shape the image.
            link.peak_pressures.fill(0.0);
            for c in contacts {
                for &i in &c.taxels {
                    link.peak_pressures[i] = pressures[i].max(threshold);
                }
            }
        }
        let due = if touch.decision.is_none() {
            touch.frames >= o.decide_frames.max(1)
        } else {
            touch.peak_total > touch.classified_total * f64::from(o.reclassify_growth.max(1.0))
        };
        if due {
            self.decide(k, time, events)?;
        }
        Ok(())
    }

    /// Classifies (and segments) the fullest frame of link `k`'s touch.
    fn decide(&mut self, k: usize, time: f64, events: &mut Vec<TouchEvent>) -> Result<(), TouchError> {
        let Some(classifier) = &mut self.models.classifier else {
            return Ok(());
        };
        let link = &mut self.links[k];
        let border_mm = link.image_border_mm();
        let Some(touch) = &mut link.touch else {
            return Ok(());
        };
        let t0 = Instant::now();
        let size = link.imager.output_size();
        let (rows, cols) = (size.rows, size.cols);
        let image = link
            .imager
            .process(&link.peak_pressures)
            .map_err(|source| TouchError::Map {
                link: link.name.clone(),
                source,
            })?;
        let image = ImageView::new(image, size).map_err(|e| TouchError::Frame {
            time,
            why: format!("link {}: {e}", link.name),
        })?;
        let t1 = Instant::now();
        let decide = |source| TouchError::Decide {
            time,
            link: link.name.clone(),
            touch: touch.id,
            source,
        };
        let probabilities = classifier.classify(image).map_err(decide)?;
        let t2 = Instant::now();
        self.times.image += t1 - t0;
        self.times.classify += t2 - t1;
        self.times.runs.0 += 1;
        let (class, probability) = most_likely(&probabilities, &self.models.classes).map_err(decide)?;
        let mut parts = Vec::new();
        if class.is_hand()
            && let Some(segmenter) = &mut self.models.segmenter
        {
            let labels = segmenter.segment(image).map_err(decide)?;
            if labels.len() != rows * cols {
                let why = format!(
                    "the segmenter gave {} labels for a {rows} x {cols} image",
                    labels.len()
                );
                return Err(decide(ModelError::Run(why.into())));
            }
            parts = part_contacts(
                &link.map,
                link.imager.raster(),
                ImageSize { rows, cols },
                &labels,
                &link.peak_pressures,
            );
            self.times.segment += t2.elapsed();
            self.times.runs.1 += 1;
        }
        let revised = touch
            .decision
            .as_ref()
            .is_some_and(|d| d.class.index() != class.index());
        let first = touch.decision.is_none();
        touch.classified_total = touch.peak_total;
        let decision = Decision {
            class,
            probability,
            parts,
            border_mm,
        };
        if first || revised {
            events.push(TouchEvent::Classified(Classified {
                link: k,
                id: touch.id,
                time,
                decision: decision.clone(),
                revised,
            }));
        }
        touch.decision = Some(decision);
        Ok(())
    }

    fn release(&mut self, k: usize, time: f64, events: &mut Vec<TouchEvent>) -> Result<(), TouchError> {
        // A touch too short to have been decided is decided on its fullest frame now.
        let undecided = self.links[k].touch.as_ref().is_some_and(|t| t.decision.is_none());
        if undecided {
            self.decide(k, time, events)?;
        }
        if let Some(t) = self.links[k].touch.take() {
            events.push(TouchEvent::Released(Released {
                link: k,
                id: t.id,
                start: t.start,
                time: t.last,
                duration: t.last - t.start,
                frames: t.frames,
                peak: t.peak,
                decision: t.decision,
            }));
        }
        Ok(())
    }
}

/// A view of an imager's pixels at `size`; none if they do not fill it (nothing imaged yet).
fn view<T>(pixels: &[T], size: ImageSize) -> Option<ImageView<'_, T>> {
    ImageView::new(pixels, size).ok()
}
