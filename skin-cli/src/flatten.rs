//! `skin flatten`: a link's layout -> tactile map.

use anyhow::{Context, Result, bail};
use skin_core::LinkSkin;
use skin_core::format::{self, cyskin, icub};
use skin_geom::{FlattenOptions, MeshOptions, MeshSource, TactileMap, load_mesh_file};
use std::path::{Path, PathBuf};

/// Flatten a link's taxels into a 2D tactile map (least-squares conformal map).
///
/// INPUT is a skin layout: the project's JSON (`skin-layout/1`, its first link), a Cyskin
/// calibration JSON, an iCub `positions/*.txt` file (duplicated positions are merged and
/// reported), or a mesh (.obj, .gltf, .glb) whose vertices are the taxels. Without triangles in the
/// input, the taxels are triangulated (Delaunay in a best-fit plane or unrolled cylinder, whichever
/// fits; the report says which). Prints what was repaired and the map's distortion.
///
/// Output units are metres. Exit code 1 with one line on stderr if anything is wrong.
#[derive(clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// Layout file (.json, .txt, .obj, .gltf, .glb).
    input: PathBuf,
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
    let mut link = load_input(&args.input)?;
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

/// All links of a skin-layout/1 file, or the one link of any other layout file.
pub(crate) fn load_links(path: &Path) -> Result<Vec<LinkSkin>> {
    let text = std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    if text.contains("skin-layout/") {
        let layout = skin_core::format::native::read_layout(path)?;
        if layout.links.is_empty() {
            bail!("{}: the layout has no link", path.display());
        }
        return Ok(layout.links);
    }
    Ok(vec![crate::flatten::load_input(path)?])
}

pub(crate) fn load_input(path: &Path) -> Result<LinkSkin> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .unwrap_or_default();
    match ext.as_str() {
        "obj" | "gltf" | "glb" => {
            let name = path.file_stem().and_then(|s| s.to_str()).unwrap_or("mesh");
            Ok(load_mesh_file(path)?.into_link(name)?)
        }
        "txt" => {
            let read = icub::read(path, icub::Duplicates::Merge)?;
            crate::say!(
                "{}: {} taxel rows, {} unused (all-zero) rows dropped",
                path.display(),
                read.skin.taxels.len()
                    + read.zero_slots.len()
                    + read.duplicates.iter().map(|g| g.slots.len() - 1).sum::<usize>(),
                read.zero_slots.len()
            );
            if !read.duplicates.is_empty() {
                let merged: usize = read.duplicates.iter().map(|g| g.slots.len() - 1).sum();
                crate::say!(
                    "duplicated positions: {} groups, {merged} taxels merged into the first of their group:",
                    read.duplicates.len()
                );
                for g in &read.duplicates {
                    crate::say!("  lines {:?} (taxels {:?})", g.lines, g.slots);
                }
            }
            Ok(read.skin)
        }
        "json" => Ok(format::load_link(path)?),
        _ => bail!(
            "{}: unknown layout format (expected .json, .txt, .obj, .gltf or .glb)",
            path.display()
        ),
    }
}

fn print_report(input: &Path, link: &LinkSkin, map: &TactileMap) {
    let r = &map.report;
    let (w, h) = map.extent();
    crate::say!(
        "{}: link \"{}\", {} taxels",
        input.display(),
        link.name,
        link.taxels.len()
    );
    match r.source {
        Some(MeshSource::Triangulated { chart }) => crate::say!(
            "mesh: {} triangles, Delaunay in the {chart}; {} triangles bridging holes or the outer concavity removed",
            map.faces.len(),
            r.mesh.bridging_faces
        ),
        _ => crate::say!("mesh: {} triangles as given", map.faces.len()),
    }
    if !r.mesh.welded.is_empty() {
        crate::say!(
            "taxels at the same position (sharing one map point): {}",
            r.mesh
                .welded
                .iter()
                .map(|g| format!("{:?}", g.iter().map(|t| t.0).collect::<Vec<_>>()))
                .collect::<Vec<_>>()
                .join(" ")
        );
    }
    if r.mesh.degenerate_faces + r.mesh.duplicate_faces + r.pinch_faces > 0 {
        crate::say!(
            "dropped triangles: {} of zero area, {} repeated, {} pinched to another piece at one vertex",
            r.mesh.degenerate_faces,
            r.mesh.duplicate_faces,
            r.pinch_faces
        );
    }
    if !r.mesh.isolated.is_empty() {
        crate::say!(
            "taxels in no triangle (map point extrapolated from the nearest triangle): {:?}",
            r.mesh.isolated.iter().map(|t| t.0).collect::<Vec<_>>()
        );
    }
    if r.components > 1 {
        crate::say!(
            "{} separate pieces, flattened one by one and laid side by side",
            r.components
        );
    }
    crate::say!(
        "map: {:.1} x {:.1} mm (LSCM, area-preserving scale)",
        w * 1e3,
        h * 1e3
    );
    crate::say!("{}", r.distortion);
}
