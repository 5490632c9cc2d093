//! Runnable examples of the `skin` crates: see the `examples/` folder of this package.
