//! Closed sets of values that files and bindings write by name (a polarity, a gate's action, a
//! normalisation): the names, `Display`, `FromStr` and the error that lists the names there
//! are, written once for every such enum by [`by_name!`](crate::by_name).

/// Gives a fieldless enum its names: `ALL` (every value, in the order given), `name()`,
/// `Display` (the name), `FromStr` (by the name), and an error type `$err` for text that names
/// none of them (the text cut to 40 characters, then `expected $expected`).
///
/// ```
/// #[derive(Debug, Clone, Copy, PartialEq, Eq)]
/// pub enum Side { Left, Right }
/// skin_core::by_name!(Side, UnknownSide, "\"left\" or \"right\"", { Left => "left", Right => "right" });
///
/// assert_eq!("right".parse::<Side>(), Ok(Side::Right));
/// assert_eq!(Side::Left.to_string(), "left");
/// assert_eq!("up".parse::<Side>().unwrap_err().to_string(), r#""up": expected "left" or "right""#);
/// assert_eq!(Side::ALL, [Side::Left, Side::Right]);
/// ```
#[macro_export]
macro_rules! by_name {
    ($ty:ident, $err:ident, $expected:literal, { $($variant:ident => $name:literal),+ $(,)? }) => {
        impl $ty {
            /// Every value, in the order errors list them.
            pub const ALL: [$ty; [$($name),+].len()] = [$($ty::$variant),+];

            /// Its name, as files and bindings write it.
            pub fn name(self) -> &'static str {
                match self {
                    $($ty::$variant => $name),+
                }
            }
        }

        impl ::std::fmt::Display for $ty {
            fn fmt(&self, f: &mut ::std::fmt::Formatter<'_>) -> ::std::fmt::Result {
                f.write_str(self.name())
            }
        }

        #[doc = concat!("Text that names no [`", stringify!($ty), "`]: the text (its first 40 characters); the message says the names there are.")]
        #[derive(Debug, Clone, PartialEq, Eq)]
        pub struct $err(pub String);

        impl ::std::fmt::Display for $err {
            fn fmt(&self, f: &mut ::std::fmt::Formatter<'_>) -> ::std::fmt::Result {
                write!(f, "{:?}: expected {}", self.0, $expected)
            }
        }

        impl ::std::error::Error for $err {}

        #[doc = concat!("A [`", stringify!($ty), "`] by its name, as files and bindings give it.")]
        impl ::std::str::FromStr for $ty {
            type Err = $err;

            fn from_str(s: &str) -> ::std::result::Result<$ty, $err> {
                $ty::ALL
                    .into_iter()
                    .find(|v| v.name() == s)
                    .ok_or_else(|| $err(s.chars().take(40).collect()))
            }
        }
    };
}
