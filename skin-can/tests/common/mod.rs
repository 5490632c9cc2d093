//! Test data shared by skin-can's test files.

#![allow(dead_code, clippy::unwrap_used)] // each test file uses what it needs

use skin_can::BusMap;
use std::path::Path;

/// Two skin16 buses: modules 0 and 5 on can0 (taxels 16-26, 32-42), module 1 on can1 (48-58);
/// slot 11 unused.
pub const TWO_BUSES: &str = r#"
format = "skin16"
[[bus]]
interface = "can0"
[[bus.module]]
address = 0
taxels = [16, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26, -1]
[[bus.module]]
address = 5
taxels = [32, 33, 34, 35, 36, 37, 38, 39, 40, 41, 42, -1]
[[bus]]
interface = "can1"
[[bus.module]]
address = 1
taxels = [48, 49, 50, 51, 52, 53, 54, 55, 56, 57, 58, -1]
"#;

/// [`TWO_BUSES`], parsed.
pub fn two_buses() -> BusMap {
    BusMap::parse(TWO_BUSES, Path::new("map.toml")).unwrap()
}
