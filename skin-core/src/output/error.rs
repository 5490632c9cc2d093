//! Why an output cannot be written, naming the path the user gave.

use std::fmt;
use std::path::{Path, PathBuf};

/// What the output rules return.
pub(super) type Result<T, E = OutputError> = std::result::Result<T, E>;

/// Why an output cannot be written. Each variant names the path the user gave.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// The output is one of the inputs (`input` as the user named it).
    #[error("{}: the output is {}; write it elsewhere", output.display(), same_as(output, input))]
    IsInput {
        /// The output.
        output: PathBuf,
        /// The input it would overwrite.
        input: PathBuf,
    },
    /// Two outputs name the same file.
    #[error("{first} and {second} name the same file {}; give each its own", path.display())]
    SameFile {
        /// How the first is named (a flag, e.g. `-o`).
        first: String,
        /// How the second is named.
        second: String,
        /// The file.
        path: PathBuf,
    },
    /// A folder where a file is expected.
    #[error("{}: a folder; give a file name (e.g. {})", path.display(), path.join("out").display())]
    IsFolder {
        /// The path given.
        path: PathBuf,
    },
    /// Something other than a folder where a folder is expected.
    #[error("{}: exists and is not a folder", path.display())]
    NotAFolder {
        /// The path given.
        path: PathBuf,
    },
    /// A folder that holds files this command did not write.
    #[error(
        "{}: holds {whose} ({}); choose a new or empty folder, or force writing {command}'s files into it (nothing else there is touched)",
        dir.display(),
        listing(files)
    )]
    NotOurs {
        /// The folder.
        dir: PathBuf,
        /// Whose files they are: skin did not write them, or another command did.
        whose: Whose,
        /// Some of those files, sorted.
        files: Vec<String>,
        /// The command that wanted to write.
        command: String,
    },
    /// Another process holds the folder's lock.
    #[error(
        "{}: another skin command is writing this folder; wait for it to finish or choose another output folder",
        dir.display()
    )]
    Busy {
        /// The folder.
        dir: PathBuf,
    },
    /// Another process is writing the file ([`OutputFile::create_exclusive`](super::OutputFile::create_exclusive)).
    #[error(
        "{}: another skin command is writing this file; wait for it to finish or choose another name",
        path.display()
    )]
    FileBusy {
        /// The file.
        path: PathBuf,
    },
    /// The output folder was deleted, moved or replaced while the command wrote it.
    #[error(
        "{}: the output folder was moved or deleted while skin wrote it; nothing was put there: run again",
        dir.display()
    )]
    Vanished {
        /// The folder.
        dir: PathBuf,
    },
    /// A folder or a link stands where the command writes a file.
    #[error(
        "{}: is a folder or a link, where {command} writes a file; move it away or choose another output folder",
        path.display()
    )]
    Blocked {
        /// The path in the output folder.
        path: PathBuf,
        /// The command.
        command: String,
    },
    /// A chain of symbolic links that does not end.
    #[error("{}: too many levels of symbolic links", path.display())]
    LinkLoop {
        /// The path given.
        path: PathBuf,
    },
    /// An existing file that is not of the kind being written (a user's file, not an earlier
    /// output): replacing it would lose it.
    #[error(
        "{}: exists and is not {kind}; skin replaces only a file of the kind it writes there: move it or choose another name",
        path.display()
    )]
    Foreign {
        /// The file.
        path: PathBuf,
        /// What is written there, e.g. "a tactile map".
        kind: String,
    },
    /// Two inputs whose outputs would have the same name ([`output_names`](super::output_names)).
    #[error(
        "{} and {}: both would be written as {name}; give inputs distinct names (or list each once)",
        first.display(),
        second.display()
    )]
    SameName {
        /// The first input.
        first: PathBuf,
        /// The second.
        second: PathBuf,
        /// The name both would have.
        name: String,
    },
    /// The operating system refused (a full disk, no permission, ...).
    #[error("cannot {action} {}: {source}", path.display())]
    Io {
        /// What was being done.
        action: Action,
        /// The path the user gave (never a temporary name).
        path: PathBuf,
        /// What the operating system said.
        source: std::io::Error,
    },
}

/// What the operating system was asked to do when it refused ([`OutputError::Io`]): read in the
/// message as "cannot ACTION PATH".
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Action {
    /// Write a file.
    Write,
    /// Create a folder.
    Create,
    /// Create the folder a file goes in.
    CreateFolderOf,
    /// Read a file or a folder's listing.
    Read,
    /// Read where a symbolic link points.
    ReadLink,
    /// Lock an output folder.
    Lock,
    /// Write into an output folder (its lock, staging folder or records).
    WriteInto,
}

impl Action {
    /// The words of the message: "write", "create the folder of", ...
    pub fn as_str(self) -> &'static str {
        match self {
            Action::Write => "write",
            Action::Create => "create",
            Action::CreateFolderOf => "create the folder of",
            Action::Read => "read",
            Action::ReadLink => "read the link",
            Action::Lock => "lock",
            Action::WriteInto => "write into",
        }
    }
}

impl fmt::Display for Action {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Whose the files are that keep a command out of a folder ([`OutputError::NotOurs`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Whose {
    /// No manifest names them: files that skin did not write.
    NotSkins,
    /// The folder is the output of another command (its name, e.g. "skin image").
    Command(String),
}

impl fmt::Display for Whose {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Whose::NotSkins => f.write_str("files that skin did not write"),
            Whose::Command(command) => write!(f, "the output of `{command}`"),
        }
    }
}

fn same_as(output: &Path, input: &Path) -> String {
    if output == input {
        "also an input".to_owned()
    } else {
        format!("the input {} (the same file)", input.display())
    }
}

fn listing(files: &[String]) -> String {
    let shown: Vec<&str> = files.iter().take(3).map(String::as_str).collect();
    match files.len() {
        n if n > 3 => format!("{} and {} more", shown.join(", "), n - 3),
        _ => shown.join(", "),
    }
}

/// The [`OutputError::Io`] of `action` on `path` (the path the user gave), for `map_err`.
pub(super) fn io(action: Action, path: &Path) -> impl FnOnce(std::io::Error) -> OutputError + '_ {
    move |source| OutputError::Io {
        action,
        path: path.to_owned(),
        source,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_typed_kinds_read_as_the_words_of_the_messages() {
        let e = OutputError::Io {
            action: Action::CreateFolderOf,
            path: PathBuf::from("out/map.json"),
            source: std::io::ErrorKind::PermissionDenied.into(),
        };
        assert!(
            e.to_string()
                .starts_with("cannot create the folder of out/map.json: "),
            "{e}"
        );
        let words: Vec<&str> = [
            Action::Write,
            Action::Create,
            Action::CreateFolderOf,
            Action::Read,
            Action::ReadLink,
            Action::Lock,
            Action::WriteInto,
        ]
        .iter()
        .map(|a| a.as_str())
        .collect();
        let expected = [
            "write",
            "create",
            "create the folder of",
            "read",
            "read the link",
            "lock",
            "write into",
        ];
        assert_eq!(words, expected);
        let not_ours = |whose| OutputError::NotOurs {
            dir: PathBuf::from("out"),
            whose,
            files: vec!["a.png".into()],
            command: "skin run".into(),
        };
        let e = not_ours(Whose::Command("skin image".into()));
        assert!(
            e.to_string()
                .starts_with("out: holds the output of `skin image` (a.png); "),
            "{e}"
        );
        let e = not_ours(Whose::NotSkins);
        assert!(
            e.to_string()
                .starts_with("out: holds files that skin did not write (a.png); "),
            "{e}"
        );
    }
}
