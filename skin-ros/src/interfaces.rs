//! ROS 2 message definitions (`.msg` text), read by the code: the standard types the skin
//! publishes (`msg/standard.msg`) and the repository's own `skin_msgs` package. From them come
//! the `ros2msg` schemas an MCAP file carries ([`Interfaces::schema`]) and the RIHS01 type
//! hashes rmw_zenoh matches on ([`Interfaces::type_hash`], computed in `type_hash.rs`).
//!
//! A service (`.srv`: the request's fields, a line `---`, the response's) becomes the four types
//! rosidl makes of it, which its type hash covers: `pkg/srv/Name_Request`, `pkg/srv/Name_Response`,
//! `pkg/srv/Name_Event` (a `service_msgs/ServiceEventInfo` and at most one of each) and
//! `pkg/srv/Name` holding the three.
//!
//! The `.msg` grammar read here: one field a line, `TYPE NAME [DEFAULT]`, or a constant
//! `TYPE NAME=VALUE`; `#` starts a comment (outside a string constant); TYPE is a primitive
//! (`bool byte char int8..uint64 float32 float64 string wstring`, a string bounded as
//! `string<=N`), or a message `pkg/Name` (or `Name` for one of the same package), each
//! optionally an array: `T[N]`, `T[<=N]` or `T[]`.

use std::collections::BTreeMap;

/// The standard types, as `MSG: pkg/Name` blocks.
const STANDARD: &str = include_str!("../msg/standard.msg");

/// The repository's `skin_msgs` package (its `.msg` files, which colcon builds).
const SKIN_MSGS: [(&str, &str); 9] = [
    ("Contact", include_str!("../../skin_msgs/msg/Contact.msg")),
    ("Contacts", include_str!("../../skin_msgs/msg/Contacts.msg")),
    ("Footprint", include_str!("../../skin_msgs/msg/Footprint.msg")),
    ("HandPart", include_str!("../../skin_msgs/msg/HandPart.msg")),
    (
        "MissingModule",
        include_str!("../../skin_msgs/msg/MissingModule.msg"),
    ),
    ("TouchEvent", include_str!("../../skin_msgs/msg/TouchEvent.msg")),
    ("LinkLayout", include_str!("../../skin_msgs/msg/LinkLayout.msg")),
    (
        "TactileLayout",
        include_str!("../../skin_msgs/msg/TactileLayout.msg"),
    ),
    (
        "TactileState",
        include_str!("../../skin_msgs/msg/TactileState.msg"),
    ),
];

/// The services of `skin_msgs` (its `.srv` files).
const SKIN_SRVS: [(&str, &str); 1] = [("Describe", include_str!("../../skin_msgs/srv/Describe.srv"))];

/// A `.msg` that cannot be read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{type_name}: line {line}: {why}")]
pub struct DefinitionError {
    /// The type being read, `pkg/msg/Name`.
    pub type_name: String,
    /// Line in its text (1-based).
    pub line: usize,
    /// What is wrong.
    pub why: String,
}

/// The element type of a field.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum BaseType {
    /// A primitive: `bool`, `int32`, `float64`, `string` ...
    Primitive(String),
    /// `string<=N`.
    BoundedString(u64),
    /// A message type, `pkg/msg/Name`.
    Message(String),
}

/// Whether a field holds one value or several.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Arity {
    /// One value.
    Single,
    /// `T[N]`.
    Array(u64),
    /// `T[<=N]`.
    Bounded(u64),
    /// `T[]`.
    Sequence,
}

/// One field of a message.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Field {
    /// Its name.
    pub name: String,
    /// Its element type.
    pub base: BaseType,
    /// One value or several.
    pub arity: Arity,
}

/// One message type.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Definition {
    /// `pkg/msg/Name`.
    pub name: String,
    /// Its fields, in order.
    pub fields: Vec<Field>,
    /// Its constants, as written (`uint8 APPEARED=2`).
    pub constants: Vec<String>,
}

/// A set of message definitions that refer to each other.
#[derive(Debug, Clone, Default)]
pub struct Interfaces {
    types: BTreeMap<String, Definition>,
}

const PRIMITIVES: [&str; 15] = [
    "bool", "byte", "char", "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64", "uint64",
    "float32", "float64", "string", "wstring",
];

impl Interfaces {
    /// The standard types and `skin_msgs`, checked: every nested type is defined.
    pub fn skin() -> Result<Interfaces, DefinitionError> {
        let mut all = Interfaces::default();
        for (name, text) in split_blocks(STANDARD) {
            if name.contains("/srv/") {
                all.add_service(&name, &text)?;
            } else {
                all.add(&name, &text)?;
            }
        }
        for (name, text) in SKIN_MSGS {
            all.add(&format!("skin_msgs/msg/{name}"), text)?;
        }
        for (name, text) in SKIN_SRVS {
            all.add_service(&format!("skin_msgs/srv/{name}"), text)?;
        }
        all.check()?;
        Ok(all)
    }

    /// Adds the type `pkg/msg/Name` from its `.msg` text.
    pub fn add(&mut self, name: &str, text: &str) -> Result<(), DefinitionError> {
        let def = parse(name, text)?;
        self.types.insert(def.name.clone(), def);
        Ok(())
    }

    /// Adds the service `pkg/srv/Name` from its `.srv` text: its request, response and event
    /// types, and the service type holding the three (whose hash rmw_zenoh puts in a
    /// service's key expression).
    pub fn add_service(&mut self, name: &str, text: &str) -> Result<(), DefinitionError> {
        let mut request = String::new();
        let mut response = None::<String>;
        for line in text.lines() {
            match &mut response {
                None if line.trim() == "---" => response = Some(String::new()),
                None => request.push_str(line),
                Some(r) => r.push_str(line),
            }
            match &mut response {
                Some(r) if line.trim() != "---" => r.push('\n'),
                Some(_) => {}
                None => request.push('\n'),
            }
        }
        let Some(response) = response else {
            return Err(DefinitionError {
                type_name: name.to_owned(),
                line: text.lines().count(),
                why: "a service needs a line \"---\" between its request and its response".into(),
            });
        };
        // Nested types of a service's fields are messages: parse them as the package's msg.
        let as_msg = name.replacen("/srv/", "/msg/", 1);
        let part = |suffix: &str, text: &str| -> Result<Definition, DefinitionError> {
            let mut def = parse(&format!("{as_msg}{suffix}"), text)?;
            def.name = format!("{name}{suffix}");
            Ok(def)
        };
        let single = |field: &str, base: String, arity| Field {
            name: field.to_owned(),
            base: BaseType::Message(base),
            arity,
        };
        let event = Definition {
            name: format!("{name}_Event"),
            fields: vec![
                single("info", "service_msgs/msg/ServiceEventInfo".into(), Arity::Single),
                single("request", format!("{name}_Request"), Arity::Bounded(1)),
                single("response", format!("{name}_Response"), Arity::Bounded(1)),
            ],
            constants: Vec::new(),
        };
        let service = Definition {
            name: name.to_owned(),
            fields: vec![
                single("request_message", format!("{name}_Request"), Arity::Single),
                single("response_message", format!("{name}_Response"), Arity::Single),
                single("event_message", format!("{name}_Event"), Arity::Single),
            ],
            constants: Vec::new(),
        };
        for def in [
            part("_Request", &request)?,
            part("_Response", &response)?,
            event,
            service,
        ] {
            self.types.insert(def.name.clone(), def);
        }
        Ok(())
    }

    /// Every nested type is defined.
    pub fn check(&self) -> Result<(), DefinitionError> {
        for def in self.types.values() {
            for f in &def.fields {
                if let BaseType::Message(n) = &f.base
                    && !self.types.contains_key(n)
                {
                    return Err(DefinitionError {
                        type_name: def.name.clone(),
                        line: 0,
                        why: format!("field {} has type {n}, which is not defined", f.name),
                    });
                }
            }
        }
        Ok(())
    }

    /// Every type's name, `pkg/msg/Name`, sorted.
    pub fn names(&self) -> impl Iterator<Item = &str> {
        self.types.keys().map(String::as_str)
    }

    /// The definition of `name` (`pkg/msg/Name`).
    pub fn get(&self, name: &str) -> Option<&Definition> {
        self.types.get(name)
    }

    /// The types `name` nests, directly or not, in the order a depth-first walk first meets
    /// them (the order of a `ros2msg` schema).
    pub fn nested(&self, name: &str) -> Vec<&Definition> {
        let mut seen = Vec::new();
        self.visit(name, name, &mut seen);
        seen
    }

    fn visit<'a>(&'a self, name: &str, top: &str, seen: &mut Vec<&'a Definition>) {
        let Some(def) = self.types.get(name) else {
            return;
        };
        for f in &def.fields {
            if let BaseType::Message(n) = &f.base
                && n != top
                && !seen.iter().any(|d| &d.name == n)
                && let Some(d) = self.types.get(n)
            {
                seen.push(d);
                self.visit(n, top, seen);
            }
        }
    }

    /// The `ros2msg` schema of `name` as MCAP's ros2 profile and rosbag2 write it: the type's
    /// own text, then each nested type after a line of 80 `=` and a `MSG: pkg/Name` line.
    pub fn schema(&self, name: &str) -> Option<String> {
        let def = self.types.get(name)?;
        let mut text = body(def);
        for d in self.nested(name) {
            text.push_str(&"=".repeat(80));
            text.push('\n');
            text.push_str(&format!("MSG: {}\n", short_name(&d.name)));
            text.push_str(&body(d));
        }
        Some(text)
    }
}

/// `pkg/msg/Name` -> `pkg/Name` (how schemas name nested types).
fn short_name(name: &str) -> String {
    name.replacen("/msg/", "/", 1)
}

/// A definition as `.msg` text: constants, then fields (nested types as `pkg/Name`).
fn body(def: &Definition) -> String {
    let mut text = String::new();
    for c in &def.constants {
        text.push_str(c);
        text.push('\n');
    }
    for f in &def.fields {
        let base = match &f.base {
            BaseType::Primitive(p) => p.clone(),
            BaseType::BoundedString(n) => format!("string<={n}"),
            BaseType::Message(m) => short_name(m),
        };
        let arity = match f.arity {
            Arity::Single => String::new(),
            Arity::Array(n) => format!("[{n}]"),
            Arity::Bounded(n) => format!("[<={n}]"),
            Arity::Sequence => "[]".into(),
        };
        text.push_str(&format!("{base}{arity} {}\n", f.name));
    }
    text
}

/// `MSG: pkg/Name` and `SRV: pkg/Name` blocks (the line starting with `MSG: ` or `SRV: `) ->
/// (`pkg/msg/Name` or `pkg/srv/Name`, text).
fn split_blocks(all: &str) -> Vec<(String, String)> {
    let mut out: Vec<(String, String)> = Vec::new();
    for line in all.lines() {
        let head = line
            .strip_prefix("MSG: ")
            .map(|h| (h, "msg"))
            .or_else(|| line.strip_prefix("SRV: ").map(|h| (h, "srv")));
        if let Some((head, kind)) = head {
            let name = match head.trim().split_once('/') {
                Some((pkg, n)) => format!("{pkg}/{kind}/{n}"),
                None => head.trim().to_owned(),
            };
            out.push((name, String::new()));
        } else if let Some((_, text)) = out.last_mut() {
            text.push_str(line);
            text.push('\n');
        }
    }
    out
}

fn parse(name: &str, text: &str) -> Result<Definition, DefinitionError> {
    let package = name.split('/').next().unwrap_or_default();
    let mut def = Definition {
        name: name.to_owned(),
        fields: Vec::new(),
        constants: Vec::new(),
    };
    for (k, raw) in text.lines().enumerate() {
        let err = |why: String| DefinitionError {
            type_name: name.to_owned(),
            line: k + 1,
            why,
        };
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let (ty, rest) = line
            .split_once(char::is_whitespace)
            .ok_or_else(|| err(format!("\"{line}\" is a type without a name")))?;
        let rest = rest.trim_start();
        // A constant: NAME=VALUE (a string constant keeps its '#').
        if let Some((cname, value)) = rest.split_once('=')
            && !cname.trim().contains(char::is_whitespace)
        {
            let value = if ty == "string" {
                value.trim()
            } else {
                value.split('#').next().unwrap_or_default().trim()
            };
            def.constants.push(format!("{ty} {}={value}", cname.trim()));
            continue;
        }
        let rest = rest.split('#').next().unwrap_or_default();
        let field_name = rest
            .split_whitespace()
            .next()
            .ok_or_else(|| err(format!("\"{line}\" has no field name")))?;
        if !field_name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
            || !field_name.starts_with(|c: char| c.is_ascii_lowercase())
        {
            return Err(err(format!(
                "field name \"{field_name}\": lower case letters, digits and '_', starting with a letter"
            )));
        }
        let (base, arity) = field_type(ty, package).map_err(err)?;
        def.fields.push(Field {
            name: field_name.to_owned(),
            base,
            arity,
        });
    }
    Ok(def)
}

/// A field's type `ty` (`T`, `T[N]`, `T[<=N]`, `T[]`; `T` a primitive, `string<=N` or a message
/// name, relative to `package` when it has no package), or why it is not one.
fn field_type(ty: &str, package: &str) -> Result<(BaseType, Arity), String> {
    let (base_text, arity) = match ty.split_once('[') {
        None => (ty, Arity::Single),
        Some((b, a)) => {
            let a = a
                .strip_suffix(']')
                .ok_or_else(|| format!("type \"{ty}\": an array needs its ']'"))?;
            let number = |s: &str| {
                s.parse::<u64>()
                    .map_err(|_| format!("type \"{ty}\": \"{s}\" is not a size"))
            };
            let arity = if a.is_empty() {
                Arity::Sequence
            } else if let Some(n) = a.strip_prefix("<=") {
                Arity::Bounded(number(n)?)
            } else {
                Arity::Array(number(a)?)
            };
            (b, arity)
        }
    };
    let base = if let Some(n) = base_text.strip_prefix("string<=") {
        BaseType::BoundedString(
            n.parse()
                .map_err(|_| format!("type \"{ty}\": \"{n}\" is not a size"))?,
        )
    } else if PRIMITIVES.contains(&base_text) {
        BaseType::Primitive(base_text.to_owned())
    } else {
        let full = match base_text.split('/').collect::<Vec<_>>()[..] {
            [n] => format!("{package}/msg/{n}"),
            [p, n] => format!("{p}/msg/{n}"),
            [p, "msg", n] => format!("{p}/msg/{n}"),
            _ => return Err(format!("type \"{ty}\" is not a message name")),
        };
        BaseType::Message(full)
    };
    Ok((base, arity))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_definition_reads_and_nests_only_defined_types() -> Result<(), DefinitionError> {
        let all = Interfaces::skin()?;
        for name in [
            "sensor_msgs/msg/PointCloud2",
            "sensor_msgs/msg/Image",
            "visualization_msgs/msg/MarkerArray",
            "skin_msgs/msg/Contacts",
            "skin_msgs/msg/TouchEvent",
        ] {
            assert!(all.get(name).is_some(), "{name}");
        }
        let event = all.get("skin_msgs/msg/TouchEvent").map(|d| d.fields.len());
        assert_eq!(event, Some(17));
        Ok(())
    }

    #[test]
    fn schema_lists_nested_types_depth_first_once() -> Result<(), DefinitionError> {
        let all = Interfaces::skin()?;
        let text = all.schema("sensor_msgs/msg/PointCloud2").unwrap_or_default();
        let nested: Vec<&str> = text.lines().filter_map(|l| l.strip_prefix("MSG: ")).collect();
        assert_eq!(
            nested,
            [
                "std_msgs/Header",
                "builtin_interfaces/Time",
                "sensor_msgs/PointField"
            ]
        );
        assert!(text.starts_with("std_msgs/Header header\nuint32 height\n"));
        assert!(text.contains("uint8 FLOAT32=7\n"));
        Ok(())
    }

    #[test]
    fn bad_lines_are_named() {
        let e = parse("p/msg/T", "int32 x\nint32[ y\n").err();
        assert_eq!(e.map(|e| e.line), Some(2));
        let e = parse("p/msg/T", "float64 X\n").err();
        assert!(e.is_some_and(|e| e.why.contains("field name")));
        let mut all = Interfaces::default();
        assert!(all.add("p/msg/T", "Missing m\n").is_ok());
        assert!(all.check().is_err());
    }
}
