//! Model cards: the Markdown file beside a model (`handsnet.onnx` -> `handsnet.md`) that says
//! what it was trained on and how well it does, with a front matter a program can read:
//!
//! ```text
//! ---
//! input: [N, 1, 68, 100] grey
//! input_scale: unit
//! classes: hand, non_hand
//! ---
//! ```
//!
//! `input_scale` is `unit` (pixels / 255) or `bytes` (0..255). A classifier's card may name its
//! hand class (`hand_class: NAME`, one of `classes`); without it the first class listed is the hand
//! ([`crate::model::Classes::from_card`]).

use std::path::{Path, PathBuf};

/// The machine-readable part of a model card.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ModelCard {
    /// Where the card was read from.
    pub path: PathBuf,
    /// Pixel scaling the model was trained with: `Some(true)` for 0..1, `Some(false)` for
    /// 0..255, `None` if the card does not say.
    pub unit_scale: Option<bool>,
    /// Class names, in output order (empty if the card does not list them).
    pub classes: Vec<String>,
    /// The class that is the hand (`hand_class:`), if the card names it.
    pub hand: Option<String>,
}

impl ModelCard {
    /// The card path of a model: the same name with the extension `md`.
    pub fn path_for(model: &Path) -> PathBuf {
        model.with_extension("md")
    }

    /// Reads the card beside `model`, if there is one.
    pub fn for_model(model: &Path) -> Option<ModelCard> {
        let path = Self::path_for(model);
        // A card as an editor saved it (byte-order mark, CR line ends) reads as any other.
        let text = skin_core::format::read_text(&path).ok()?;
        Some(Self::parse(&text, path))
    }

    /// Parses the front matter of a card's text (everything else is for people).
    pub fn parse(text: &str, path: PathBuf) -> ModelCard {
        let mut card = ModelCard {
            path,
            ..Default::default()
        };
        let mut lines = text.lines();
        if lines.next().map(str::trim) != Some("---") {
            return card;
        }
        for line in lines.take_while(|l| l.trim() != "---") {
            let Some((key, value)) = line.split_once(':') else {
                continue;
            };
            let value = value.trim();
            match key.trim() {
                "input_scale" => {
                    card.unit_scale = match value {
                        "unit" | "1" => Some(true),
                        "bytes" | "255" => Some(false),
                        _ => None,
                    }
                }
                "classes" => {
                    card.classes = value
                        .split(',')
                        .map(|c| c.trim().to_string())
                        .filter(|c| !c.is_empty())
                        .collect()
                }
                "hand_class" => card.hand = Some(value.to_string()).filter(|v| !v.is_empty()),
                _ => {}
            }
        }
        card
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn front_matter_is_read_and_the_rest_ignored() {
        let c = ModelCard::parse(
            "---\nmodel: x\ninput_scale: unit\nclasses: hand, non_hand\n---\n# input_scale: bytes\n",
            "m.md".into(),
        );
        assert_eq!(c.unit_scale, Some(true));
        assert_eq!(c.classes, ["hand", "non_hand"]);
        let c = ModelCard::parse("input_scale: bytes\n", "m.md".into());
        assert_eq!(c.unit_scale, None, "no front matter, nothing read");
        let c = ModelCard::parse("---\ninput_scale: 255\n---\n", "m.md".into());
        assert_eq!(c.unit_scale, Some(false));
    }
}
