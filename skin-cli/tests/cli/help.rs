//! `skin --help` and `skin help CMD`: one line a command, units and formats explained.

use super::*;

/// `skin --help` gives one line per command at clap's default width (100 columns); the details
/// are in `skin help CMD`.
#[test]
fn help_lists_each_command_on_one_line() {
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_skin"))
        .arg("--help")
        .env_remove("COLUMNS")
        .output()
        .unwrap();
    let out = String::from_utf8(o.stdout).unwrap();
    let commands: Vec<&str> = out
        .split("Commands:\n")
        .nth(1)
        .and_then(|rest| rest.split("\n\n").next())
        .unwrap_or_default()
        .lines()
        .collect();
    assert!(commands.len() >= 10, "{out}");
    for line in &commands {
        let name = line.split_whitespace().next().unwrap_or_default();
        assert!(
            line.starts_with("  ")
                && !line.starts_with("   ")
                && name.chars().all(|c| c.is_ascii_lowercase() || c == '-'),
            "a summary broken over lines: {line:?}\n{out}"
        );
    }
    let (long, _) = text(&skin(&["help", "replay"]));
    assert!(long.contains("--window-ms") && long.contains("sync"), "{long}");
}

#[test]
fn help_explains_units_and_formats() {
    let (out, _) = text(&skin(&["flatten", "--help"]));
    assert!(
        out.contains("metres") && out.contains("iCub") && out.contains("Cyskin"),
        "{out}"
    );
    let (out, _) = text(&skin(&["image", "--help"]));
    assert!(out.contains("millimetres") && out.contains("68x100"), "{out}");
}
