//! Runnable examples of the `skin` crates: see the `examples/` folder of this package.

/// The README's Rust snippets, compiled as doctests so that they stay true.
#[cfg(doctest)]
#[doc = include_str!("../../README.md")]
pub struct ReadmeExamples;
