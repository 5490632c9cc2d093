use crate::TaxelId;

/// One synchronous snapshot of a skin: a timestamp and one value per taxel, in layout order.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    /// Acquisition time, seconds (from the start of the recording, or any fixed epoch).
    pub time: f64,
    /// One reading per taxel, in the order of the taxel list the frame belongs to.
    pub values: Vec<f32>,
}

/// A sequence of frames over a fixed list of taxels.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Recording {
    /// The taxels, in the order of each frame's values.
    pub taxel_ids: Vec<TaxelId>,
    /// Frame numbers as recorded (Cyskin recordings count from 0).
    pub frame_numbers: Vec<u64>,
    /// The frames.
    pub frames: Vec<Frame>,
}
