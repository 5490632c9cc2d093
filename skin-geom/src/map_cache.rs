//! Tactile maps made once and kept: flattening a link of thousands of taxels takes a second or
//! more, and a runtime that starts often (a robot stack, `skin run`) needs the same maps each time.
//!
//! A map is kept in a folder under a name made of the link's name and a 64-bit FNV-1a hash of
//! the layout file's bytes, the link's name and the flattening options: any change to the
//! layout gives new names, so a stale map is never read. A kept map that does not read, or
//! does not list the link's taxels in layout order, is made again. A map that cannot be kept (a
//! read-only folder, a full disk) is still made and used: the cache only saves time
//! ([`MapCache::check_writable`] says so up front).

use crate::{FlattenOptions, Result, TactileMap};
use skin_core::LinkSkin;
use skin_core::output::{Inputs, write_file};
use std::path::{Path, PathBuf};

/// A folder of tactile maps keyed by layout content.
///
/// ```
/// use nalgebra::{Point3, Unit, Vector3};
/// use skin_core::{LinkSkin, Taxel, TaxelId};
/// use skin_geom::{FlattenOptions, MapCache};
///
/// let taxels = (0..16u32)
///     .map(|i| Taxel {
///         id: TaxelId(i),
///         position: Point3::new((i % 4) as f64 * 0.008, (i / 4) as f64 * 0.008, 0.0),
///         normal: Unit::new_normalize(Vector3::z()),
///     })
///     .collect();
/// let link = LinkSkin::new("patch", taxels);
/// let layout = b"the layout file's bytes";
/// let dir = std::env::temp_dir().join(format!("skin-map-cache-doc-{}", std::process::id()));
/// let cache = MapCache::new(&dir);
/// let (made, from_cache) = cache.map(layout, &link, &FlattenOptions::default())?;
/// assert!(!from_cache);
/// let (kept, from_cache) = cache.map(layout, &link, &FlattenOptions::default())?;
/// assert!(from_cache && kept.ids == made.ids);
/// # std::fs::remove_dir_all(&dir).ok();
/// # Ok::<(), skin_geom::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MapCache {
    dir: PathBuf,
}

impl MapCache {
    /// A cache in `dir` (created when the first map is kept).
    pub fn new(dir: impl Into<PathBuf>) -> MapCache {
        MapCache { dir: dir.into() }
    }

    /// The folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Where the map of `link` of the layout whose file holds `layout` is kept.
    pub fn path(&self, layout: &[u8], link: &LinkSkin, options: &FlattenOptions) -> PathBuf {
        let mut h = fnv1a(FNV_OFFSET, layout);
        h = fnv1a(h, link.name.as_bytes());
        h = fnv1a(h, format!("{options:?}").as_bytes());
        let safe: String = link
            .name
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                    c
                } else {
                    '_'
                }
            })
            .collect();
        self.dir.join(format!("{safe}-{h:016x}.map.json"))
    }

    /// Whether maps can be kept in the folder (made if missing): an error says why not, for a
    /// warning that every run will flatten its maps again. Nothing is left behind.
    pub fn check_writable(&self) -> std::io::Result<()> {
        let probe = self.dir.join(".skin-write-check");
        match skin_core::output::OutputFile::create(&probe, &Inputs::default()) {
            Ok(_dropped_unfinished) => Ok(()),
            Err(skin_core::output::OutputError::Io { source, .. }) => Err(source),
            Err(e) => Err(std::io::Error::other(e.to_string())),
        }
    }

    /// The map of `link`: read from the cache when kept there for this `layout` (the layout
    /// file's bytes) and these options, else flattened and kept (if it can be: a folder that
    /// cannot be written only costs the time to flatten again). Also says whether it came from
    /// the cache.
    pub fn map(
        &self,
        layout: &[u8],
        link: &LinkSkin,
        options: &FlattenOptions,
    ) -> Result<(TactileMap, bool)> {
        let path = self.path(layout, link, options);
        if let Ok(map) = TactileMap::read(&path)
            && map.ids == link.ids()
        {
            return Ok((map, true));
        }
        let map = TactileMap::flatten(link, options)?;
        // Not kept: the map is as good, only the next run flattens it again.
        let _ = write_file(&path, map.to_json().as_bytes(), &Inputs::default());
        Ok((map, false))
    }
}

const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;

/// 64-bit FNV-1a: small, stable across versions and platforms (std's hashers are neither).
fn fnv1a(mut h: u64, bytes: &[u8]) -> u64 {
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use nalgebra::{Point3, Unit, Vector3};
    use skin_core::{Taxel, TaxelId};

    fn link(name: &str, n: u32) -> LinkSkin {
        let taxels = (0..n * n)
            .map(|i| Taxel {
                id: TaxelId(100 + i),
                position: Point3::new(f64::from(i % n) * 0.008, f64::from(i / n) * 0.008, 0.0),
                normal: Unit::new_normalize(Vector3::z()),
            })
            .collect();
        LinkSkin::new(name, taxels)
    }

    #[test]
    fn fnv1a_is_the_published_function() {
        // Test vectors of the FNV reference: "" and "a".
        assert_eq!(fnv1a(FNV_OFFSET, b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a(FNV_OFFSET, b"a"), 0xaf63_dc4c_8601_ec8c);
    }

    #[test]
    fn a_changed_layout_or_a_stale_file_is_never_read_back() {
        let dir = tempfile::tempdir().unwrap();
        let cache = MapCache::new(dir.path().join("maps"));
        let o = FlattenOptions::default();
        let (a, cached) = cache.map(b"v1", &link("fore arm", 4), &o).unwrap();
        assert!(!cached);
        assert!(cache.map(b"v1", &link("fore arm", 4), &o).unwrap().1);
        // Another layout file: another name, made again.
        assert_ne!(
            cache.path(b"v2", &link("fore arm", 4), &o),
            cache.path(b"v1", &link("fore arm", 4), &o)
        );
        assert!(!cache.map(b"v2", &link("fore arm", 4), &o).unwrap().1);
        // A kept file of other taxels (edited by hand) or garbage: made again, and replaced.
        let path = cache.path(b"v1", &link("fore arm", 4), &o);
        std::fs::write(&path, link_map(3)).unwrap();
        let (b, cached) = cache.map(b"v1", &link("fore arm", 4), &o).unwrap();
        assert!(!cached && b.ids == a.ids);
        std::fs::write(&path, "{").unwrap();
        assert!(!cache.map(b"v1", &link("fore arm", 4), &o).unwrap().1);
        assert!(cache.map(b"v1", &link("fore arm", 4), &o).unwrap().1);
    }

    #[cfg(unix)]
    #[test]
    fn a_folder_that_cannot_be_written_still_gives_maps() {
        // A file where the folder should be: nothing can be kept there, whoever runs this.
        let dir = tempfile::tempdir().unwrap();
        let blocked = dir.path().join("cache");
        std::fs::write(&blocked, "a file, not a folder").unwrap();
        let cache = MapCache::new(blocked.join("maps"));
        assert!(cache.check_writable().is_err());
        let o = FlattenOptions::default();
        let (map, cached) = cache.map(b"v1", &link("fore arm", 4), &o).unwrap();
        assert!(!cached && map.ids == link("fore arm", 4).ids());
        // A folder that can be written: checked, and nothing left behind.
        let ok = MapCache::new(dir.path().join("ok"));
        ok.check_writable().unwrap();
        assert_eq!(std::fs::read_dir(ok.dir()).unwrap().count(), 0);
    }

    fn link_map(n: u32) -> String {
        TactileMap::flatten(&link("fore arm", n), &FlattenOptions::default())
            .unwrap()
            .to_json()
    }
}
