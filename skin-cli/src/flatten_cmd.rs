//! `skin flatten`: a link's layout -> tactile map.

use anyhow::{Context, Result, bail};
use skin_core::LinkSkin;
use skin_core::format::cyskin;
use skin_geom::{FlattenOptions, MeshOptions, TactileMap, load_mesh_file};
use std::path::{Path, PathBuf};

/// Flatten a link's taxels into a 2D tactile map (least-squares conformal map).
///
/// INPUT is a skin layout: the project's JSON (`skin-layout/1`), a Cyskin calibration JSON, an
/// iCub `positions/*.txt` file (duplicated positions are merged and reported), a URDF whose
/// tactile sensors (urdf_tactile arrays and taxel lists) give one skin per link, or a mesh
/// (.obj, .gltf, .glb) whose vertices are the taxels. A file of several links needs --link.
/// Without triangles in the input, the taxels are triangulated (Delaunay in a best-fit plane or
/// unrolled cylinder, whichever fits; the report says which). Prints what was repaired (real
/// files' quirks, each named) and the map's distortion.
///
/// Output units are metres. Exit code 1 with one line on stderr if anything is wrong.
#[derive(clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// Layout file (.json, .txt, .urdf, .obj, .gltf, .glb).
    input: PathBuf,
    /// The link to flatten, in a file of several (a skin-layout/1 or a URDF).
    #[arg(long, value_name = "NAME")]
    link: Option<String>,
    /// Where to write the tactile map.
    #[arg(short, long, value_name = "MAP.json")]
    output: PathBuf,
    /// `native`: the project's map (3D and 2D points, triangles, report), readable by `skin image`;
    /// `cyskin`: Cyskin `tactile_maps` JSON (2D points in metres, triangles).
    #[arg(long, value_enum, default_value_t = MapFormat::Native)]
    format: MapFormat,
    /// Also draw the map (triangles and taxels, millimetres) to this SVG file.
    #[arg(long, value_name = "MAP.svg")]
    svg: Option<PathBuf>,
    /// Take the triangles from this mesh (.obj, .gltf, .glb); each vertex must lie on a taxel.
    #[arg(long, value_name = "MESH")]
    mesh: Option<PathBuf>,
    /// Ignore triangles given in the input and triangulate the taxels.
    #[arg(long)]
    triangulate: bool,
    /// Triangulation: an edge longer than this many local taxel pitches bridges a hole.
    #[arg(long, default_value_t = 3.0, value_name = "PITCHES", value_parser = crate::numbers::above(0.0, 1e3))]
    max_edge: f64,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum MapFormat {
    Native,
    Cyskin,
}

pub fn run(args: Args) -> Result<()> {
    let inputs = crate::output::Inputs::new([Some(&args.input), args.mesh.as_ref()].into_iter().flatten());
    crate::output::replaceable(&inputs, Some(&args.output), crate::output::Kind::Map)?;
    crate::output::replaceable(&inputs, args.svg.as_deref(), crate::output::Kind::Svg)?;
    inputs.check_outputs(&[("-o", Some(&args.output)), ("--svg", args.svg.as_deref())])?;
    let mut links = crate::shared::load_links(&args.input)?;
    let names: Vec<&str> = links.iter().map(|l| l.name.as_str()).collect();
    let pick = match (&args.link, links.len()) {
        (None, 1) => 0,
        (None, n) => bail!(
            "{}: {n} links ({}); choose one with --link",
            args.input.display(),
            names.join(", ")
        ),
        (Some(name), _) => names.iter().position(|n| n == name).with_context(|| {
            format!(
                "{}: no link \"{name}\" (it has {})",
                args.input.display(),
                names.join(", ")
            )
        })?,
    };
    let mut link = links.swap_remove(pick);
    if let Some(mesh_path) = &args.mesh {
        let mesh = load_mesh_file(mesh_path)?;
        link = mesh
            .attach_to(&link, 1e-3)
            .with_context(|| format!("{}", mesh_path.display()))?;
    }
    if link.name.is_empty() {
        link.name = args
            .input
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or("link")
            .to_string();
    }
    let options = FlattenOptions {
        mesh: MeshOptions {
            use_given_faces: !args.triangulate,
            max_edge_pitches: args.max_edge,
            ..MeshOptions::default()
        },
    };
    let map = TactileMap::flatten(&link, &options).with_context(|| format!("{}", args.input.display()))?;
    print_report(&args.input, &link, &map);

    let text = match args.format {
        MapFormat::Native => map.to_json(),
        MapFormat::Cyskin => cyskin::tactile_map_to_string(&map.to_cyskin()),
    };
    crate::output::write_file(&args.output, text.as_bytes(), &inputs)?;
    crate::say!("wrote {}", args.output.display());
    if let Some(svg) = &args.svg {
        crate::output::write_file(svg, map.to_svg().as_bytes(), &inputs)?;
        crate::say!("wrote {}", svg.display());
    }
    Ok(())
}

fn print_report(input: &Path, link: &LinkSkin, map: &TactileMap) {
    crate::say!(
        "{}: link \"{}\", {} taxels",
        input.display(),
        link.name,
        link.taxels.len()
    );
    crate::say!("{}", map.flattening());
}
