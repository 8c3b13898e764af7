//! The raw layer under manifest parsing: typed access to the keys of one
//! TOML table that remembers which keys were read, so every key left over
//! becomes a warning (the contract ignores unknown keys, never rejects
//! them), and that builds errors naming the file, the key path and what was
//! expected.
//!
//! Key paths read like `position "p1".capture "flash0".lights`: array
//! elements are named by their `name` where they have a usable one, else by
//! index (`position[1]`).

use crate::error::ScanError;
use std::collections::BTreeSet;
use std::path::Path;
use toml::{Table, Value};

/// One table being read.
pub(super) struct Fields<'a> {
    path: &'a Path,
    table: &'a Table,
    key: String,
    read: BTreeSet<&'a str>,
}

impl<'a> Fields<'a> {
    pub fn new(path: &'a Path, table: &'a Table, key: String) -> Self {
        Self {
            path,
            table,
            key,
            read: BTreeSet::new(),
        }
    }

    /// The key path of `name` inside this table.
    pub fn key_of(&self, name: &str) -> String {
        if self.key.is_empty() {
            name.to_string()
        } else {
            format!("{}.{name}", self.key)
        }
    }

    pub fn error(&self, name: &str, expected: impl Into<String>) -> ScanError {
        ScanError::Invalid {
            path: self.path.to_path_buf(),
            key: self.key_of(name),
            expected: expected.into(),
        }
    }

    /// Looks `name` up and marks it as understood.
    pub fn get(&mut self, name: &'a str) -> Option<&'a Value> {
        self.read.insert(name);
        self.table.get(name)
    }

    /// Warns about every key nobody read.
    pub fn finish(self, warnings: &mut Vec<String>) {
        for name in self.table.keys() {
            if !self.read.contains(name.as_str()) {
                warnings.push(format!(
                    "{}: key `{}` is not part of {}; ignored",
                    self.path.display(),
                    self.key_of(name),
                    super::FORMAT
                ));
            }
        }
    }

    pub fn required(&mut self, name: &'a str, expected: &str) -> Result<&'a Value, ScanError> {
        self.get(name)
            .ok_or_else(|| self.error(name, format!("missing; expected {expected}")))
    }

    pub fn string(&mut self, name: &'a str) -> Result<String, ScanError> {
        let v = self.required(name, "a string")?;
        self.as_string(name, v)
    }

    pub fn opt_string(&mut self, name: &'a str) -> Result<Option<String>, ScanError> {
        self.get(name).map(|v| self.as_string(name, v)).transpose()
    }

    fn as_string(&self, name: &str, v: &Value) -> Result<String, ScanError> {
        match v {
            Value::String(s) => Ok(s.clone()),
            other => Err(self.error(
                name,
                format!("expected a string, found {}", describe(other)),
            )),
        }
    }

    /// A finite number; TOML integers count as numbers.
    pub fn number(&mut self, name: &'a str) -> Result<f64, ScanError> {
        let v = self.required(name, "a number")?;
        number(v)
            .map_err(|found| self.error(name, format!("expected a finite number, found {found}")))
    }

    pub fn opt_number(&mut self, name: &'a str) -> Result<Option<f64>, ScanError> {
        match self.get(name) {
            None => Ok(None),
            Some(v) => number(v).map(Some).map_err(|found| {
                self.error(name, format!("expected a finite number, found {found}"))
            }),
        }
    }

    /// A number `> 0`.
    pub fn positive(&mut self, name: &'a str, unit: &str) -> Result<f64, ScanError> {
        let x = self.number(name)?;
        if x > 0.0 {
            Ok(x)
        } else {
            Err(self.error(name, format!("expected a positive number{unit}, found {x}")))
        }
    }

    /// A number in `[0, 1]`, or `default` when absent.
    pub fn unit_interval(&mut self, name: &'a str, default: Option<f64>) -> Result<f64, ScanError> {
        let x = match (self.opt_number(name)?, default) {
            (Some(x), _) => x,
            (None, Some(d)) => return Ok(d),
            (None, None) => return Err(self.error(name, "missing; expected a number from 0 to 1")),
        };
        if (0.0..=1.0).contains(&x) {
            Ok(x)
        } else {
            Err(self.error(name, format!("expected a number from 0 to 1, found {x}")))
        }
    }

    /// A positive integer that fits a pixel count.
    pub fn pixels(&mut self, name: &'a str) -> Result<u32, ScanError> {
        let v = self.required(name, "a positive integer (pixels)")?;
        match v {
            Value::Integer(i) if *i > 0 && *i <= i64::from(u32::MAX) => Ok(*i as u32),
            other => Err(self.error(
                name,
                format!(
                    "expected a positive integer (pixels), found {}",
                    describe(other)
                ),
            )),
        }
    }

    /// Exactly `N` finite numbers.
    pub fn numbers<const N: usize>(&mut self, name: &'a str) -> Result<[f64; N], ScanError> {
        let v = self.required(name, &format!("{N} numbers"))?;
        self.as_numbers(name, v)
    }

    pub fn opt_numbers<const N: usize>(
        &mut self,
        name: &'a str,
    ) -> Result<Option<[f64; N]>, ScanError> {
        self.get(name).map(|v| self.as_numbers(name, v)).transpose()
    }

    fn as_numbers<const N: usize>(&self, name: &str, v: &Value) -> Result<[f64; N], ScanError> {
        let Value::Array(items) = v else {
            return Err(self.error(name, format!("expected {N} numbers, found {}", describe(v))));
        };
        if items.len() != N {
            return Err(self.error(name, format!("expected {N} numbers, found {}", items.len())));
        }
        let mut out = [0.0; N];
        for (i, (slot, item)) in out.iter_mut().zip(items).enumerate() {
            *slot = number(item).map_err(|found| {
                self.error(
                    name,
                    format!("expected {N} finite numbers, item {i} is {found}"),
                )
            })?;
        }
        Ok(out)
    }

    /// A list of strings.
    pub fn strings(&mut self, name: &'a str, expected: &str) -> Result<Vec<String>, ScanError> {
        let v = self.required(name, expected)?;
        let Value::Array(items) = v else {
            return Err(self.error(name, format!("expected {expected}, found {}", describe(v))));
        };
        items
            .iter()
            .enumerate()
            .map(|(i, item)| match item {
                Value::String(s) => Ok(s.clone()),
                other => Err(self.error(
                    name,
                    format!("expected {expected}, item {i} is {}", describe(other)),
                )),
            })
            .collect()
    }

    /// An optional sub-table (`[a.b]` or an inline `{ ... }`).
    pub fn opt_table(&mut self, name: &'a str) -> Result<Option<Fields<'a>>, ScanError> {
        match self.get(name) {
            None => Ok(None),
            Some(Value::Table(t)) => Ok(Some(Fields::new(self.path, t, self.key_of(name)))),
            Some(other) => {
                Err(self.error(name, format!("expected a table, found {}", describe(other))))
            }
        }
    }

    pub fn table(&mut self, name: &'a str) -> Result<Fields<'a>, ScanError> {
        self.opt_table(name)?
            .ok_or_else(|| self.error(name, format!("missing; expected a table [{name}]")))
    }

    /// An optional array of tables (`[[a.b]]`), each element keyed by its
    /// `name` where that is a string, else by index.
    pub fn array_of_tables(&mut self, name: &'a str) -> Result<Vec<Fields<'a>>, ScanError> {
        let path = self.path;
        let items = match self.get(name) {
            None => return Ok(Vec::new()),
            Some(Value::Array(items)) => items,
            Some(other) => {
                return Err(self.error(
                    name,
                    format!(
                        "expected an array of tables ([[{name}]]), found {}",
                        describe(other)
                    ),
                ))
            }
        };
        items
            .iter()
            .enumerate()
            .map(|(i, item)| match item {
                Value::Table(t) => {
                    let element = match t.get("name") {
                        Some(Value::String(n)) => format!("{name} {n:?}"),
                        _ => format!("{name}[{i}]"),
                    };
                    let key = if self.key.is_empty() {
                        element
                    } else {
                        format!("{}.{element}", self.key)
                    };
                    Ok(Fields::new(path, t, key))
                }
                other => Err(self.error(
                    name,
                    format!(
                        "expected an array of tables ([[{name}]]), item {i} is {}",
                        describe(other)
                    ),
                )),
            })
            .collect()
    }
}

/// A finite number, or a description of what was found instead.
fn number(v: &Value) -> Result<f64, String> {
    match v {
        Value::Integer(i) => Ok(*i as f64),
        Value::Float(f) if f.is_finite() => Ok(*f),
        other => Err(describe(other)),
    }
}

/// What a value is, for error messages.
pub(super) fn describe(v: &Value) -> String {
    match v {
        Value::String(s) => format!("the string {s:?}"),
        Value::Integer(i) => format!("{i}"),
        Value::Float(f) => format!("{f}"),
        Value::Boolean(b) => format!("the boolean {b}"),
        Value::Datetime(d) => format!("the datetime {d}"),
        Value::Array(a) => format!("an array of {} items", a.len()),
        Value::Table(_) => "a table".to_string(),
    }
}
