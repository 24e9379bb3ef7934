//! The lens file format (documented on the `lens` module): parse, write, load.

use std::path::{Path, PathBuf};
use std::str::FromStr;

use thiserror::Error;

use super::prescription::{LensPrescription, LensSurface, PrescriptionError, curvature_of_radius};
use crate::fresnel::Coating;
use crate::glass::Glass;

/// Why a lens file could not be read.
#[derive(Debug, Error)]
pub enum ParseError {
    /// A field that does not hold what it must.
    #[error("line {line}, field `{field}`: expected {expected}, got `{got}`")]
    Field {
        /// 1-based line number.
        line: usize,
        /// Name of the field (`radius`, `semi_aperture`, `focal_length`, ...).
        field: &'static str,
        /// What was expected, in words.
        expected: &'static str,
        /// The text found.
        got: String,
    },
    /// A table row with the wrong number of fields.
    #[error(
        "line {line}: expected 4 or 5 fields (radius thickness medium semi_aperture [coating]), got {count}: `{text}`"
    )]
    FieldCount {
        /// 1-based line number.
        line: usize,
        /// Number of whitespace-separated fields found.
        count: usize,
        /// The line without its comment.
        text: String,
    },
    /// A header key the format does not have.
    #[error(
        "line {line}: unknown key `{key}` (known: name, source, focal_length, f_number, units)"
    )]
    UnknownKey {
        /// 1-based line number.
        line: usize,
        /// The key.
        key: String,
    },
    /// A header key given twice.
    #[error("line {line}: key `{key}` given twice")]
    DuplicateKey {
        /// 1-based line number.
        line: usize,
        /// The key.
        key: String,
    },
    /// A `key = value` line after the first table row.
    #[error("line {line}: header line `{key} = ...` after the surface table")]
    HeaderAfterTable {
        /// 1-based line number.
        line: usize,
        /// The key.
        key: String,
    },
    /// A required header key is missing.
    #[error("missing header key `{key}`")]
    MissingKey {
        /// The key.
        key: &'static str,
    },
    /// The rows parse but do not make a valid lens; `line` is the row of the
    /// surface at fault when there is one.
    #[error("{}{source}", line.map(|l| format!("line {l}: ")).unwrap_or_default())]
    Invalid {
        /// 1-based line of the offending row, if the error is about one surface.
        line: Option<usize>,
        /// What is wrong.
        source: PrescriptionError,
    },
    /// The bytes are not UTF-8 text (a binary or corrupted file).
    #[error("line {line}: not UTF-8 text")]
    NotText {
        /// 1-based line of the first byte that is not UTF-8.
        line: usize,
    },
    /// The file could not be read.
    #[error("reading {}: {source}", path.display())]
    Io {
        /// The path given.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
}

impl ParseError {
    /// The 1-based line the error is on, if it is on one.
    pub fn line(&self) -> Option<usize> {
        match self {
            ParseError::Field { line, .. }
            | ParseError::FieldCount { line, .. }
            | ParseError::UnknownKey { line, .. }
            | ParseError::DuplicateKey { line, .. }
            | ParseError::HeaderAfterTable { line, .. }
            | ParseError::NotText { line } => Some(*line),
            ParseError::Invalid { line, .. } => *line,
            ParseError::MissingKey { .. } | ParseError::Io { .. } => None,
        }
    }
}

impl LensPrescription {
    /// Parses a lens file's text (the format is documented on the `lens`
    /// module) and validates it.
    pub fn parse(text: &str) -> Result<Self, ParseError> {
        parse_lens_file(text)
    }

    /// [`Self::parse`] for the raw bytes of a file, as an asset loader gets
    /// them: bytes that are not UTF-8 are [`ParseError::NotText`], naming
    /// the line they are on.
    pub fn parse_bytes(bytes: &[u8]) -> Result<Self, ParseError> {
        match std::str::from_utf8(bytes) {
            Ok(text) => Self::parse(text),
            Err(e) => {
                let line = 1 + bytes[..e.valid_up_to()]
                    .iter()
                    .filter(|&&b| b == b'\n')
                    .count();
                Err(ParseError::NotText { line })
            }
        }
    }

    /// Reads and parses the lens file at `path`.
    pub fn load(path: impl AsRef<Path>) -> Result<Self, ParseError> {
        let path = path.as_ref();
        let bytes = std::fs::read(path).map_err(|source| ParseError::Io {
            path: path.to_owned(),
            source,
        })?;
        Self::parse_bytes(&bytes)
    }

    /// The prescription as a lens file (the format of [`Self::parse`]).
    pub fn to_lens_file(&self) -> String {
        let mut out = String::new();
        out.push_str("# optica lens file: radius thickness medium semi_aperture [coating]; thickness and medium follow the surface\n");
        out.push_str(&format!("name = {}\n", self.name().trim()));
        if !self.source().trim().is_empty() {
            out.push_str(&format!("source = {}\n", self.source().trim()));
        }
        if let Some(f) = self.design_focal_length_mm() {
            out.push_str(&format!("focal_length = {f}\n"));
        }
        if let Some(n) = self.design_f_number() {
            out.push_str(&format!("f_number = {n}\n"));
        }
        out.push_str("units = mm\n\n");
        for s in self.surfaces() {
            // Radii are written as 1/c: for a finite c this round-trips c
            // exactly only if 1/(1/c) == c, so when it does not, the file
            // holds the radius that does (checked below).
            let radius = if s.is_stop {
                "stop".to_string()
            } else if s.curvature == 0.0 {
                "inf".to_string()
            } else {
                radius_text(s.curvature)
            };
            out.push_str(&format!(
                "{radius} {} {} {}",
                s.thickness_after_mm,
                glass_text(&s.glass_after),
                s.semi_aperture_mm
            ));
            if let Some(c) = &s.coating {
                out.push_str(&format!(" {}/{}", c.index(), c.thickness_nm()));
            }
            out.push('\n');
        }
        out
    }
}

impl FromStr for LensPrescription {
    type Err = ParseError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::parse(s)
    }
}

/// How many one-ulp steps [`radius_text`] tries around `1/c`. Correctly
/// rounded division makes `1/(1/c)` miss `c` by at most an ulp or two, so a
/// radius within a few ulps of `1/c` gives `c` back when any does.
const RADIUS_ULP_STEPS: usize = 4;

/// A radius whose reciprocal gives back `c` exactly, if a nearby one does.
fn radius_text(c: f64) -> String {
    let r = 1.0 / c;
    // 1/(1/c) can miss c by an ulp; a neighbour of r usually hits it. 1/r
    // falls as r rises (either sign), so step r up when 1/r is too large.
    let mut candidate = r;
    for _ in 0..RADIUS_ULP_STEPS {
        let back = 1.0 / candidate;
        if back == c {
            return format!("{candidate}");
        }
        candidate = if back > c {
            candidate.next_up()
        } else {
            candidate.next_down()
        };
    }
    format!("{r}")
}

fn glass_text(g: &Glass) -> String {
    match g {
        Glass::Air => "air".into(),
        // `n/inf`: an Abbe number of infinity is no dispersion (a bare number
        // would read back the same; `n/inf` says so explicitly).
        Glass::Constant(n) => format!("{n}/inf"),
        Glass::Abbe { nd, vd } => format!("{nd}/{vd}"),
        Glass::Sellmeier { b, c } => format!(
            "sellmeier:{},{},{},{},{},{}",
            b[0], b[1], b[2], c[0], c[1], c[2]
        ),
    }
}

/// One header value, remembered with its line.
struct Header {
    name: Option<String>,
    source: Option<String>,
    focal_length: Option<f64>,
    f_number: Option<f64>,
    units_seen: bool,
}

fn parse_lens_file(text: &str) -> Result<LensPrescription, ParseError> {
    let mut header = Header {
        name: None,
        source: None,
        focal_length: None,
        f_number: None,
        units_seen: false,
    };
    let mut surfaces = Vec::new();
    let mut rows = Vec::new(); // line of each surface, for errors
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let content = raw.split('#').next().unwrap_or("").trim();
        if content.is_empty() {
            continue;
        }
        if let Some((key, value)) = content.split_once('=') {
            let key = key.trim().to_ascii_lowercase();
            let value = value.trim();
            if !surfaces.is_empty() {
                return Err(ParseError::HeaderAfterTable { line, key });
            }
            header_line(&mut header, line, &key, value)?;
            continue;
        }
        surfaces.push(row(line, content)?);
        rows.push(line);
    }
    let name = header.name.ok_or(ParseError::MissingKey { key: "name" })?;
    LensPrescription::new(name, header.source.unwrap_or_default(), surfaces)
        .and_then(|p| p.with_design(header.focal_length, header.f_number))
        .map_err(|source| ParseError::Invalid {
            line: source.surface().and_then(|k| rows.get(k).copied()),
            source,
        })
}

fn header_line(h: &mut Header, line: usize, key: &str, value: &str) -> Result<(), ParseError> {
    let dup = || ParseError::DuplicateKey {
        line,
        key: key.to_string(),
    };
    match key {
        "name" => {
            if h.name.is_some() {
                return Err(dup());
            }
            if value.is_empty() {
                return Err(ParseError::Field {
                    line,
                    field: "name",
                    expected: "a non-empty name",
                    got: value.into(),
                });
            }
            h.name = Some(value.to_string());
        }
        "source" => {
            if h.source.is_some() {
                return Err(dup());
            }
            h.source = Some(value.to_string());
        }
        "focal_length" => {
            if h.focal_length.is_some() {
                return Err(dup());
            }
            h.focal_length = Some(positive(line, "focal_length", value)?);
        }
        "f_number" => {
            if h.f_number.is_some() {
                return Err(dup());
            }
            h.f_number = Some(positive(line, "f_number", value)?);
        }
        "units" => {
            if h.units_seen {
                return Err(dup());
            }
            if !value.eq_ignore_ascii_case("mm") {
                return Err(ParseError::Field {
                    line,
                    field: "units",
                    expected: "`mm`",
                    got: value.into(),
                });
            }
            h.units_seen = true;
        }
        _ => {
            return Err(ParseError::UnknownKey {
                line,
                key: key.to_string(),
            });
        }
    }
    Ok(())
}

fn number(text: &str) -> Option<f64> {
    // Only finite decimal numbers: Rust's parser also takes `inf` and `NaN`,
    // which must not sneak in as thicknesses or indices.
    let v: f64 = text.parse().ok()?;
    v.is_finite().then_some(v)
}

fn positive(line: usize, field: &'static str, text: &str) -> Result<f64, ParseError> {
    match number(text) {
        Some(v) if v > 0.0 => Ok(v),
        _ => Err(ParseError::Field {
            line,
            field,
            expected: "a positive number",
            got: text.into(),
        }),
    }
}

fn row(line: usize, content: &str) -> Result<LensSurface, ParseError> {
    let fields: Vec<&str> = content.split_whitespace().collect();
    if !(4..=5).contains(&fields.len()) {
        return Err(ParseError::FieldCount {
            line,
            count: fields.len(),
            text: content.into(),
        });
    }
    let (is_stop, curvature) = match fields[0].to_ascii_lowercase().as_str() {
        "stop" => (true, 0.0),
        "inf" | "infinity" | "+inf" | "-inf" | "flat" => (false, 0.0),
        t => match number(t) {
            Some(r) if r != 0.0 => (false, curvature_of_radius(r)),
            _ => {
                return Err(ParseError::Field {
                    line,
                    field: "radius",
                    expected: "a non-zero number, `inf` (flat) or `stop`",
                    got: fields[0].into(),
                });
            }
        },
    };
    let thickness = match number(fields[1]) {
        Some(t) if t >= 0.0 => t,
        _ => {
            return Err(ParseError::Field {
                line,
                field: "thickness",
                expected: "a number >= 0",
                got: fields[1].into(),
            });
        }
    };
    let glass = medium(line, fields[2])?;
    let semi_aperture = positive(line, "semi_aperture", fields[3])?;
    let coating = match fields.get(4) {
        None => None,
        Some(t) => coating(line, t)?,
    };
    Ok(LensSurface {
        curvature,
        thickness_after_mm: thickness,
        glass_after: glass,
        semi_aperture_mm: semi_aperture,
        is_stop,
        coating,
    })
}

fn medium(line: usize, text: &str) -> Result<Glass, ParseError> {
    let bad = |expected| ParseError::Field {
        line,
        field: "medium",
        expected,
        got: text.into(),
    };
    if text.eq_ignore_ascii_case("air") {
        return Ok(Glass::Air);
    }
    if let Some(list) = text.strip_prefix("sellmeier:") {
        const SELLMEIER: &str =
            "`sellmeier:B1,B2,B3,C1,C2,C3` with six finite numbers >= 0 giving n_d >= 1";
        let v: Vec<f64> = list
            .split(',')
            .map(number)
            .collect::<Option<_>>()
            .ok_or_else(|| bad(SELLMEIER))?;
        if v.len() != 6 {
            return Err(bad(SELLMEIER));
        }
        // Checked: negative coefficients give curves no glass has.
        return Glass::sellmeier_checked([v[0], v[1], v[2]], [v[3], v[4], v[5]])
            .map_err(|_| bad(SELLMEIER));
    }
    if let Some((nd, vd)) = text.split_once('/') {
        let no_dispersion = matches!(vd.to_ascii_lowercase().as_str(), "inf" | "infinity");
        return match (number(nd), number(vd)) {
            (Some(nd), _) if no_dispersion && nd >= 1.0 => Ok(Glass::Constant(nd)),
            (Some(nd), Some(vd)) if nd >= 1.0 && vd > 0.0 => Ok(Glass::Abbe { nd, vd }),
            _ => Err(bad(
                "`nd/vd` with nd >= 1 and vd > 0 (like `1.6910/54.8`), or `n/inf`",
            )),
        };
    }
    // A number is always a constant index, never a catalog lookup (which
    // would make `1.67` the dispersive spectacle glass and `1.670` a constant).
    if let Ok(n) = text.parse::<f64>() {
        return match number(text) {
            Some(_) if n >= 1.0 => Ok(Glass::Constant(n)),
            _ => Err(bad(
                "`air`, a catalog glass name, `nd/vd`, `n/inf` or an index >= 1",
            )),
        };
    }
    Glass::catalog(text)
        .ok_or_else(|| bad("`air`, a catalog glass name, `nd/vd`, `n/inf` or an index >= 1"))
}

fn coating(line: usize, text: &str) -> Result<Option<Coating>, ParseError> {
    let bad = || ParseError::Field {
        line,
        field: "coating",
        expected: "`none`, `index/thickness_nm` or `qw:index@wavelength_nm`",
        got: text.into(),
    };
    if text.eq_ignore_ascii_case("none") || text == "-" {
        return Ok(None);
    }
    if let Some(rest) = text.strip_prefix("qw:") {
        let (n, wl) = rest.split_once('@').ok_or_else(bad)?;
        return match (number(n), number(wl)) {
            (Some(n), Some(wl)) if n >= 1.0 => {
                Coating::quarter_wave(n, wl).map(Some).map_err(|_| bad())
            }
            _ => Err(bad()),
        };
    }
    let (n, t) = text.split_once('/').ok_or_else(bad)?;
    match (number(n), number(t)) {
        (Some(index), Some(thickness_nm)) if index >= 1.0 => Coating::new(index, thickness_nm)
            .map(Some)
            .map_err(|_| bad()),
        _ => Err(bad()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SMALL: &str = "\
# a test lens
name = Test singlet
source = made up for the tests
focal_length = 100
f_number = 4
units = mm
stop   2.0   air          5.0
 50.0  4.0   1.5168/64.17 10.0   # front
-50.0  45.0  air          10.0
";

    fn err(text: &str) -> ParseError {
        LensPrescription::parse(text).unwrap_err()
    }

    /// Replaces line `line` (1-based) of SMALL with `with`.
    fn with_line(line: usize, with: &str) -> String {
        SMALL
            .lines()
            .enumerate()
            .map(|(i, l)| {
                if i + 1 == line {
                    with.to_string()
                } else {
                    l.to_string()
                }
            })
            .collect::<Vec<_>>()
            .join("\n")
    }

    #[test]
    fn parses_header_and_rows() {
        let p = LensPrescription::parse(SMALL).unwrap();
        assert_eq!(p.name(), "Test singlet");
        assert_eq!(p.source(), "made up for the tests");
        assert_eq!(p.design_focal_length_mm(), Some(100.0));
        assert_eq!(p.design_f_number(), Some(4.0));
        assert_eq!(p.surfaces().len(), 3);
        assert!(p.surfaces()[0].is_stop);
        assert_eq!(p.surfaces()[1].curvature, 1.0 / 50.0);
        assert_eq!(
            p.surfaces()[1].glass_after,
            Glass::Abbe {
                nd: 1.5168,
                vd: 64.17
            }
        );
        assert_eq!(p.surfaces()[2].thickness_after_mm, 45.0);
        let q: LensPrescription = SMALL.parse().unwrap();
        assert_eq!(p, q);
    }

    #[test]
    fn round_trip_write_then_parse() {
        // Exercise every medium and coating form, and an awkward curvature.
        let p = LensPrescription::parse(SMALL)
            .unwrap()
            .edited(|s| {
                s[1].coating = Some(Coating::quarter_wave(1.38, 550.0).unwrap());
                s[1].curvature = 1.0 / 37.3;
                s[2].glass_after = Glass::Constant(1.0003);
                s.insert(
                    2,
                    LensSurface::new(
                        f64::INFINITY,
                        1.0,
                        Glass::Sellmeier {
                            b: [1.03961212, 0.231792344, 1.01046945],
                            c: [0.00600069867, 0.0200179144, 103.560653],
                        },
                        10.0,
                    ),
                );
            })
            .unwrap();
        let text = p.to_lens_file();
        let q = LensPrescription::parse(&text).unwrap_or_else(|e| panic!("{e}\n{text}"));
        assert_eq!(p, q, "{text}");
        // And the shipped files round-trip too.
        for file in super::super::LENS_FILES {
            let p = LensPrescription::parse(file.1).unwrap();
            assert_eq!(
                LensPrescription::parse(&p.to_lens_file()).unwrap(),
                p,
                "{}",
                file.0
            );
        }
    }

    #[test]
    fn error_names_line_and_field_of_a_bad_semi_aperture() {
        let e = err(&with_line(9, "-50.0  45.0  air  -3"));
        assert_eq!(
            e.to_string(),
            "line 9, field `semi_aperture`: expected a positive number, got `-3`"
        );
    }

    #[test]
    fn each_kind_of_malformed_input_is_typed() {
        let field = |line: usize, text: &str, want: &str| {
            let e = err(&with_line(line, text));
            match &e {
                ParseError::Field { line: l, field, .. } => {
                    assert_eq!((*l, *field), (line, want), "{e}");
                }
                other => panic!("expected a field error on `{want}`, got {other}"),
            }
        };
        field(8, "zero 4.0 1.5 10", "radius");
        field(8, "0 4.0 1.5 10", "radius");
        field(8, "NaN 4.0 1.5 10", "radius");
        field(8, "50 -4.0 1.5 10", "thickness");
        field(8, "50 inf 1.5 10", "thickness");
        field(8, "50 4.0 unobtainium 10", "medium");
        field(8, "50 4.0 1.5/-3 10", "medium");
        field(8, "50 4.0 sellmeier:1,2 10", "medium");
        field(8, "50 4.0 1.5 0", "semi_aperture");
        field(8, "50 4.0 1.5 ten", "semi_aperture");
        field(8, "50 4.0 1.5 10 qw:1.38", "coating");
        field(8, "50 4.0 1.5 10 0.5/100", "coating");
        field(4, "focal_length = -100", "focal_length");
        field(5, "f_number = fast", "f_number");
        field(6, "units = inch", "units");
        field(2, "name =", "name");

        assert!(matches!(
            err(&with_line(8, "50 4.0 1.5")),
            ParseError::FieldCount {
                line: 8,
                count: 3,
                ..
            }
        ));
        assert!(matches!(
            err(&with_line(8, "50 4 1.5 10 none extra")),
            ParseError::FieldCount {
                line: 8,
                count: 6,
                ..
            }
        ));
        assert!(matches!(
            err(&with_line(4, "focal = 100")),
            ParseError::UnknownKey { line: 4, .. }
        ));
        assert!(matches!(
            err(&with_line(4, "name = again")),
            ParseError::DuplicateKey { line: 4, .. }
        ));
        assert!(matches!(
            err(&format!("{SMALL}f_number = 2\n")),
            ParseError::HeaderAfterTable { line: 10, .. }
        ));
        assert!(matches!(
            err(&with_line(2, "# no name")),
            ParseError::MissingKey { key: "name" }
        ));

        // Rows that parse but make an invalid lens name the row's line.
        let e = err(&with_line(7, "inf 2.0 air 5.0"));
        assert!(
            matches!(
                e,
                ParseError::Invalid {
                    line: None,
                    source: PrescriptionError::StopCount { count: 0 }
                }
            ),
            "{e}"
        );
        let e = err(&with_line(8, "5 4.0 1.5 10"));
        assert!(
            matches!(
                e,
                ParseError::Invalid {
                    line: Some(8),
                    source: PrescriptionError::HemispherePlus { surface: 1, .. }
                }
            ),
            "{e}"
        );
        assert!(
            e.to_string().starts_with("line 8: surface 1: |R| = 5 mm"),
            "{e}"
        );
        let e = err(&with_line(8, "50 4.0 3.2 10"));
        assert!(
            matches!(&e, ParseError::Invalid { line: Some(8), source: PrescriptionError::Surface { surface: 1, input } }
                if input.what == "refractive index after the surface at the d line" && input.value == 3.2),
            "{e}"
        );
        assert_eq!(e.line(), Some(8));
        let e = err(&with_line(7, "stop 2.0 1.5 5.0"));
        assert!(matches!(
            e,
            ParseError::Invalid {
                line: Some(7),
                source: PrescriptionError::StopChangesMedium { .. }
            }
        ));
        let e = err("name = empty\n");
        assert!(matches!(
            e,
            ParseError::Invalid {
                source: PrescriptionError::SurfaceCount { count: 0 },
                ..
            }
        ));
    }

    #[test]
    fn a_bare_number_is_always_a_constant_index() {
        // `1.67` used to be the catalog's dispersive spectacle glass 1.67/32
        // while `1.670` was Constant(1.670).
        for (text, want) in [
            ("1.67", Glass::Constant(1.67)),
            ("1.670", Glass::Constant(1.67)),
            ("1.60", Glass::Constant(1.6)),
            ("1.74", Glass::Constant(1.74)),
            ("1.5", Glass::Constant(1.5)),
            ("index-1.67", Glass::Abbe { nd: 1.67, vd: 32.0 }),
            ("INDEX-1.60", Glass::Abbe { nd: 1.60, vd: 41.0 }),
            (
                "CR-39",
                Glass::Abbe {
                    nd: 1.498,
                    vd: 58.0,
                },
            ),
            ("n-bk7", Glass::n_bk7()),
        ] {
            let p = LensPrescription::parse(&with_line(8, &format!("50 4.0 {text} 10"))).unwrap();
            assert_eq!(p.surfaces()[1].glass_after, want, "{text}");
        }
        // Numbers Rust parses but the format does not take are errors, not lookups.
        for text in ["inf", "NaN", "0.9"] {
            assert!(
                matches!(
                    err(&with_line(8, &format!("50 4.0 {text} 10"))),
                    ParseError::Field {
                        line: 8,
                        field: "medium",
                        ..
                    }
                ),
                "{text}"
            );
        }
    }

    #[test]
    fn bad_glass_data_is_rejected_with_line_and_field() {
        // Sellmeier coefficients must be finite and >= 0.
        for text in [
            "sellmeier:-1,0,0,0,0,0",
            "sellmeier:1.04,0.23,1.01,-0.006,0.02,103.6",
            "sellmeier:1,2,3,4,5,nan",
        ] {
            let e = err(&with_line(8, &format!("50 4.0 {text} 10")));
            assert!(
                matches!(
                    e,
                    ParseError::Field {
                        line: 8,
                        field: "medium",
                        ..
                    }
                ),
                "{text}: {e}"
            );
        }
        // 1.5/0.05 is 1.5 at the d line but −2.98 at 700 nm: the row is named.
        let e = err(&with_line(8, "50 4.0 1.5/0.05 10"));
        assert!(
            matches!(
                e,
                ParseError::Invalid {
                    line: Some(8),
                    source: PrescriptionError::IndexOverVisible { surface: 1, .. }
                }
            ),
            "{e}"
        );
        assert!(
            e.to_string()
                .starts_with("line 8: surface 1: refractive index"),
            "{e}"
        );
    }

    #[test]
    fn bytes_that_are_not_text_name_their_line() {
        let mut bytes = SMALL.as_bytes().to_vec();
        assert_eq!(
            LensPrescription::parse_bytes(&bytes).unwrap(),
            LensPrescription::parse(SMALL).unwrap()
        );
        // A byte 0xFF (never UTF-8) in the middle of line 8.
        let at = SMALL.lines().take(7).map(|l| l.len() + 1).sum::<usize>() + 3;
        bytes[at] = 0xFF;
        let e = LensPrescription::parse_bytes(&bytes).unwrap_err();
        assert!(matches!(e, ParseError::NotText { line: 8 }), "{e}");
        assert_eq!(e.to_string(), "line 8: not UTF-8 text");
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(512))]
        /// Random bytes, and the test lens with random lines spliced in,
        /// give a lens or an error naming a line or a missing key, never a
        /// panic.
        #[test]
        fn random_input_is_a_lens_or_a_typed_error(
            bytes in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..400),
            junk in "[ -~]{0,60}",
            at in 0usize..12,
        ) {
            let located = |e: &ParseError| e.line().is_some() || matches!(e, ParseError::MissingKey { .. } | ParseError::Invalid { .. });
            if let Err(e) = LensPrescription::parse_bytes(&bytes) {
                proptest::prop_assert!(located(&e), "{e:?}");
            }
            let mut lines: Vec<&str> = SMALL.lines().collect();
            lines.insert(at.min(lines.len()), &junk);
            if let Err(e) = LensPrescription::parse(&lines.join("\n")) {
                proptest::prop_assert!(located(&e), "{e:?}");
            }
        }
    }

    #[test]
    fn load_reports_missing_file() {
        let e = LensPrescription::load("/nonexistent/optica/lens.lens").unwrap_err();
        assert!(matches!(e, ParseError::Io { .. }));
        assert!(e.to_string().contains("/nonexistent/optica/lens.lens"));
    }

    #[test]
    fn load_reads_a_shipped_file() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("lenses/tessar-us2854889.lens");
        let p = LensPrescription::load(path).unwrap();
        assert_eq!(p.surfaces().len(), 8);
    }
}
