//! `laydown table`: a stage version's per-point results as one table, read back from the
//! archive, as CSV, Markdown or JSON, at full precision.
//!
//! A table has one row per element of its **row dimensions** and one column per dataset
//! that lies along them. The row dimensions of each stage kind:
//!
//! | kind | rows (default) | rows with `--all` |
//! |---|---|---|
//! | `laydown` | point | point, replicate |
//! | `laid_web` | point | point, replicate |
//! | `spectra` | point, bin (mean spectra) | point, fibre (per-fibre bending energies) |
//! | `web` | point | – (no per-realisation values are stored; the per-point table) |
//! | `grid` | point | point, realisation |
//! | `image` | point, condition (without a sweep: condition) | point, sample (without a sweep: sample) |
//! | `accuracy` | candidate, metric | – (the same table) |
//!
//! Columns: the row dimensions' coordinates (an index where a dimension has none, e.g.
//! `point`), then every dataset whose dimensions are some of the row dimensions (in the
//! same order), repeated along the ones it lacks: first the swept parameters, named as
//! in the pipeline (`bonds.contrast`), then text (labels, file names), then the values
//! along all row dimensions, then those repeated along some; by name within each. So the default table holds the
//! means and standard deviations over replicates (`cv_mean`, `cv_std`, ...) next to the
//! swept parameters, and `--all` the per-replicate values with the per-point ones beside
//! them. Numbers are written in Rust's shortest round-trip form (`{:?}`: `0.1`, `1e-7`),
//! so reading them back gives the stored `f64` exactly; NaN is `NaN` (CSV, Markdown) or
//! `null` (JSON).
use crate::archive::data::Attr;
use crate::archive::{hdf, Archive};
use anyhow::{anyhow, bail, Context, Result};
use hdf5::types::TypeDescriptor;
use std::collections::BTreeMap;
use std::path::Path;

/// Output format of a table.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    Csv,
    Markdown,
    Json,
}

/// One cell of a table.
#[derive(Debug, Clone, PartialEq)]
pub enum Cell {
    Float(f64),
    Int(i64),
    Text(String),
}

/// One column: a dataset (or coordinate, or swept parameter) along the row dimensions.
#[derive(Debug, Clone)]
pub struct Column {
    pub name: String,
    pub units: String,
    pub long_name: String,
    pub cells: Vec<Cell>,
}

/// A stage version's results as rows along `row_dims`.
#[derive(Debug, Clone)]
pub struct Table {
    pub stage: String,
    pub version: u32,
    pub kind: String,
    pub group: String,
    pub row_dims: Vec<String>,
    pub columns: Vec<Column>,
    /// Said on stderr, e.g. that a kind stores no per-replicate values.
    pub note: Option<String>,
}

/// The row dimensions of a stage kind (`all`: per replicate); None: no such table.
pub fn row_dims(kind: &str, all: bool) -> Option<&'static [&'static str]> {
    Some(match (kind, all) {
        ("laydown", false) => &["point"],
        ("laydown", true) => &["point", "replicate"],
        ("laid_web", false) => &["point"],
        ("laid_web", true) => &["point", "replicate"],
        ("spectra", false) => &["point", "bin"],
        ("spectra", true) => &["point", "fibre"],
        ("web", false) => &["point"],
        ("grid", false) => &["point"],
        ("grid", true) => &["point", "realisation"],
        ("image", false) => &["point", "condition"],
        ("image", true) => &["point", "sample"],
        ("accuracy", false) => &["candidate", "metric"],
        _ => return None,
    })
}

/// The values of one dataset, flat (row-major), with its shape.
struct Data {
    shape: Vec<usize>,
    cells: Vec<Cell>,
    units: String,
    long_name: String,
    parameter: Option<String>,
}

fn read(group: &hdf5::Group, name: &str) -> Result<Data> {
    let ds = group.dataset(name)?;
    let attrs = hdf::read_attrs(&ds)?;
    let text = |k: &str| match attrs.get(k) {
        Some(Attr::Str(s)) => s.clone(),
        _ => String::new(),
    };
    let cells = match ds.dtype()?.to_descriptor()? {
        TypeDescriptor::Float(_) => hdf::read_f64(group, name)?.iter().map(|&v| Cell::Float(v)).collect(),
        TypeDescriptor::Integer(_) | TypeDescriptor::Unsigned(_) | TypeDescriptor::Boolean | TypeDescriptor::Enum(_) => {
            hdf::read_i64(group, name)?.iter().map(|&v| Cell::Int(v)).collect()
        }
        TypeDescriptor::VarLenUnicode | TypeDescriptor::VarLenAscii | TypeDescriptor::FixedAscii(_) | TypeDescriptor::FixedUnicode(_) => {
            hdf::read_strings(group, name)?.into_iter().map(Cell::Text).collect()
        }
        other => bail!("dataset `{name}` has a type a table cannot hold: {other:?}"),
    };
    let parameter = match attrs.get("parameter") {
        Some(Attr::Str(p)) => Some(p.clone()),
        _ => None,
    };
    Ok(Data { shape: ds.shape(), cells, units: text("units"), long_name: text("long_name"), parameter })
}

/// Reads the table of `stage_ref` (`STAGE` or `STAGE@vN`) of an archive.
pub fn read_table(archive: &Path, stage_ref: &str, all: bool) -> Result<Table> {
    let (stage, number) = crate::archive::parse_stage_ref(stage_ref)?;
    let a = Archive::open_read(archive)?;
    let info = a.version(&stage, number)?;
    let group = info.open()?;
    let kind = info.attr_str("stage_kind").unwrap_or("?").to_string();
    let mut note = None;
    let wanted = match (row_dims(&kind, all), all) {
        (Some(d), _) => d,
        (None, true) => {
            let d = row_dims(&kind, false).ok_or_else(|| anyhow!("no table for stage kind `{kind}`"))?;
            note = Some(format!("a {kind} stage stores no per-replicate values: the table is per {}", d.join(" × ")));
            d
        }
        (None, false) => bail!("no table for stage kind `{kind}`"),
    };
    let dims = hdf::dimension_names(&group).with_context(|| format!("{}: reading dimensions", info.group_path()))?;
    let is_scale = |d: &str| dims.get(d).is_some_and(|v| v.len() == 1 && v[0] == d);
    let rows: Vec<String> = wanted.iter().filter(|d| is_scale(d)).map(|d| d.to_string()).collect();
    if rows.is_empty() {
        bail!("{}: none of the row dimensions {} of a {kind} stage is stored", info.group_path(), wanted.join(", "));
    }
    let mut data: BTreeMap<String, Data> = BTreeMap::new();
    let get = |data: &mut BTreeMap<String, Data>, name: &str| -> Result<()> {
        if !data.contains_key(name) {
            data.insert(name.to_string(), read(&group, name).with_context(|| format!("{}: dataset `{name}`", info.group_path()))?);
        }
        Ok(())
    };
    let mut sizes = Vec::new();
    for d in &rows {
        get(&mut data, d)?;
        sizes.push(data[d.as_str()].shape.first().copied().unwrap_or(1));
    }
    let n: usize = sizes.iter().product();
    // Datasets along some of the row dimensions, in their order: (name, positions in rows).
    let mut along: Vec<(String, Vec<usize>)> = Vec::new();
    for (name, d) in &dims {
        if d.is_empty() || rows.contains(name) {
            continue;
        }
        let pos: Option<Vec<usize>> = d.iter().map(|x| rows.iter().position(|r| r == x)).collect();
        if let Some(pos) = pos.filter(|p| p.windows(2).all(|w| w[0] < w[1])) {
            along.push((name.clone(), pos));
        }
    }
    for (name, _) in &along {
        get(&mut data, name)?;
    }
    // Row-major multi-index of each row.
    let index = |r: usize| -> Vec<usize> {
        let mut idx = vec![0; sizes.len()];
        let mut rest = r;
        for k in (0..sizes.len()).rev() {
            idx[k] = rest % sizes[k];
            rest /= sizes[k];
        }
        idx
    };
    let column = |name: &str, label: String, pos: &[usize]| -> Result<Column> {
        let d = &data[name];
        let cells = (0..n)
            .map(|r| {
                let idx = index(r);
                let mut off = 0;
                for (k, &p) in pos.iter().enumerate() {
                    off = off * d.shape[k] + idx[p];
                }
                d.cells.get(off).cloned().ok_or_else(|| anyhow!("dataset `{name}` is shorter than its dimensions say"))
            })
            .collect::<Result<_>>()?;
        Ok(Column { name: label, units: d.units.clone(), long_name: d.long_name.clone(), cells })
    };
    let mut columns = Vec::new();
    for (k, d) in rows.iter().enumerate() {
        columns.push(column(d, d.clone(), &[k])?);
    }
    // Swept parameters, text (labels, file names), values along every row dimension,
    // then those repeated along some; by name within each.
    along.sort_by_key(|(name, pos)| {
        let d = &data[name];
        let rank = if d.parameter.is_some() {
            0
        } else if matches!(d.cells.first(), Some(Cell::Text(_))) {
            1
        } else if pos.len() == rows.len() {
            2
        } else {
            3
        };
        (rank, name.clone())
    });
    for (name, pos) in &along {
        let label = data[name].parameter.clone().unwrap_or_else(|| name.clone());
        if columns.iter().any(|c| c.name == label) {
            continue;
        }
        columns.push(column(name, label, pos)?);
    }
    Ok(Table { stage: info.stage.clone(), version: info.number, kind, group: info.group_path(), row_dims: rows, columns, note })
}

/// A number in its shortest round-trip form.
fn number(v: f64) -> String {
    if v.is_nan() {
        "NaN".into()
    } else {
        format!("{v:?}")
    }
}

fn plain(c: &Cell) -> String {
    match c {
        Cell::Float(v) => number(*v),
        Cell::Int(v) => v.to_string(),
        Cell::Text(s) => s.clone(),
    }
}

impl Table {
    pub fn rows(&self) -> usize {
        self.columns.first().map(|c| c.cells.len()).unwrap_or(0)
    }

    /// The column called `name`.
    pub fn column(&self, name: &str) -> Option<&Column> {
        self.columns.iter().find(|c| c.name == name)
    }

    pub fn render(&self, format: Format) -> String {
        match format {
            Format::Csv => self.csv(),
            Format::Markdown => self.markdown(),
            Format::Json => self.json(),
        }
    }

    /// RFC 4180 CSV: a header of column names, then one line per row.
    pub fn csv(&self) -> String {
        let field = |s: &str| {
            if s.contains([',', '"', '\n', '\r']) || s.starts_with(' ') || s.ends_with(' ') {
                format!("\"{}\"", s.replace('"', "\"\""))
            } else {
                s.to_string()
            }
        };
        let mut out = self.columns.iter().map(|c| field(&c.name)).collect::<Vec<_>>().join(",");
        out.push('\n');
        for r in 0..self.rows() {
            out += &self.columns.iter().map(|c| field(&plain(&c.cells[r]))).collect::<Vec<_>>().join(",");
            out.push('\n');
        }
        out
    }

    /// A Markdown (GitHub) table; headers carry the units, numbers are right-aligned.
    pub fn markdown(&self) -> String {
        let esc = |s: &str| s.replace('|', "\\|").replace('\n', " ");
        let head: Vec<String> = self
            .columns
            .iter()
            .map(|c| match c.units.as_str() {
                "" | "1" => esc(&c.name),
                u => format!("{} ({})", esc(&c.name), esc(u)),
            })
            .collect();
        let align: Vec<&str> = self.columns.iter().map(|c| if matches!(c.cells.first(), Some(Cell::Text(_))) { "---" } else { "---:" }).collect();
        let mut out = format!("| {} |\n|{}|\n", head.join(" | "), align.join("|"));
        for r in 0..self.rows() {
            out += &format!("| {} |\n", self.columns.iter().map(|c| esc(&plain(&c.cells[r]))).collect::<Vec<_>>().join(" | "));
        }
        out
    }

    /// `{"stage", "version", "kind", "group", "row_dims", "columns": [{name, units, long_name}], "rows": [[...], ...]}`.
    pub fn json(&self) -> String {
        use serde_json::{json, Value};
        let cell = |c: &Cell| match c {
            Cell::Float(v) if v.is_finite() => json!(v),
            Cell::Float(_) => Value::Null,
            Cell::Int(v) => json!(v),
            Cell::Text(s) => json!(s),
        };
        let rows: Vec<Value> = (0..self.rows()).map(|r| Value::Array(self.columns.iter().map(|c| cell(&c.cells[r])).collect())).collect();
        let columns: Vec<Value> = self.columns.iter().map(|c| json!({"name": c.name, "units": c.units, "long_name": c.long_name})).collect();
        let doc = json!({
            "stage": self.stage,
            "version": self.version,
            "kind": self.kind,
            "group": self.group,
            "row_dims": self.row_dims,
            "columns": columns,
            "rows": rows,
        });
        serde_json::to_string_pretty(&doc).expect("a table is valid JSON") + "\n"
    }
}
