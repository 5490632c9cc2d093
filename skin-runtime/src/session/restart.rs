//! A session started again on the same skin, for the next input of a batch.

use super::{Session, SessionError};
use crate::script::Tally;

impl Session {
    /// This session's skin, maps, models, bus map, stitching and script, with nothing seen yet
    /// (no baseline, no touch, no count): what building it from its configuration gave, without reading a
    /// file again. A batch builds its session once and restarts it for each input, so every
    /// input meets the same layout and models even if their files change meanwhile.
    pub fn restarted(self) -> Result<Session, SessionError> {
        let Session {
            setup,
            pipeline,
            tally,
            ..
        } = self;
        let mut fresh = Session::new(setup.links, pipeline.restarted()?, setup.options)?;
        fresh.setup.can = setup.can;
        fresh.setup.stitching = setup.stitching.map(|mut s| {
            s.clear_live_posture();
            s
        });
        // The same script, nothing scored.
        fresh.tally = tally.map(|t| Tally::new(t.into_script()));
        fresh.setup.source = setup.source;
        fresh.setup.layout_notes = setup.layout_notes;
        fresh.setup.simulated = setup.simulated;
        fresh.setup.calibration_ids = setup.calibration_ids;
        fresh.setup.kinematics = setup.kinematics;
        Ok(fresh)
    }
}
