//! Bus maps: which taxel each value on the wire belongs to.
//!
//! ```toml
//! format = "skin16"            # or "icub8"
//! [[bus]]
//! interface = "can0"           # the candump interface name, or the live interface
//! [[bus.module]]
//! address = 0                  # skin16: module_on_bus; icub8: board << 4 | triangle
//! taxels = [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11]   # taxel id of each of the 12 slots; -1 = unused
//! ```
//! Frames list their values in bus-map order: bus by bus, module by module, slot by slot, unused
//! slots skipped ([`BusMap::taxel_ids`]).

use crate::{Error, Result};
use serde::Deserialize;
use skin_core::TaxelId;
use std::path::Path;

/// Slots per module (12 channels of a Cyskin or iCub triangle).
pub const SLOTS: usize = 12;

/// The most buses (CAN interfaces) a bus map or a log may name: more than any skin has, and a
/// bound on what a bad file can make the assembler hold.
pub const MAX_BUSES: usize = 256;

/// The wire format of every bus in a map.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum WireFormat {
    /// The project's 16-bit format with a broadcast sync (see [`crate::decode::skin16`]).
    Skin16,
    /// The iCub skin periodic message, 8-bit values, no sync.
    Icub8,
}

impl WireFormat {
    /// The name used in bus maps and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            WireFormat::Skin16 => "skin16",
            WireFormat::Icub8 => "icub8",
        }
    }
}

/// Why [`BusMap::for_taxels`] cannot split a layout's taxels over buses.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SplitError {
    /// A number of buses outside 1..=[`MAX_BUSES`].
    #[error("{0} buses: give 1 to {MAX_BUSES}")]
    Buses(usize),
    /// A taxel id whose channel (`id & 15`) is not one of a module's 12.
    #[error("taxel {0} has channel {c}; Cyskin modules have channels 0..11", c = .0.channel())]
    Channel(TaxelId),
    /// A taxel id listed twice.
    #[error("taxel {0} appears twice")]
    Repeated(TaxelId),
    /// More buses than modules.
    #[error("{buses} buses for {modules} module(s) would leave buses empty: give at most {}", .modules.max(&1))]
    EmptyBuses {
        /// Buses asked for.
        buses: usize,
        /// Modules of the layout.
        modules: usize,
    },
    /// More modules per bus than the wire format can address.
    #[error("{modules} modules on {buses} bus(es) is more than {} allows per bus ({limit}): use more buses", .format.name())]
    Crowded {
        /// Modules of the layout.
        modules: usize,
        /// Buses asked for.
        buses: usize,
        /// The wire format.
        format: WireFormat,
        /// Its addresses per bus.
        limit: usize,
    },
    /// The map made fails the checks of a bus map read from a file (a fault of this function).
    #[error("the bus map made for these taxels is not valid: {0}")]
    Check(String),
}

/// One module (triangle) on a bus.
#[derive(Debug, Clone, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModuleMap {
    /// skin16: the module's number on its bus (0..128); icub8: board << 4 | triangle.
    pub address: u32,
    /// Taxel id of each of the 12 slots; -1 for an unused slot.
    pub taxels: Vec<i64>,
}

/// One bus.
#[derive(Debug, Clone, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BusSpec {
    /// Interface name (`can0`, ...), as in candump logs.
    pub interface: String,
    /// Its modules.
    #[serde(default, rename = "module")]
    pub modules: Vec<ModuleMap>,
}

/// A whole bus map.
#[derive(Debug, Clone, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BusMap {
    /// Wire format.
    pub format: WireFormat,
    /// The buses.
    #[serde(rename = "bus")]
    pub buses: Vec<BusSpec>,
}

impl BusMap {
    /// Reads a bus map file (refused past
    /// [`MAX_DOCUMENT_BYTES`](skin_core::text::MAX_DOCUMENT_BYTES), as every file read whole).
    pub fn read(path: &Path) -> Result<BusMap> {
        Self::parse(&skin_core::format::read_text(path)?, path)
    }

    /// Parses bus-map TOML and checks it; `path` is used in error messages.
    pub fn parse(text: &str, path: &Path) -> Result<BusMap> {
        let map: BusMap = toml::from_str(text).map_err(|e| {
            let line = e.span().map_or(0, |s| {
                text.get(..s.start).unwrap_or(text).matches('\n').count() + 1
            });
            Error::Line {
                path: path.to_owned(),
                line,
                message: e.message().to_string(),
            }
        })?;
        map.check().map_err(|message| Error::Invalid {
            path: path.to_owned(),
            message,
        })?;
        Ok(map)
    }

    fn check(&self) -> std::result::Result<(), String> {
        if self.buses.len() > MAX_BUSES {
            return Err(format!(
                "{} buses; a bus map names at most {MAX_BUSES}",
                self.buses.len()
            ));
        }
        let mut seen = std::collections::HashMap::new();
        for (b, bus) in self.buses.iter().enumerate() {
            let name = skin_core::format::excerpt(&bus.interface);
            if self.buses[..b].iter().any(|o| o.interface == bus.interface) {
                return Err(format!("interface \"{name}\" appears on two buses"));
            }
            for (m, module) in bus.modules.iter().enumerate() {
                let place = format!("bus \"{name}\" module {m} (address {})", module.address);
                if module.taxels.len() != SLOTS {
                    return Err(format!(
                        "{place}: {} taxel slots, expected {SLOTS}",
                        module.taxels.len()
                    ));
                }
                if self.format == WireFormat::Skin16 && module.address >= 128 {
                    return Err(format!("{place}: skin16 addresses are 0..127"));
                }
                if self.format == WireFormat::Icub8 && module.address >= 256 {
                    return Err(format!(
                        "{place}: icub8 addresses are board << 4 | triangle, 0..255"
                    ));
                }
                if bus.modules[..m].iter().any(|o| o.address == module.address) {
                    return Err(format!("{place}: address used twice on this bus"));
                }
                for (slot, &t) in module.taxels.iter().enumerate() {
                    if t == -1 {
                        continue;
                    }
                    let id = u32::try_from(t)
                        .map_err(|_| format!("{place} slot {slot}: taxel id {t} is not -1 or a u32"))?;
                    if let Some(first) = seen.insert(id, place.clone()) {
                        return Err(format!("{place} slot {slot}: taxel {id} is also in {first}"));
                    }
                }
            }
        }
        Ok(())
    }

    /// Each module in bus-map order: its bus's index, the module, and its slots in the assembled
    /// frame (indices into [`BusMap::taxel_ids`]; unused slots take none).
    pub fn module_slots(&self) -> impl Iterator<Item = (usize, &ModuleMap, std::ops::Range<usize>)> {
        let mut slot = 0;
        self.buses
            .iter()
            .enumerate()
            .flat_map(|(b, bus)| bus.modules.iter().map(move |m| (b, m)))
            .map(move |(b, m)| {
                let used = m.taxels.iter().filter(|&&t| t >= 0).count();
                slot += used;
                (b, m, slot - used..slot)
            })
    }

    /// The slots of an assembled frame: the taxels the buses carry, without listing them.
    pub fn slot_count(&self) -> usize {
        self.buses
            .iter()
            .flat_map(|b| &b.modules)
            .map(|m| m.taxels.iter().filter(|&&t| t >= 0).count())
            .sum()
    }

    /// Taxel ids in bus-map order (bus, module, slot; unused slots skipped): the column order of
    /// assembled frames.
    pub fn taxel_ids(&self) -> Vec<TaxelId> {
        self.buses
            .iter()
            .flat_map(|b| b.modules.iter())
            .flat_map(|m| m.taxels.iter())
            .filter(|&&t| t >= 0)
            .map(|&t| TaxelId(t as u32))
            .collect()
    }
}

impl BusMap {
    /// A bus map for taxels with Cyskin ids (module << 4 | channel, channel 0..=11): modules in
    /// increasing order, split into `buses` nearly equal consecutive blocks on `can0`, `can1`, ...,
    /// addressed from 0 on each bus; a channel no taxel uses is an unused slot.
    pub fn for_taxels(
        ids: &[TaxelId],
        format: WireFormat,
        buses: usize,
    ) -> std::result::Result<BusMap, SplitError> {
        if buses == 0 || buses > MAX_BUSES {
            return Err(SplitError::Buses(buses));
        }
        let mut modules: std::collections::BTreeMap<u32, Vec<i64>> = std::collections::BTreeMap::new();
        for id in ids {
            let channel = id.channel() as usize;
            if channel >= SLOTS {
                return Err(SplitError::Channel(*id));
            }
            let slots = modules.entry(id.module()).or_insert_with(|| vec![-1; SLOTS]);
            if slots[channel] != -1 {
                return Err(SplitError::Repeated(*id));
            }
            slots[channel] = i64::from(id.0);
        }
        if buses > modules.len().max(1) {
            return Err(SplitError::EmptyBuses {
                buses,
                modules: modules.len(),
            });
        }
        let per_bus = modules.len().div_ceil(buses).max(1);
        let limit = match format {
            WireFormat::Skin16 => 128,
            WireFormat::Icub8 => 256,
        };
        if per_bus > limit {
            return Err(SplitError::Crowded {
                modules: modules.len(),
                buses,
                format,
                limit,
            });
        }
        let modules: Vec<Vec<i64>> = modules.into_values().collect();
        let even = (buses - 1) * per_bus >= modules.len();
        let map = BusMap {
            format,
            buses: (0..buses)
                .map(|b| BusSpec {
                    interface: format!("can{b}"),
                    // Consecutive blocks of `per_bus`; where those would leave the last buses
                    // empty (65 modules on 60 buses), blocks as even as can be instead.
                    modules: modules
                        .iter()
                        .skip(if even {
                            b * (modules.len() / buses) + b.min(modules.len() % buses)
                        } else {
                            b * per_bus
                        })
                        .take(if even {
                            modules.len() / buses + usize::from(b < modules.len() % buses)
                        } else {
                            per_bus
                        })
                        .enumerate()
                        .map(|(a, taxels)| ModuleMap {
                            address: a as u32,
                            taxels: taxels.clone(),
                        })
                        .collect(),
                })
                .collect(),
        };
        map.check().map_err(SplitError::Check)?;
        Ok(map)
    }

    /// The map in its TOML form.
    pub fn to_toml(&self) -> String {
        use std::fmt::Write as _;
        let mut s = format!("format = \"{}\"\n", self.format.name());
        for bus in &self.buses {
            let _ = write!(s, "\n[[bus]]\ninterface = \"{}\"\n", bus.interface);
            for m in &bus.modules {
                let taxels: Vec<String> = m.taxels.iter().map(i64::to_string).collect();
                let _ = write!(
                    s,
                    "\n[[bus.module]]\naddress = {}\ntaxels = [{}]\n",
                    m.address,
                    taxels.join(", ")
                );
            }
        }
        s
    }
}
