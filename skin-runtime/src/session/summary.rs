//! A session's summary and its time per stage, as text (what `skin run` prints and writes to
//! `summary.txt`).

use super::{Session, SessionStats, TOUCH_HISTORY};
use crate::script::{Score, Tally};
use crate::touch::Released;
use std::fmt::{self, Display, Formatter};
use std::time::Duration;

/// The run, the touches, and the score against the script ([`Session::summary`]).
#[derive(Debug)]
pub struct Summary<'a> {
    pub(super) session: &'a Session,
    pub(super) span: f64,
}

/// Time per frame, stage by stage ([`Session::timings`]).
#[derive(Debug)]
pub struct Timings<'a> {
    pub(super) session: &'a Session,
    pub(super) span: f64,
}

/// How the run's touches score against the script ([`Summary::script_score`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ScriptScore {
    /// Scripted touches.
    pub scripted: usize,
    /// Of them, found.
    pub found: usize,
    /// Of them, found with the right class.
    pub right: usize,
    /// Touches found that are not in the script.
    pub extra: usize,
}

impl Summary<'_> {
    /// The session's counts and time per stage.
    pub fn stats(&self) -> SessionStats {
        self.session.stats()
    }

    /// The touches that ended, in the order they ended: the last [`TOUCH_HISTORY`] of them.
    pub fn touches(&self) -> impl ExactSizeIterator<Item = &Released> + DoubleEndedIterator + '_ {
        self.session.touches()
    }

    /// The input's span, seconds.
    pub fn span(&self) -> f64 {
        self.span
    }

    /// The score against the script (none without one).
    pub fn script_score(&self) -> Option<ScriptScore> {
        let tally = self.session.tally.as_ref()?;
        let score = tally.score();
        Some(ScriptScore {
            scripted: tally.script().touches.len(),
            found: score.found(),
            right: score.right(),
            extra: score.extra_among(tally.found()),
        })
    }
}

impl Display for Summary<'_> {
    fn fmt(&self, out: &mut Formatter<'_>) -> fmt::Result {
        let s = self.session;
        let st = s.stats();
        let taxels: usize = s.setup.links.iter().map(|l| l.taxels.len()).sum();
        writeln!(
            out,
            "{} frames ({} incomplete) of {} taxels on {} link(s) over {:.2} s; baseline from the first {} frames",
            st.frames,
            st.incomplete,
            taxels,
            s.setup.links.len(),
            self.span,
            s.setup.options.baseline_frames
        )?;
        if st.counter_resets > 0 {
            writeln!(
                out,
                "sync counter restarted {} time(s) (recordings joined or a hub reset): the frames after it are kept, numbered on by time (\"counter_reset\" events)",
                st.counter_resets
            )?;
        }
        for note in &s.notes {
            writeln!(out, "{note}")?;
        }
        self.write_health(out)?;
        // Each scripted touch's detected touch: the one overlapping it the longest.
        let score = s.tally.as_ref().map(Tally::score);
        self.write_touches(out, score.as_ref())?;
        if let (Some(tally), Some(score)) = (&s.tally, &score) {
            Self::write_script(out, tally, score)?;
        }
        Ok(())
    }
}

impl Summary<'_> {
    /// Taxels that cannot be trusted, baselines learned under pressure or corrected since, and
    /// contacts stitched across joints: one line each, only where there is something to say.
    fn write_health(&self, out: &mut Formatter<'_>) -> fmt::Result {
        let s = self.session;
        for (l, h) in s.base.health.iter().enumerate() {
            if !h.dead.is_empty() || !h.stuck.is_empty() {
                let ids = |v: &[usize]| {
                    v.iter()
                        .map(|&i| s.setup.links[l].taxels[i].id.to_string())
                        .collect::<Vec<_>>()
                        .join(", ")
                };
                writeln!(
                    out,
                    "link {}: taxels that cannot be trusted: dead [{}], stuck [{}]",
                    s.setup.links[l].name,
                    ids(&h.dead),
                    ids(&h.stuck)
                )?;
            }
        }
        for (l, h) in s.base.health.iter().enumerate() {
            if !h.pressed.is_empty() {
                writeln!(
                    out,
                    "link {}: {} taxel(s) were pressed while the baseline was learned (a touch in progress): their offsets are their least pressed readings until the pressure goes",
                    s.setup.links[l].name,
                    h.pressed.len()
                )?;
            }
        }
        for (l, c) in s.base.correcting.iter().enumerate() {
            if c.events > 0 {
                writeln!(
                    out,
                    "link {}: baseline corrected {} time(s), {} taxel offset(s) reset: readings fell below offsets learned or drifted under pressure, beyond the noise (baseline_corrected events)",
                    s.setup.links[l].name, c.events, c.taxels
                )?;
            }
        }
        if s.setup.stitching.is_some() {
            writeln!(
                out,
                "contacts across joints (stitched maps): {}",
                s.stats().across_joints
            )?;
        }
        Ok(())
    }

    /// The table of finished touches, with the scripted touch each one matched.
    fn write_touches(&self, out: &mut Formatter<'_>, score: Option<&Score>) -> fmt::Result {
        let s = self.session;
        let ended = s.stats.touches;
        // The touches kept are the last ones: the first kept is touch `first` of all that ended.
        let first = ended - s.done.len();
        write!(out, "{ended} touch(es):")?;
        if first > 0 {
            write!(
                out,
                "\n  the last {TOUCH_HISTORY} listed (a session keeps no more; the events have every touch)"
            )?;
        }
        // A column of newtons when a link has a force model (its touches' peak force).
        let newtons = (0..s.setup.links.len()).any(|l| s.pipeline.force_model(l).is_some());
        write!(
            out,
            "\n  touch  link        start s   end s  class        prob  taxels  area cm2  mean  {}{}parts",
            if newtons { "peak N  " } else { "" },
            if s.tally.is_some() {
                "script               "
            } else {
                ""
            }
        )?;
        for (j, d) in (first..).zip(&s.done) {
            let (class, prob, parts) = match &d.decision {
                Some(dec) => (
                    dec.class.name().to_string(),
                    format!("{:.3}", dec.probability),
                    dec.parts
                        .iter()
                        .map(|p| format!("{} {}", p.part.name(), p.taxels))
                        .collect::<Vec<_>>()
                        .join(", "),
                ),
                None => ("-".into(), "-".into(), String::new()),
            };
            let script = match (&s.tally, score) {
                (Some(tally), Some(score)) => {
                    let name = score.scripted_of(j).map_or("(not scripted)".to_string(), |k| {
                        let t = &tally.script().touches[k];
                        format!("{} {}", t.class, t.kind)
                    });
                    format!("{name:<21}")
                }
                _ => String::new(),
            };
            let force = match (newtons, d.peak.force_n) {
                (false, _) => String::new(),
                (true, Some(f)) => format!("{f:>6.1}  "),
                (true, None) => format!("{:>6}  ", "-"),
            };
            let row = format!(
                "  {:>5}  {:<10} {:>7.2} {:>7.2}  {:<10} {:>6}  {:>6}  {:>8.1}  {:>4.0}  {force}{script}{parts}",
                d.id,
                s.setup.links[d.link].name,
                d.start,
                d.time,
                class,
                prob,
                d.peak.taxels,
                d.peak.area_cm2,
                d.peak.mean_pressure,
            );
            write!(out, "\n{}", row.trim_end())?;
        }
        Ok(())
    }

    /// The score against the script, and each scripted touch missed or taken for another class.
    fn write_script(out: &mut Formatter<'_>, tally: &Tally, score: &Score) -> fmt::Result {
        let script = tally.script();
        write!(
            out,
            "\nscript: {} of {} scripted touches found, {} with the right class ({:.1}%); {} touch(es) not in the script",
            score.found(),
            script.touches.len(),
            score.right(),
            100.0 * score.right() as f64 / script.touches.len().max(1) as f64,
            score.extra_among(tally.found())
        )?;
        for (k, (t, m)) in script.touches.iter().zip(&score.matches).enumerate() {
            match m {
                Some(_) if !score.correct[k] => {
                    let got = tally.class_of(k).unwrap_or("-");
                    write!(
                        out,
                        "\n  scripted touch {k} ({} {}) taken for {got}",
                        t.class, t.kind
                    )?;
                }
                Some(_) => {}
                None => write!(out, "\n  scripted touch {k} ({} {}) not found", t.class, t.kind)?,
            }
        }
        Ok(())
    }
}

impl Display for Timings<'_> {
    fn fmt(&self, out: &mut Formatter<'_>) -> fmt::Result {
        let s = self.session;
        let st = s.stats();
        let t = &st.pipeline;
        let frames = t.frames.max(1) as f64;
        let us = |d: Duration| d.as_secs_f64() * 1e6;
        let wall = st.wall();
        write!(out, "time per frame (mean over all frames), stage by stage:")?;
        let rows = [
            ("CAN decode + assembly", st.assemble),
            ("baseline", st.baseline),
            ("contacts", t.contacts),
            ("tactile images", t.image),
            ("classifier", t.classify),
            ("segmenter + parts", t.segment),
            ("events and images out", st.output),
        ];
        for (name, d) in rows {
            write!(out, "\n  {name:<24} {:>9.1} us", us(d) / frames)?;
        }
        write!(
            out,
            "\n  {:<24} {:>9.1} us  (slowest frame of the pipeline: {:.2} ms; {} classifier and {} segmenter runs)",
            "all",
            us(wall) / frames,
            t.worst_frame.as_secs_f64() * 1e3,
            t.runs.0,
            t.runs.1
        )?;
        if self.span > 0.0 && wall > Duration::ZERO {
            write!(
                out,
                "\n  {:.0}x real time ({:.2} s of input in {:.3} s)",
                self.span / wall.as_secs_f64(),
                self.span,
                wall.as_secs_f64()
            )?;
        }
        Ok(())
    }
}
