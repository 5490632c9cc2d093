/// Everything that can go wrong building a mesh, a tactile map or a tactile image.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Reading or checking an input file failed.
    #[error(transparent)]
    Core(#[from] skin_core::Error),
    /// The taxels cannot give a surface: too few, all collinear, or all at one point.
    #[error("{0}")]
    TooFewTaxels(String),
    /// A mesh edge is shared by more than two triangles, so the surface is not a manifold.
    #[error(
        "edge between taxels {a} and {b} is shared by {count} triangles (faces {faces:?}); a skin surface has at most two per edge"
    )]
    NonManifoldEdge {
        /// Taxel id at one end of the edge.
        a: skin_core::TaxelId,
        /// Taxel id at the other end.
        b: skin_core::TaxelId,
        /// How many triangles use the edge.
        count: usize,
        /// Indices of those triangles (at most 4 listed).
        faces: Vec<usize>,
    },
    /// The triangles of one piece cannot be oriented consistently (a Moebius-like strip) or the
    /// piece is closed: either way it cannot be flattened in one piece.
    #[error("{0}")]
    NotFlattenable(String),
    /// The sparse linear solve failed.
    #[error("LSCM solve failed: {0}")]
    Solve(String),
    /// A user mesh file (OBJ, glTF) could not be used.
    #[error("{path}: {message}")]
    MeshFile {
        /// The file.
        path: String,
        /// What is wrong.
        message: String,
    },
    /// A tactile map, grid or frame does not fit what it is used with.
    #[error("{0}")]
    Mismatch(String),
    /// Writing an output file failed.
    #[error("{path}: {message}")]
    Output {
        /// The file.
        path: String,
        /// What went wrong.
        message: String,
    },
}

/// `Result` with this crate's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;
