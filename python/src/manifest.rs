//! `panoconv.read_manifest` and `panoconv.verify`: a converted dataset's manifest, and the
//! check `panoconv verify` makes of the files against it, with the same text.

use crate::errors::IntoPy;
use panoconv::error::Error;
use panoconv::run::manifest::MANIFEST;
use panoconv::tools::verify::{verify as verify_folder, Problem, Report};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use serde_json::Value;
use std::path::{Path, PathBuf};

/// The manifest file of `path`: `path/panoconv.json` for a folder, else `path` itself.
fn manifest_file(path: &Path) -> PathBuf {
    if path.is_dir() {
        path.join(MANIFEST)
    } else {
        path.to_path_buf()
    }
}

fn to_python<'py>(py: Python<'py>, v: &Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match v {
        Value::Null => py.None().into_bound(py),
        Value::Bool(b) => b.into_pyobject(py)?.to_owned().into_any(),
        Value::Number(n) => match (n.as_i64(), n.as_u64()) {
            (Some(i), _) => i.into_pyobject(py)?.into_any(),
            (None, Some(u)) => u.into_pyobject(py)?.into_any(),
            _ => n.as_f64().unwrap_or(f64::NAN).into_pyobject(py)?.into_any(),
        },
        Value::String(s) => s.into_pyobject(py)?.into_any(),
        Value::Array(items) => {
            let list = PyList::empty(py);
            for item in items {
                list.append(to_python(py, item)?)?;
            }
            list.into_any()
        }
        Value::Object(map) => {
            let dict = PyDict::new(py);
            for (k, item) in map {
                dict.set_item(k, to_python(py, item)?)?;
            }
            dict.into_any()
        }
    })
}

/// Reads a converted dataset's manifest (`OUT/panoconv.json`, or the folder `OUT`) as Python
/// values (dicts in the file's key order). Malformed JSON raises `ParseError` naming the line
/// and column.
#[pyfunction]
pub fn read_manifest<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, PyAny>> {
    let file = manifest_file(&path);
    let value = py
        .detach(|| {
            let bytes = panoconv::fs::read_file(&file)?;
            serde_json::from_slice::<Value>(&bytes).map_err(|e| {
                let text = e.to_string();
                let suffix = format!(" at line {} column {}", e.line(), e.column());
                Error::Parse {
                    path: file.clone(),
                    line: e.line(),
                    field: format!("column {}", e.column()),
                    message: format!(
                        "not a panoconv manifest: {}",
                        text.strip_suffix(&suffix).unwrap_or(&text)
                    ),
                }
            })
        })
        .py()?;
    to_python(py, &value)
}

/// What `panoconv verify` found: the problems, counts and the text it prints.
#[pyclass(module = "panoconv", frozen)]
pub struct VerifyReport {
    report: Report,
    folder: String,
}

#[pymethods]
impl VerifyReport {
    /// True when every listed file matches and nothing is missing, changed or extra.
    #[getter]
    fn ok(&self) -> bool {
        self.report.is_ok()
    }
    /// Distinct output files the manifest lists.
    #[getter]
    fn listed(&self) -> usize {
        self.report.listed
    }
    /// Listed files whose blake3 matched.
    #[getter]
    fn matched(&self) -> usize {
        self.report.matched
    }
    /// Listed files that are absent.
    #[getter]
    fn missing(&self) -> usize {
        self.report.missing()
    }
    /// Listed files whose hash differs.
    #[getter]
    fn changed(&self) -> usize {
        self.report.changed()
    }
    /// Files under the folder that nothing lists.
    #[getter]
    fn extra(&self) -> usize {
        self.report.extra()
    }
    /// One `(kind, path, line)` per problem: kind is `missing`, `changed`, `extra`,
    /// `unreadable`, `bad path` or `conflict`; line is the text `panoconv verify` prints.
    #[getter]
    fn problems(&self) -> Vec<(&'static str, String, String)> {
        self.report
            .problems
            .iter()
            .map(|p| {
                let kind = match p {
                    Problem::Missing { .. } => "missing",
                    Problem::Changed { .. } => "changed",
                    Problem::Extra { .. } => "extra",
                    Problem::Unreadable { .. } => "unreadable",
                    Problem::BadPath { .. } => "bad path",
                    Problem::Conflict { .. } => "conflict",
                };
                (kind, p.path().to_owned(), p.to_string())
            })
            .collect()
    }
    /// `N files listed, M match, a missing, b changed, c extra`.
    #[getter]
    fn summary(&self) -> String {
        self.report.summary()
    }
    /// The exit status `panoconv verify` gives: 0 everything matches, 1 problems found.
    #[getter]
    fn exit_code(&self) -> i32 {
        if self.report.is_ok() {
            0
        } else {
            1
        }
    }
    /// Exactly what `panoconv verify FOLDER` prints on standard output.
    fn __str__(&self) -> String {
        let mut out: String = self
            .report
            .problems
            .iter()
            .map(|p| format!("{p}\n"))
            .collect();
        let verdict = if self.report.is_ok() { "OK" } else { "FAILED" };
        out.push_str(&format!(
            "panoconv verify: {verdict}: {} ({})\n",
            self.report.summary(),
            self.folder
        ));
        out
    }
    fn __repr__(&self) -> String {
        format!("VerifyReport(ok={}, {})", self.ok(), self.summary())
    }
}

/// Checks a converted dataset against its manifest as `panoconv verify` does (every listed
/// file re-hashed with blake3, unlisted files reported). A missing or malformed manifest
/// raises the error the command prints.
#[pyfunction]
pub fn verify(py: Python<'_>, path: PathBuf) -> PyResult<VerifyReport> {
    let report = py.detach(|| verify_folder(&path)).py()?;
    Ok(VerifyReport {
        report,
        folder: path.display().to_string(),
    })
}
