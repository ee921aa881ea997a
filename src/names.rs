//! The one way the crate spells a choice as text: `name` or `name:parameter[:parameter]`
//! (`lumped`, `blended:0.5`, `series:8`, `cg:1e-10`, `gimp:0.25`, `xpic:3`). Every choice type
//! (mass scheme, transfer, update scheme, shape function, stabilisation, singularity policy)
//! implements `Display` and `FromStr` in it, and its serde form is that text; the command line,
//! `mpm bench`, report labels, scene files, checkpoints and the Python package all read and
//! write the same words. Scene files may also write a parameterised choice as a TOML table,
//! `{ blended = { gamma = 0.5 } }`.
//!
//! `{}` prints parameters exactly, so that the text reads back to the same value; `{:#}` prints
//! them for people, with six significant digits (`blended:0.722222` for a 13/18 blend), as
//! reports and labels do.

use std::fmt;
use std::marker::PhantomData;
use std::str::FromStr;

use serde::de::{self, MapAccess, Visitor};
use serde::{Deserialize, Deserializer};

use crate::numbers::{exact, human};

/// A choice as text: its name and its parameters.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Spelled<'a> {
    /// The whole text, for messages.
    pub(crate) text: &'a str,
    /// The name (before the first `:`).
    pub(crate) name: &'a str,
    params: [Option<&'a str>; 3],
}

impl<'a> Spelled<'a> {
    /// `text` cut into its name and up to three parameters (`name:p:q:r`, or the older
    /// `name(p, q)`); more than three parameters are an error naming the text.
    pub(crate) fn parse(text: &'a str) -> Result<Spelled<'a>, String> {
        let text = text.trim();
        let (name, rest) = match (text.split_once(':'), text.split_once('(')) {
            (Some((name, rest)), _) => (name, Some((rest, ':'))),
            (None, Some((name, rest))) => (name, Some((rest.trim_end().trim_end_matches(')'), ','))),
            (None, None) => (text, None),
        };
        let mut params = [None, None, None];
        if let Some((rest, separator)) = rest {
            let mut parts = rest.split(separator).map(str::trim);
            for slot in params.iter_mut() {
                *slot = parts.next();
            }
            if parts.next().is_some() {
                return Err(format!("`{text}`: too many parameters"));
            }
        }
        Ok(Spelled {
            text,
            name: name.trim(),
            params,
        })
    }

    /// Parameter `i` parsed as `T`, or `default` when it is absent (`None`: required).
    pub(crate) fn param<T: FromStr>(&self, i: usize, default: Option<T>) -> Result<T, String> {
        match (self.params[i].filter(|p| !p.is_empty()), default) {
            (Some(p), _) => p
                .parse()
                .map_err(|_| format!("`{}`: `{p}` is not a valid parameter", self.text)),
            (None, Some(d)) => Ok(d),
            (None, None) => Err(format!("`{}` needs a parameter (`{}:value`)", self.text, self.name)),
        }
    }

    /// An error unless no parameter is given.
    pub(crate) fn no_params(&self) -> Result<(), String> {
        match self.params[0] {
            None => Ok(()),
            Some(_) => Err(format!("`{}` takes no parameter", self.text)),
        }
    }
}

/// A parameter of a choice.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Param {
    /// A number (a weight, a tolerance).
    Real(f64),
    /// A count (terms, iterations).
    Count(usize),
}

/// Writes `name` and its real parameters `params` (`name:p:q`): [`write_params`].
pub(crate) fn write(f: &mut fmt::Formatter<'_>, name: &str, params: &[f64]) -> fmt::Result {
    let params: Vec<Param> = params.iter().map(|&p| Param::Real(p)).collect();
    write_params(f, name, &params)
}

/// Writes `name` and the parameters `params` (`name:p:q`): numbers with [`exact`], or with
/// [`human`] under the alternate flag (`{:#}`), counts as integers. The text is padded to the
/// formatter's width (`{:<14}`).
pub(crate) fn write_params(f: &mut fmt::Formatter<'_>, name: &str, params: &[Param]) -> fmt::Result {
    let mut text = name.to_string();
    for &p in params {
        text.push(':');
        text.push_str(&match p {
            Param::Real(v) if f.alternate() => human(v),
            Param::Real(v) => exact(v),
            Param::Count(k) => k.to_string(),
        });
    }
    f.pad(&text)
}

/// A choice type's two spellings: its text (`Display`, `FromStr`) and, in scene files, its
/// table form `{ name = { parameter = value, … } }`, read into the text by the parameters'
/// names: the one list of what each choice takes.
pub(crate) trait Choice: FromStr<Err = String> + fmt::Display {
    /// What a message says is expected (`a mass scheme (lumped, consistent, …)`).
    const EXPECTING: &'static str;
    /// The names that take parameters (aliases included), each with its parameters' table keys
    /// in the order of the text.
    const PARAMETERS: &'static [(&'static str, &'static [&'static str])];
}

/// `Serialize` as the text and `Deserialize` from the text or the table form, for a
/// [`Choice`].
macro_rules! choice_serde {
    ($t:ty) => {
        impl serde::Serialize for $t {
            fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
                s.collect_str(self)
            }
        }

        impl<'de> serde::Deserialize<'de> for $t {
            fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<$t, D::Error> {
                $crate::names::deserialize(d)
            }
        }
    };
}
pub(crate) use choice_serde;

/// Deserializes a choice from its text (`FromStr`) or, in self-describing formats such as
/// TOML, from its table form.
pub(crate) fn deserialize<'de, D: Deserializer<'de>, T: Choice>(d: D) -> Result<T, D::Error> {
    let visitor = ChoiceVisitor::<T>(PhantomData);
    if d.is_human_readable() {
        d.deserialize_any(visitor)
    } else {
        d.deserialize_str(visitor)
    }
}

struct ChoiceVisitor<T>(PhantomData<T>);

/// A parameter's value in a table form.
#[derive(Deserialize)]
#[serde(untagged)]
enum Value {
    Count(u64),
    Real(f64),
}

impl<'de, T: Choice> Visitor<'de> for ChoiceVisitor<T> {
    type Value = T;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(T::EXPECTING)
    }

    fn visit_str<E: de::Error>(self, v: &str) -> Result<T, E> {
        v.parse().map_err(E::custom)
    }

    /// `{ name = { parameter = value, … } }` as the text `name:value:…`, each parameter in its
    /// place (an absent one empty, so that it takes its default).
    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<T, A::Error> {
        let Some((name, table)) = map.next_entry::<String, std::collections::BTreeMap<String, Value>>()? else {
            return Err(de::Error::custom(format!("an empty table: expected {}", T::EXPECTING)));
        };
        if let Some(other) = map.next_key::<String>()? {
            return Err(de::Error::custom(format!(
                "one choice per table: `{name}` and `{other}` are given"
            )));
        }
        let keys = T::PARAMETERS
            .iter()
            .find(|(n, _)| *n == name)
            .map_or(&[][..], |(_, k)| k);
        if let Some(unknown) = table.keys().find(|k| !keys.contains(&k.as_str())) {
            // A name the choice does not have is named before its keys.
            if let Err(e) = name.parse::<T>() {
                if keys.is_empty() && !e.contains("needs a parameter") {
                    return Err(de::Error::custom(e));
                }
            }
            let takes = if keys.is_empty() {
                "no parameters".to_string()
            } else {
                keys.join(", ")
            };
            return Err(de::Error::custom(format!(
                "unknown key `{unknown}` in the table of `{name}` (it takes {takes})"
            )));
        }
        let mut text = name.clone();
        let given = keys.iter().rposition(|k| table.contains_key(*k)).map_or(0, |i| i + 1);
        let mut values = Vec::new();
        for key in &keys[..given] {
            let value = match table.get(*key) {
                Some(Value::Count(k)) => k.to_string(),
                Some(Value::Real(v)) => exact(*v),
                None => String::new(),
            };
            text.push(':');
            text.push_str(&value);
            values.push((key, value));
        }
        text.parse().map_err(|e: String| {
            // The message names the key whose value the text refused, or the keys it takes.
            let culprit = values
                .iter()
                .find(|(_, v)| !v.is_empty() && e.contains(&format!("`{v}` is not")));
            de::Error::custom(match culprit {
                Some((key, value)) => format!("`{name}.{key}` = {value}: {e}"),
                None if keys.is_empty() => e,
                None => format!("{e} (the table of `{name}` takes {})", keys.join(", ")),
            })
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_and_parameters_are_cut_at_colons_or_in_parentheses() {
        let s = Spelled::parse(" cg:1e-8:200 ").unwrap();
        assert_eq!(s.name, "cg");
        assert_eq!(s.param::<f64>(0, None).unwrap(), 1e-8);
        assert_eq!(s.param::<usize>(1, Some(500)).unwrap(), 200);
        let s = Spelled::parse("series(3)").unwrap();
        assert_eq!((s.name, s.param::<usize>(0, None).unwrap()), ("series", 3));
        assert!(Spelled::parse("blended").unwrap().param::<f64>(0, None).is_err());
        assert!(Spelled::parse("a:1:2:3:4").is_err());
        assert!(Spelled::parse("lumped:1").unwrap().no_params().is_err());
    }
}
