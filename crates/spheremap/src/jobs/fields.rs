//! A request read from its fields — a recipe's table, Python's keywords, JSON — by serde, with
//! an error that names the field at fault, as every entry point spells it.

use crate::base::error::{Error, Result};
use serde::de::DeserializeOwned;
use serde::Serialize;
use serde_json::Value;

/// `T` read from `fields` (a JSON object: a recipe's table, Python's keywords); a value of the
/// wrong type or out of its domain is refused with the field's name (`fov: invalid type:
/// string "x", expected f64`), a key `T` does not know with the keys it takes (its own, those
/// of its flattened parts, and `also`: keys the caller reads itself).
pub fn read<T>(fields: &Value, also: &[&str]) -> Result<T>
where
    T: DeserializeOwned + Serialize + Default,
{
    let e = match serde_path_to_error::deserialize(fields) {
        Ok(t) => return Ok(t),
        Err(e) => e,
    };
    let path = e.path().to_string();
    let msg = e.into_inner().to_string();
    if !path.is_empty() && path != "." {
        return Err(named(&path, msg));
    }
    // A field of a flattened part (the source, the output map) loses its path in serde: the
    // field at fault is the one that is refused alone (every request has defaults).
    if let Value::Object(map) = fields {
        for (k, v) in map {
            let one = Value::Object([(k.clone(), v.clone())].into_iter().collect());
            let Err(e) = T::deserialize(&one) else {
                continue;
            };
            let m = e.to_string();
            if !m.starts_with("unknown field") {
                return Err(named(k, m));
            }
            // serde's own list leaves out the keys of a flattened part.
            let mut keys: Vec<String> = match serde_json::to_value(T::default()) {
                Ok(Value::Object(o)) => o.keys().cloned().collect(),
                _ => Vec::new(),
            };
            keys.extend(also.iter().map(|k| k.to_string()));
            return Err(Error::param(
                k,
                format!("unknown field `{k}`; expected one of: {}", keys.join(", ")),
            ));
        }
    }
    Err(Error::param("request", msg))
}

/// `msg` about the field `name`; a name's own error already names its argument ("filter:
/// unknown filter ...").
fn named(name: &str, msg: String) -> Error {
    match msg.split_once(": ") {
        Some((arg, reason)) if !arg.contains(' ') && !arg.contains('`') => {
            Error::param(arg, reason)
        }
        _ => Error::param(name, msg),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::jobs::irradiance::IrradianceRequest;

    fn json<T: DeserializeOwned + Serialize + Default>(s: &str) -> Result<T> {
        read(&serde_json::from_str(s).unwrap(), &[])
    }

    #[test]
    fn errors_name_the_field_flattened_ones_too() {
        let e = json::<IrradianceRequest>(r#"{"size": "x"}"#).unwrap_err();
        assert!(e.to_string().starts_with("size: invalid type"), "{e}");
        // `src` lives in the flattened `Source`.
        let e = json::<IrradianceRequest>(r#"{"src": 3}"#).unwrap_err();
        assert!(e.to_string().starts_with("src: invalid type"), "{e}");
        let e = json::<IrradianceRequest>(r#"{"nonfinite": "nope"}"#).unwrap_err();
        assert!(e.to_string().starts_with("nonfinite: unknown"), "{e}");
        let e = json::<IrradianceRequest>(r#"{"nope": 1}"#)
            .unwrap_err()
            .to_string();
        // The keys it takes: its own and its flattened source's.
        assert!(
            e.starts_with("nope: unknown field `nope`; expected one of: "),
            "{e}"
        );
        assert!(e.contains("window") && e.contains("src_preset"), "{e}");
        let r = json::<IrradianceRequest>(r#"{"size": 8}"#).unwrap();
        assert_eq!(r.size, 8);
    }
}
