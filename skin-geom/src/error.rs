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
    /// A layout read from a file could not be flattened ([`crate::read_map`]).
    #[error("{}: {source}", path.display())]
    Layout {
        /// The layout file.
        path: std::path::PathBuf,
        /// Why it could not be flattened.
        source: Box<Error>,
    },
    /// A user mesh file (OBJ, glTF) could not be used.
    #[error("{path}: {message}")]
    MeshFile {
        /// The file.
        path: String,
        /// What is wrong.
        message: String,
    },
    /// A list does not have the length what it goes with needs: a frame's values and the map's
    /// taxels, an image buffer and the grid, poses and the chain's links, ...
    #[error("{what}: {got}, expected {expected}")]
    Length {
        /// What was counted, and against what.
        what: &'static str,
        /// The length given.
        got: usize,
        /// The length needed.
        expected: usize,
    },
    /// A pose or a placement holds a number that is not finite.
    #[error("{what} is not finite")]
    NotFinite {
        /// Which pose, e.g. "the pose of link 1".
        what: String,
    },
    /// A parameter outside its range.
    #[error("{name} = {value}: expected {expected}")]
    Parameter {
        /// The parameter.
        name: &'static str,
        /// Its value.
        value: f64,
        /// Its range, in words.
        expected: &'static str,
    },
    /// An image or a grid with no pixel, or too many.
    #[error("a {rows} x {cols} image: {why}")]
    ImageSize {
        /// Rows asked for.
        rows: usize,
        /// Columns asked for.
        cols: usize,
        /// What is wrong with it.
        why: &'static str,
    },
    /// A tactile map with no triangle cannot be rendered.
    #[error("tactile map \"{map}\" has no triangle")]
    NoTriangle {
        /// The map's name.
        map: String,
    },
    /// A face names a taxel the link does not have.
    #[error("face {face} uses taxel index {index}, but the link has {taxels} taxels")]
    FaceIndex {
        /// The face.
        face: usize,
        /// The index it uses.
        index: usize,
        /// Taxels of the link.
        taxels: usize,
    },
    /// A mesh vertex with no taxel of the layout at its position.
    #[error(
        "mesh vertex {vertex} at ({:.4}, {:.4}, {:.4}) m has no taxel within {:.1} mm (nearest: taxel {nearest} at {:.1} mm)",
        at[0], at[1], at[2], tolerance_m * 1e3, distance_m * 1e3
    )]
    NoTaxelAtVertex {
        /// The vertex.
        vertex: usize,
        /// Its position, metres.
        at: [f64; 3],
        /// How far a taxel may be, metres.
        tolerance_m: f64,
        /// The nearest taxel.
        nearest: skin_core::TaxelId,
        /// Its distance, metres.
        distance_m: f64,
    },
    /// A chain of links that cannot be stitched as given.
    #[error("{0}")]
    Chain(ChainError),
    /// Stitching a chain at one of its postures failed.
    #[error("posture \"{posture}\": {source}")]
    Posture {
        /// The posture's name.
        posture: String,
        /// What failed.
        source: Box<Error>,
    },
    /// Writing an output file failed.
    #[error("{}: {source}", path.display())]
    Output {
        /// The file.
        path: std::path::PathBuf,
        /// What the operating system said.
        source: std::io::Error,
    },
    /// An image could not be encoded (PNG).
    #[error("encoding a PNG: {source}")]
    Encode {
        /// What the encoder said.
        source: image::ImageError,
    },
}

/// Why a chain of maps cannot be stitched.
#[derive(Debug, thiserror::Error)]
pub enum ChainError {
    /// Fewer than two links.
    #[error("stitching needs at least 2 links, got {0}")]
    TooFewLinks(usize),
    /// A map without the 3D positions of its taxels.
    #[error("map {index} (\"{name}\") has no 3D taxel positions: stitching needs them")]
    NoPositions {
        /// Its place in the chain.
        index: usize,
        /// Its name.
        name: String,
    },
    /// A joint with no taxel of a link near the other link.
    #[error("joint {joint}: the link \"{link}\" has no boundary taxel near its neighbour")]
    NoBoundary {
        /// The joint (between links `joint` and `joint + 1`).
        joint: usize,
        /// The link.
        link: String,
    },
    /// A boundary naming a taxel past the link's taxels.
    #[error("joint {joint}: boundary taxel index {index} is past the {taxels} taxels of \"{link}\"")]
    BoundaryIndex {
        /// The joint.
        joint: usize,
        /// The index given.
        index: usize,
        /// Taxels of the link.
        taxels: usize,
        /// The link.
        link: String,
    },
    /// Poses with no posture.
    #[error("the poses give no posture")]
    NoPosture,
    /// Contacts asked of a chain built without its contact search.
    #[error("the chain was built without contact search")]
    NoContactSearch,
    /// A bridge triangle naming a taxel no map has.
    #[error("bridge triangle {0} names a taxel no map has")]
    Bridge(crate::BridgeTriangle),
}

/// `Result` with this crate's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;
