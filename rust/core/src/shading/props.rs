//! Reading a node's `props` (Blender's property names and enum spellings) with errors
//! that name the material and node.

use crate::{Error, Result};
use serde_json::{Map, Value};

pub struct Props<'a> {
    pub map: &'a Map<String, Value>,
    pub material: &'a str,
    pub node: &'a str,
}

impl Props<'_> {
    pub fn error(&self, msg: impl std::fmt::Display) -> Error {
        Error::object("material", self.material, format!("node '{}': {msg}", self.node))
    }

    pub fn get(&self, key: &str) -> Option<&Value> {
        self.map.get(key)
    }

    pub fn enumeration<T: Copy>(&self, key: &str, table: &[(&str, T)], default: T) -> Result<T> {
        let Some(v) = self.map.get(key) else { return Ok(default) };
        let s = v.as_str().ok_or_else(|| self.error(format!("property '{key}' must be a string, got {v}")))?;
        table.iter().find(|(name, _)| *name == s).map(|(_, t)| *t).ok_or_else(|| {
            let names: Vec<&str> = table.iter().map(|(n, _)| *n).collect();
            self.error(format!("property '{key}': unknown value '{s}' (expected one of {})", names.join(", ")))
        })
    }

    pub fn boolean(&self, key: &str, default: bool) -> Result<bool> {
        match self.map.get(key) {
            None => Ok(default),
            Some(Value::Bool(b)) => Ok(*b),
            Some(Value::Number(n)) => Ok(n.as_f64() != Some(0.0)),
            Some(v) => Err(self.error(format!("property '{key}' must be a boolean, got {v}"))),
        }
    }

    pub fn string(&self, key: &str) -> Result<Option<&str>> {
        match self.map.get(key) {
            None | Some(Value::Null) => Ok(None),
            Some(Value::String(s)) => Ok(Some(s)),
            Some(v) => Err(self.error(format!("property '{key}' must be a string, got {v}"))),
        }
    }

    pub fn index(&self, key: &str) -> Result<Option<usize>> {
        match self.map.get(key) {
            None | Some(Value::Null) => Ok(None),
            Some(v) => v
                .as_u64()
                .map(|i| Some(i as usize))
                .ok_or_else(|| self.error(format!("property '{key}' must be a non-negative integer, got {v}"))),
        }
    }
}
