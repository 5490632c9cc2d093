//! A chain of links stitched at the postures of a poses file, or at a posture given live (the
//! robot's joint states): each posture solved once, a live one again whenever it moves.

use super::{StitchOptions, StitchReport, StitchedRasterizer, Stitcher};
use crate::dead_taxels::DeadTaxels;
use crate::raster::{Normalisation, to_grey};
use crate::tactile_map::TactileMap;
use crate::{ChainContacts, ChainError, ChainIndex, Error, Result};
use nalgebra::Isometry3;
use skin_core::Contact;
use skin_core::format::poses::Postures;
use skin_core::image::{ImageSize, ImageView};

/// How far a link of a live posture moves before the chain is stitched again: 0.1 mm, or
/// 1e-4 rad (0.006 degrees) of turn. Below it the last solve holds (joint encoders' noise
/// costs nothing); the images are 1 mm pixels.
pub const LIVE_TOLERANCE_M: f64 = 1e-4;
/// See [`LIVE_TOLERANCE_M`].
pub const LIVE_TOLERANCE_RAD: f64 = 1e-4;

/// Which solve a frame is stitched at.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum At {
    /// The poses file's posture of this index.
    Posture(usize),
    /// The live posture of this generation.
    Live(u64),
}

/// A chain of links stitched at the postures of a poses file: each posture solved once (a posture
/// is static), the maps placed and rendered as one tactile image, contacts chained across the
/// joints, and the chain stitched again without the taxels an input lacks.
#[derive(Debug)]
pub struct PostureChain {
    /// The whole maps, chain order.
    maps: Vec<TactileMap>,
    postures: Postures,
    options: StitchOptions,
    step_mm: f64,
    /// Whether contacts are searched over the chain ([`PostureChain::with_contacts`]).
    contacts: bool,
    /// The chain of the whole maps.
    whole: Solved,
    /// The chain without the taxels the input lacks, kept while inputs lack the same ones.
    holed: Option<(Vec<DeadTaxels>, Solved)>,
    /// The input's dead taxels, per link.
    dead: Vec<DeadTaxels>,
    /// The posture of the last frame.
    posture: At,
    /// The live posture ([`PostureChain::set_live_posture`]) and its generation: from it on,
    /// frames are stitched there rather than at the poses file's posture of their time.
    live: Option<(u64, Vec<Isometry3<f64>>)>,
    /// The last live posture that could not be stitched: not tried again while it holds.
    failed: Option<Vec<Isometry3<f64>>>,
    /// The last frame's pressures, thresholded, per link of the chain in use.
    pressures: Vec<Vec<f32>>,
    threshold: f32,
    image: Vec<f32>,
    grey: Vec<u8>,
}

/// One chain of maps solved at every posture.
#[derive(Debug)]
struct Solved {
    stitcher: Stitcher,
    reports: Vec<StitchReport>,
    raster: StitchedRasterizer,
    /// Per posture, the contact search over all links (empty without contacts).
    finders: Vec<ChainContacts>,
    /// Per link, the whole map's index of each of its taxels.
    survivors: Vec<Vec<usize>>,
    /// The posture the rasterizer is placed at.
    placed: Option<At>,
    /// The live posture's solve: its generation, its report and its contact search.
    live: Option<(u64, StitchReport, Option<ChainContacts>)>,
}

/// The solve of `at` among a chain's posture `reports` and its `live` one.
fn report_of<'a>(
    reports: &'a [StitchReport],
    live: &'a Option<(u64, StitchReport, Option<ChainContacts>)>,
    at: At,
) -> Option<&'a StitchReport> {
    match at {
        At::Posture(k) => reports.get(k),
        At::Live(g) => live.as_ref().filter(|(l, ..)| *l == g).map(|(_, r, _)| r),
    }
}

/// `source` said to have happened at `posture`.
fn at(posture: &str) -> impl Fn(Error) -> Error + '_ {
    move |source| Error::Posture {
        posture: posture.to_owned(),
        source: Box::new(source),
    }
}

/// The chain in use: the whole one, or the one without the dead taxels when some are.
fn in_use<'a>(
    whole: &'a mut Solved,
    holed: &'a mut Option<(Vec<DeadTaxels>, Solved)>,
    dead: &[DeadTaxels],
) -> &'a mut Solved {
    match holed {
        Some((_, holed)) if !dead.iter().all(DeadTaxels::is_empty) => holed,
        _ => whole,
    }
}

impl Solved {
    /// Stitches `maps` at every posture of `postures`, the middle one setting the boundaries and
    /// the first warm start.
    fn new(
        maps: Vec<TactileMap>,
        survivors: Vec<Vec<usize>>,
        postures: &Postures,
        options: StitchOptions,
        step_mm: f64,
    ) -> Result<Solved> {
        let Some(reference) = postures.postures.get(postures.postures.len() / 2) else {
            return Err(Error::Chain(ChainError::NoPosture));
        };
        let mut stitcher = Stitcher::new(maps, &reference.poses, options).map_err(at(&reference.name))?;
        let mut reports = Vec::with_capacity(postures.postures.len());
        for p in &postures.postures {
            reports.push(stitcher.reset(&p.poses).map_err(at(&p.name))?);
        }
        let raster = StitchedRasterizer::new(stitcher.maps(), step_mm)?;
        Ok(Solved {
            stitcher,
            reports,
            raster,
            finders: Vec::new(),
            survivors,
            placed: None,
            live: None,
        })
    }

    /// The solve of the live posture `poses`, with its contact search when `contacts`; kept
    /// by the caller only once every chain has one ([`PostureChain::set_live_posture`]).
    fn solve_live(
        &mut self,
        poses: &[Isometry3<f64>],
        contacts: bool,
    ) -> Result<(StitchReport, Option<ChainContacts>)> {
        let at = at("live");
        let report = self.stitcher.reset(poses).map_err(&at)?;
        let finder = match contacts {
            true => Some(ChainContacts::new(self.stitcher.maps(), poses, &report.bridges).map_err(&at)?),
            false => None,
        };
        Ok((report, finder))
    }

    /// The solve a frame at `at` is stitched at.
    fn report(&self, at: At) -> Option<&StitchReport> {
        report_of(&self.reports, &self.live, at)
    }

    /// Builds the contact search of every posture.
    fn find_contacts(&mut self, postures: &Postures) -> Result<()> {
        self.finders.clear();
        for (p, report) in postures.postures.iter().zip(&self.reports) {
            let finder =
                ChainContacts::new(self.stitcher.maps(), &p.poses, &report.bridges).map_err(at(&p.name))?;
            self.finders.push(finder);
        }
        Ok(())
    }
}

impl PostureChain {
    /// Stitches `maps` (chain order, with their taxels' 3D positions) at each posture of
    /// `postures` (one pose per map), for images of `step_mm` pixels. The middle posture sets each
    /// joint's boundary taxels and the first warm start. An error at a posture names it
    /// ([`Error::Posture`]).
    pub fn new(
        maps: Vec<TactileMap>,
        postures: Postures,
        options: StitchOptions,
        step_mm: f64,
    ) -> Result<PostureChain> {
        let survivors = maps.iter().map(|m| (0..m.ids.len()).collect()).collect();
        let whole = Solved::new(maps.clone(), survivors, &postures, options, step_mm)?;
        Ok(PostureChain {
            pressures: maps.iter().map(|m| vec![0.0; m.ids.len()]).collect(),
            dead: vec![DeadTaxels::default(); maps.len()],
            maps,
            postures,
            options,
            step_mm,
            contacts: false,
            whole,
            holed: None,
            posture: At::Posture(0),
            live: None,
            failed: None,
            threshold: 0.0,
            image: Vec::new(),
            grey: Vec::new(),
        })
    }

    /// Also searches contacts over the chain, joined across the joints
    /// ([`PostureChain::contacts`]).
    pub fn with_contacts(mut self) -> Result<PostureChain> {
        self.contacts = true;
        self.whole.find_contacts(&self.postures)?;
        if let Some((_, holed)) = &mut self.holed {
            holed.find_contacts(&self.postures)?;
        }
        Ok(self)
    }

    /// The postures.
    pub fn postures(&self) -> &Postures {
        &self.postures
    }

    /// The stitcher of the whole maps (boundaries, edge fidelity).
    pub fn stitcher(&self) -> &Stitcher {
        &self.whole.stitcher
    }

    /// Every posture's solve of the whole maps, in the postures' order.
    pub fn solves(&self) -> &[StitchReport] {
        &self.whole.reports
    }

    /// Where each link's whole map lies in the stitched plane at the posture in effect at
    /// `time` (s): the solve of that posture. A viewer draws the stitched arm with them.
    pub fn placements_at(&self, time: f64) -> &[super::Placement] {
        let at = match &self.live {
            Some((g, _)) => At::Live(*g),
            None => At::Posture(self.postures.at(time)),
        };
        self.whole.report(at).map_or(&[], |r| r.placements.as_slice())
    }

    /// Each link's pose (link frame to the common frame) at `time` (s), chain order: the live
    /// posture once one is set ([`PostureChain::set_live_posture`]), else the poses file's
    /// posture in effect then.
    pub fn poses_at(&self, time: f64) -> &[Isometry3<f64>] {
        match &self.live {
            Some((_, poses)) => poses,
            None => self
                .postures
                .postures
                .get(self.postures.at(time))
                .map_or(&[], |p| p.poses.as_slice()),
        }
    }

    /// Stitches the frames from now on at `poses` (one per map, link frame to the common
    /// frame): the robot's posture as its joint states give it, instead of the poses file's
    /// posture of their time. The chain is solved again (as a posture of the file is) when a
    /// link moved more than [`LIVE_TOLERANCE_M`] or [`LIVE_TOLERANCE_RAD`] since the last
    /// solve; true when it was. A posture that cannot be stitched is an error that changes
    /// nothing: the last one holds.
    pub fn set_live_posture(&mut self, poses: &[Isometry3<f64>]) -> Result<bool> {
        if poses.len() != self.maps.len() {
            return Err(Error::Length {
                what: "poses for the chain's links",
                got: poses.len(),
                expected: self.maps.len(),
            });
        }
        let near = |last: &[Isometry3<f64>]| {
            last.iter().zip(poses).all(|(a, b)| {
                (a.translation.vector - b.translation.vector).norm() <= LIVE_TOLERANCE_M
                    && a.rotation.angle_to(&b.rotation) <= LIVE_TOLERANCE_RAD
            })
        };
        // Where it is stitched already, or where it could not be (its error was said): nothing
        // to solve.
        if self.live.as_ref().is_some_and(|(_, last)| near(last)) || self.failed.as_deref().is_some_and(near)
        {
            return Ok(false);
        }
        let generation = self.live.as_ref().map_or(1, |(g, _)| g + 1);
        let contacts = self.contacts;
        // Every chain solved before any is changed: an error leaves the last posture whole.
        let solved = self.whole.solve_live(poses, contacts).and_then(|whole| {
            let holed = match &mut self.holed {
                Some((_, holed)) => Some(holed.solve_live(poses, contacts)?),
                None => None,
            };
            Ok((whole, holed))
        });
        let (whole, holed) = match solved {
            Ok(s) => s,
            Err(e) => {
                self.failed = Some(poses.to_vec());
                return Err(e);
            }
        };
        self.failed = None;
        let (report, finder) = whole;
        self.whole.live = Some((generation, report, finder));
        if let (Some((_, chain)), Some((report, finder))) = (&mut self.holed, holed) {
            chain.live = Some((generation, report, finder));
        }
        match &mut self.live {
            Some((g, last)) => {
                *g = generation;
                last.copy_from_slice(poses);
            }
            None => self.live = Some((generation, poses.to_vec())),
        }
        Ok(true)
    }

    /// Back to the poses file's postures: the live posture is forgotten (a new input).
    pub fn clear_live_posture(&mut self) {
        self.live = None;
        self.failed = None;
        self.whole.live = None;
        if let Some((_, holed)) = &mut self.holed {
            holed.live = None;
        }
    }

    /// The live posture, if frames are stitched at one ([`PostureChain::set_live_posture`]).
    pub fn live_posture(&self) -> Option<&[Isometry3<f64>]> {
        self.live.as_ref().map(|(_, p)| p.as_slice())
    }

    /// The dead taxels of each link.
    pub fn dead(&self) -> &[DeadTaxels] {
        &self.dead
    }

    /// Declares the dead taxels of each link (chain order): from now on the chain is stitched
    /// without them, so contacts join across them and images interpolate across them. Frames
    /// still give one pressure per taxel of the whole maps. Stitching again costs every posture's
    /// solve: the chain of the last dead set is kept, so inputs lacking the same taxels share it.
    pub fn set_dead(&mut self, dead: Vec<DeadTaxels>) -> Result<()> {
        if dead.len() != self.maps.len() {
            return Err(Error::Length {
                what: "dead-taxel lists for the chain's links",
                got: dead.len(),
                expected: self.maps.len(),
            });
        }
        let reuse = matches!(&self.holed, Some((d, _)) if *d == dead);
        if !dead.iter().all(DeadTaxels::is_empty) && !reuse {
            let maps = self
                .maps
                .iter()
                .zip(&dead)
                .map(|(m, d)| d.remove_from(m))
                .collect::<Result<Vec<_>>>()?;
            let survivors = self
                .maps
                .iter()
                .zip(&dead)
                .map(|(m, d)| d.survivors(m.ids.len()))
                .collect();
            let mut solved = Solved::new(maps, survivors, &self.postures, self.options, self.step_mm)?;
            if self.contacts {
                solved.find_contacts(&self.postures)?;
            }
            if let Some((g, poses)) = &self.live {
                let (report, finder) = solved.solve_live(poses, self.contacts)?;
                solved.live = Some((*g, report, finder));
            }
            self.holed = Some((dead.clone(), solved));
        }
        self.dead = dead;
        let chain = in_use(&mut self.whole, &mut self.holed, &self.dead);
        self.pressures = chain.survivors.iter().map(|s| vec![0.0; s.len()]).collect();
        Ok(())
    }

    /// Takes a frame at `time` (s; the posture in effect then is used): one pressure slice per
    /// link, one reading per taxel of its whole map (a dead taxel's is ignored); readings at or
    /// below `threshold` count as none.
    pub fn set_frame(&mut self, time: f64, pressures: &[impl AsRef<[f32]>], threshold: f32) -> Result<()> {
        if pressures.len() != self.maps.len() {
            return Err(Error::Length {
                what: "pressure slices for the chain's links",
                got: pressures.len(),
                expected: self.maps.len(),
            });
        }
        for (p, m) in pressures.iter().zip(&self.maps) {
            if p.as_ref().len() != m.ids.len() {
                return Err(Error::Length {
                    what: "pressures of a link for its taxels",
                    got: p.as_ref().len(),
                    expected: m.ids.len(),
                });
            }
        }
        self.posture = match &self.live {
            Some((g, _)) => At::Live(*g),
            None => At::Posture(self.postures.at(time)),
        };
        self.threshold = threshold;
        let Self {
            holed,
            whole,
            dead,
            pressures: out,
            ..
        } = self;
        let chain = in_use(whole, holed, dead);
        let floor = |v: f32| if v > threshold { v } else { 0.0 };
        for ((out, s), p) in out.iter_mut().zip(&chain.survivors).zip(pressures) {
            let p = p.as_ref();
            // Survivors are in the map's order: as many as the readings means every taxel, and a
            // straight copy (which the compiler vectorises) instead of a gather.
            if s.len() == p.len() {
                for (o, &v) in out.iter_mut().zip(p) {
                    *o = floor(v);
                }
            } else {
                for (o, &i) in out.iter_mut().zip(s) {
                    *o = floor(p[i]);
                }
            }
        }
        Ok(())
    }

    /// The contacts of the last frame over the whole chain, at its posture; contacts of fewer
    /// than `min_taxels` are dropped. A contact's taxels index the chain of the maps in use (the
    /// whole maps less their dead taxels), which the [`ChainIndex`] maps back to links; its
    /// centroid is in the poses' common frame. Fails unless built [`PostureChain::with_contacts`].
    pub fn contacts(&mut self, min_taxels: usize) -> Result<(&[Contact], &ChainIndex)> {
        let (k, threshold) = (self.posture, self.threshold);
        let Self {
            holed,
            whole,
            dead,
            pressures,
            ..
        } = self;
        let chain = in_use(whole, holed, dead);
        let finder = match k {
            At::Posture(k) => chain.finders.get_mut(k),
            At::Live(g) => match &mut chain.live {
                Some((l, _, finder)) if *l == g => finder.as_mut(),
                _ => None,
            },
        };
        let Some(finder) = finder else {
            return Err(Error::Chain(ChainError::NoContactSearch));
        };
        finder.find(pressures, threshold, min_taxels)
    }

    /// The stitched tactile image of the last frame at its posture: grey levels normalised by the
    /// frame's largest reading (eq. 3.1).
    pub fn image(&mut self) -> Result<ImageView<'_, u8>> {
        let k = self.posture;
        let Self {
            holed,
            whole,
            dead,
            pressures,
            image,
            grey,
            ..
        } = self;
        let chain = in_use(whole, holed, dead);
        if chain.placed != Some(k) {
            let Some(report) = report_of(&chain.reports, &chain.live, k) else {
                return Err(Error::Chain(ChainError::NoPosture));
            };
            chain.raster.place(&report.placements, &report.bridges)?;
            chain.placed = Some(k);
        }
        let views: Vec<&[f32]> = pressures.iter().map(Vec::as_slice).collect();
        chain.raster.render(&views, image)?;
        grey.resize(image.len(), 0);
        to_grey(image, Normalisation::ContactMax, grey);
        let (rows, cols) = (chain.raster.rows(), chain.raster.cols());
        // Not `ImageSize::new`: the canvas is bounded by its pixel count when placed, and may
        // be longer on a side than a tactile image a user asks for.
        let size = ImageSize { rows, cols };
        ImageView::new(grey, size).map_err(|_| Error::Length {
            what: "grey values for the image's pixels",
            got: grey.len(),
            expected: rows * cols,
        })
    }
}
