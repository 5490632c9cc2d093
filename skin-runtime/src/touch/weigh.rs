//! A link's force, frame by frame: each taxel's force from its pressure, each contact weighed,
//! and the link's wrench over its contacts' taxels ([`skin_core::force`]). Buffers are sized
//! once; a frame allocates nothing.

use nalgebra::{Point3, Vector3};
use skin_core::ContactFinder;
use skin_core::force::{ForceError, ForceModel, Wrench};

/// A calibrated link's force model and what it made of the last frame.
#[derive(Debug, Clone)]
pub(super) struct LinkForce {
    model: ForceModel,
    normals: Vec<Vector3<f64>>,
    forces: Vec<f64>,
    /// Over the last frame's contacts (zero with none).
    pub(super) wrench: Wrench,
    /// Taxels of the last frame's contacts read past saturation (their forces lower bounds).
    pub(super) saturated: usize,
}

impl LinkForce {
    /// `model` over a link of `taxels` taxels with outward `normals` (layout order).
    pub(super) fn new(
        model: ForceModel,
        normals: Vec<Vector3<f64>>,
        taxels: usize,
    ) -> Result<LinkForce, ForceError> {
        for (what, got) in [("gains", model.len()), ("normals", normals.len())] {
            if got != taxels {
                return Err(ForceError::Length { what, got, taxels });
            }
        }
        Ok(LinkForce {
            model,
            normals,
            forces: vec![0.0; taxels],
            wrench: Wrench::default(),
            saturated: 0,
        })
    }

    /// Weighs the contacts `finder` found last in `pressures`, and sums the link's wrench over
    /// their taxels at `positions`.
    pub(super) fn frame(
        &mut self,
        pressures: &[f32],
        finder: &mut ContactFinder,
        positions: &[Point3<f64>],
    ) -> Result<(), skin_core::Error> {
        self.saturated = 0;
        self.forces.fill(0.0);
        // Only the contacts' taxels: noise elsewhere is no load.
        for c in finder.last() {
            for &i in &c.taxels {
                let (force, saturated) = self.model.force(i, f64::from(pressures[i]));
                self.forces[i] = force;
                self.saturated += usize::from(saturated);
            }
        }
        let contacts = finder.weigh(&self.forces)?;
        let taxels = contacts.iter().flat_map(|c| c.taxels.iter().copied());
        self.wrench = Wrench::of_taxels(positions, &self.normals, &self.forces, taxels);
        Ok(())
    }

    /// The same curve and gains over new `areas` (m², layout order): a mesh made again
    /// without the dead taxels.
    pub(super) fn set_areas(&mut self, areas: Vec<f64>) -> Result<(), ForceError> {
        self.model = ForceModel::new(self.model.curve(), self.model.gains().to_vec(), areas)?;
        Ok(())
    }

    /// The same model with nothing weighed yet (for the next input of a batch).
    pub(super) fn restarted(mut self) -> LinkForce {
        self.wrench = Wrench::default();
        self.saturated = 0;
        self.forces.fill(0.0);
        self
    }

    /// The model.
    pub(super) fn model(&self) -> &ForceModel {
        &self.model
    }

    /// Each taxel's force in the last frame, N (zero outside its contacts).
    pub(super) fn forces(&self) -> &[f64] {
        &self.forces
    }

    /// The normals.
    pub(super) fn normals(&self) -> &[Vector3<f64>] {
        &self.normals
    }
}
