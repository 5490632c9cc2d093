//! `skin busmap`: a bus map for a layout's taxels.

use anyhow::{Result, bail};
use skin_can::{BusMap, WireFormat};
use skin_core::LinkSkin;
use std::path::PathBuf;

/// Write a bus map (TOML) for a layout whose taxel ids follow the Cyskin convention.
///
/// Taxel ids are module << 4 | channel. Modules in increasing order, split into consecutive blocks over the
/// buses can0, can1, ..., addressed from 0 on each bus. Prints it, or writes it with -o.
#[derive(clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// Layout (any file `skin flatten` reads).
    #[arg(long, value_name = "L.json")]
    layout: PathBuf,
    /// Wire format.
    #[arg(long, value_enum, default_value_t = Format::Skin16)]
    format: Format,
    /// Number of buses (at most 256, and no more than the layout has modules).
    #[arg(long, default_value_t = 1, value_parser = crate::numbers::count::<1, { skin_can::MAX_BUSES as u64 }>)]
    buses: usize,
    /// Where to write the map (default: standard output).
    #[arg(short, long, value_name = "MAP.toml")]
    output: Option<PathBuf>,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Format {
    Skin16,
    Icub8,
}

pub fn run(args: Args) -> Result<()> {
    let inputs = crate::output::Inputs::new([&args.layout]);
    crate::output::replaceable(&inputs, args.output.as_deref(), crate::output::Kind::BusMap)?;
    inputs.check_outputs(&[("-o", args.output.as_deref())])?;
    let ids: Vec<_> = crate::shared::load_links(&args.layout)?
        .iter()
        .flat_map(LinkSkin::ids)
        .collect();
    let format = match args.format {
        Format::Skin16 => WireFormat::Skin16,
        Format::Icub8 => WireFormat::Icub8,
    };
    let map = match BusMap::for_taxels(&ids, format, args.buses) {
        Ok(m) => m,
        Err(e) => bail!("{}: {e}", args.layout.display()),
    };
    match &args.output {
        Some(out) => {
            crate::output::write_file(out, map.to_toml().as_bytes(), &inputs)?;
            crate::say!("wrote {}", out.display());
        }
        None => crate::say!("{}", map.to_toml()),
    }
    Ok(())
}
