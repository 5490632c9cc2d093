//! What a file or folder is, whatever its name: its device and inode. An output is checked
//! against these so that nothing is written over (or removed in place of) a file that took the
//! name of the one skin made.

use std::path::Path;

/// A file's device and inode.
pub(super) type FileId = (u64, u64);

/// The device and inode in `m`.
#[cfg(unix)]
pub(super) fn file_id(m: &std::fs::Metadata) -> FileId {
    use std::os::unix::fs::MetadataExt as _;
    (m.dev(), m.ino())
}

/// No device and inode off Unix: every file looks the same, so the checks that compare them
/// fall back on names.
#[cfg(not(unix))]
pub(super) fn file_id(_: &std::fs::Metadata) -> FileId {
    (0, 0)
}

/// The device and inode of the file or folder at `path` itself (a link is not followed).
pub(super) fn id_of(path: &Path) -> Option<FileId> {
    std::fs::symlink_metadata(path).ok().map(|m| file_id(&m))
}

/// The device and inode of the folder a user named: through a symbolic link (an output folder
/// given as a link is written through it).
pub(super) fn folder_id(path: &Path) -> Option<FileId> {
    std::fs::metadata(path).ok().map(|m| file_id(&m))
}

/// Whether `path` is still the file or folder `id` (unknown ids match).
pub(super) fn is_same(path: &Path, id: Option<FileId>) -> bool {
    match id {
        Some(id) => id_of(path) == Some(id),
        None => true,
    }
}
