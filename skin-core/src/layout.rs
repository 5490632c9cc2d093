use crate::{Taxel, TaxelId};
use nalgebra::Matrix4;
use std::collections::HashMap;

/// The skin of one robot link: its taxels and, when known, the triangles between them.
#[derive(Debug, Clone, PartialEq)]
pub struct LinkSkin {
    /// Name of the link (e.g. `forearm`, or the URDF link name).
    pub name: String,
    /// The taxels, in layout order: a [`crate::Frame`] for this link has one value per taxel in
    /// this order.
    pub taxels: Vec<Taxel>,
    /// Triangles over the taxels, as indices into `taxels`, when the file gives them (Cyskin
    /// `faces`). `None` means the mesh must be built (see `skin-geom`).
    pub faces: Option<Vec<[usize; 3]>>,
    /// Pose of the frame the taxels are expressed in, relative to its parent link frame
    /// (homogeneous 4x4, metres), when the file gives one (Cyskin `parent_frames[0].tf_matrix`).
    pub frame_to_parent: Option<Matrix4<f64>>,
}

impl LinkSkin {
    /// A skin with taxels and no triangles.
    pub fn new(name: impl Into<String>, taxels: Vec<Taxel>) -> Self {
        LinkSkin {
            name: name.into(),
            taxels,
            faces: None,
            frame_to_parent: None,
        }
    }

    /// Index of each taxel id in layout order.
    pub fn index_of(&self) -> HashMap<TaxelId, usize> {
        self.taxels.iter().enumerate().map(|(i, t)| (t.id, i)).collect()
    }

    /// The taxel ids in layout order.
    pub fn ids(&self) -> Vec<TaxelId> {
        self.taxels.iter().map(|t| t.id).collect()
    }
}

/// The skins of all sensorised links of a robot.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SkinLayout {
    /// One entry per link.
    pub links: Vec<LinkSkin>,
}

impl SkinLayout {
    /// Total number of taxels over all links.
    pub fn taxel_count(&self) -> usize {
        self.links.iter().map(|l| l.taxels.len()).sum()
    }

    /// The link called `name`.
    pub fn link(&self, name: &str) -> Option<&LinkSkin> {
        self.links.iter().find(|l| l.name == name)
    }
}
