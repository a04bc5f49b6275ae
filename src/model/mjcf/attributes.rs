//! Typed reading of an element's attributes as MuJoCo resolves them: the
//! element's own value, else that of the innermost default-class element that
//! sets it. An empty value counts as unset, as in MuJoCo.

use nalgebra::Vector3;

use super::{xml, Node, Result};
use crate::model::constraint::{SOLIMP, SOLREF};
use crate::model::{ModelError, SolParams};

/// One element's attributes with the class elements it inherits from.
#[derive(Clone, Copy)]
pub struct Attrs<'a, 'b> {
    pub file: &'a str,
    /// The class's elements of this kind, outermost first.
    pub defaults: &'b [Node<'a>],
    pub element: Node<'a>,
}

impl<'a, 'b> Attrs<'a, 'b> {
    /// An element that takes no defaults.
    pub fn of(file: &'a str, element: Node<'a>) -> Self {
        Attrs {
            file,
            defaults: &[],
            element,
        }
    }

    /// Class elements then the element itself.
    pub fn nodes(&self) -> impl DoubleEndedIterator<Item = Node<'a>> + 'b {
        self.defaults
            .iter()
            .copied()
            .chain(std::iter::once(self.element))
    }

    /// The innermost value of `name` with the node that sets it.
    fn find(&self, name: &str) -> Option<(Node<'a>, &'a str)> {
        self.nodes()
            .rev()
            .find_map(|n| value(n, name).map(|v| (n, v)))
    }

    pub fn text(&self, name: &str) -> Option<&'a str> {
        self.find(name).map(|(_, v)| v)
    }

    pub fn error(&self, node: Node, message: impl Into<String>) -> ModelError {
        xml::invalid(self.file, node, message)
    }

    /// Exactly `N` numbers.
    pub fn exact<const N: usize>(&self, name: &str) -> Result<Option<[f64; N]>> {
        let Some((node, text)) = self.find(name) else {
            return Ok(None);
        };
        let v = self.numbers(node, name, text)?;
        let n = v.len();
        v.try_into().map(Some).map_err(|_| {
            self.error(
                node,
                format!("attribute '{name}' needs {N} numbers, got {n}: \"{text}\""),
            )
        })
    }

    pub fn number(&self, name: &str) -> Result<Option<f64>> {
        Ok(self.exact::<1>(name)?.map(|[x]| x))
    }

    pub fn vector(&self, name: &str) -> Result<Option<Vector3<f64>>> {
        Ok(self.exact::<3>(name)?.map(Vector3::from))
    }

    /// Up to `N` numbers, each setting overwriting the leading entries of the
    /// value so far, which starts at `init` (MuJoCo's `size`, `gear`, ...).
    pub fn leading<const N: usize>(&self, name: &str, init: [f64; N]) -> Result<[f64; N]> {
        let mut out = init;
        for node in self.nodes() {
            let Some(text) = value(node, name) else {
                continue;
            };
            let v = self.numbers(node, name, text)?;
            if v.len() > N {
                let msg = format!("attribute '{name}' takes at most {N} numbers, got \"{text}\"");
                return Err(self.error(node, msg));
            }
            out[..v.len()].copy_from_slice(&v);
        }
        Ok(out)
    }

    /// Any count of numbers.
    pub fn list(&self, name: &str) -> Result<Option<Vec<f64>>> {
        match self.find(name) {
            Some((node, text)) => self.numbers(node, name, text).map(Some),
            None => Ok(None),
        }
    }

    fn numbers(&self, node: Node, name: &str, text: &str) -> Result<Vec<f64>> {
        xml::numbers(text).ok_or_else(|| {
            self.error(
                node,
                format!("attribute '{name}' must be finite numbers, got \"{text}\""),
            )
        })
    }

    pub fn ints<const N: usize>(&self, name: &str) -> Result<Option<[i64; N]>> {
        let Some((node, text)) = self.find(name) else {
            return Ok(None);
        };
        let bad = || {
            self.error(
                node,
                format!("attribute '{name}' needs {N} integers, got \"{text}\""),
            )
        };
        let v = text.split_whitespace().map(|t| t.parse::<i64>().ok());
        let v = v.collect::<Option<Vec<i64>>>().ok_or_else(bad)?;
        v.try_into().map(Some).map_err(|_| bad())
    }

    pub fn int(&self, name: &str) -> Result<Option<i64>> {
        Ok(self.ints::<1>(name)?.map(|[x]| x))
    }

    pub fn keyword(&self, name: &str, allowed: &[&'static str]) -> Result<Option<&'static str>> {
        let Some((node, v)) = self.find(name) else {
            return Ok(None);
        };
        match allowed.iter().find(|k| **k == v) {
            Some(k) => Ok(Some(*k)),
            None => {
                let msg = format!("attribute '{name}' must be one of {allowed:?}, got \"{v}\"");
                Err(self.error(node, msg))
            }
        }
    }

    /// A `solref` and a `solimp` attribute (up to 2 and 5 numbers over
    /// MuJoCo's defaults).
    pub fn sol_params(&self, solref: &str, solimp: &str) -> Result<SolParams> {
        Ok(SolParams {
            solref: self.leading(solref, SOLREF)?,
            solimp: self.leading(solimp, SOLIMP)?,
        })
    }

    pub fn flag(&self, name: &str) -> Result<Option<bool>> {
        Ok(self.keyword(name, &["false", "true"])?.map(|k| k == "true"))
    }

    /// MuJoCo's limits: `limited` is false, true, or auto (limited when a
    /// `range` is given in increasing order). Returns the range if limited.
    pub fn limits(&self, limited: &str, range: &str, autolimits: bool) -> Result<Option<[f64; 2]>> {
        let r = self.exact::<2>(range)?.unwrap_or([0.0; 2]);
        let mode = self
            .keyword(limited, &["false", "true", "auto"])?
            .unwrap_or("auto");
        if mode == "auto" && r != [0.0; 2] && !autolimits {
            let msg = format!(
                "'{range}' without '{limited}': set <compiler autolimits=\"true\"> or '{limited}'"
            );
            return Err(self.error(self.element, msg));
        }
        let on = mode == "true" || (mode == "auto" && r[0] < r[1]);
        if on && r[0] >= r[1] {
            let msg = format!("{range}[0] must be smaller than {range}[1], got {r:?}");
            return Err(self.error(self.element, msg));
        }
        Ok(on.then_some(r))
    }
}

/// The value of attribute `name` of `node`, if set and not blank.
pub fn value<'a>(node: Node<'a>, name: &str) -> Option<&'a str> {
    node.attribute(name).filter(|v| !v.trim().is_empty())
}
