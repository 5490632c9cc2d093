//! A session's figures, typed: what its summary and timings print, for a program to read.

use super::Session;
use crate::touch::StageTimes;
use std::time::Duration;

/// Counts and time per stage of a session so far ([`Session::stats`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SessionStats {
    /// Frames taken (the baseline's included).
    pub frames: u64,
    /// Frames that came with modules missing.
    pub incomplete: u64,
    /// Times a bus's sync counter restarted.
    pub counter_resets: u64,
    /// Touches that ended.
    pub touches: usize,
    /// The most separate contacts a touch that ended had at its fullest.
    pub most_contacts: usize,
    /// Contacts that spanned a joint (each counted once, when it began).
    pub across_joints: u64,
    /// Baseline corrections, and the taxel offsets they reset.
    pub baseline_corrections: (u64, u64),
    /// CAN decoding and frame assembly (candump logs).
    pub assemble: Duration,
    /// Learning and applying the baseline.
    pub baseline: Duration,
    /// Events and images out (the sinks' time included).
    pub output: Duration,
    /// The touch pipeline's stages: contacts, images, model runs.
    pub pipeline: StageTimes,
}

impl SessionStats {
    /// The whole path's time: assembly, baseline, touch pipeline, output.
    pub fn wall(&self) -> Duration {
        self.assemble + self.baseline + self.pipeline.total + self.output
    }
}

impl Session {
    /// Counts and time per stage so far.
    pub fn stats(&self) -> SessionStats {
        let corrections = self
            .base
            .correcting
            .iter()
            .fold((0, 0), |(e, t), c| (e + c.events, t + c.taxels));
        SessionStats {
            baseline_corrections: corrections,
            pipeline: self.pipeline.times().clone(),
            ..self.stats.clone()
        }
    }
}
