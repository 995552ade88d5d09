//! PLY reading: header parsing, validation against the file's size, and payload decoding.
//!
//! The header is parsed here (not with `ply-rs-bw`'s generic parser) so that every malformed
//! header gives a precise one-line reason, duplicate element or property names are caught, and
//! the payload's byte offset is known exactly. Binary payloads are decoded straight from the
//! bytes: an element without list properties has a fixed record size, so its records are sliced
//! at a fixed stride (the fast path: no per-property callbacks, no intermediate values).
//!
//! Safety against hostile headers: before anything is allocated, the minimum number of bytes every
//! element needs (binary: its records with empty lists; ascii: two bytes per value) is summed with
//! checked arithmetic and compared with the bytes after the header. Capacities are therefore
//! bounded by the file's size, never by a header count alone.
//!
//! An ascii record is one line: a line with more or fewer values than its element's properties
//! (a list: its length, then that many entries) is an error naming the line, so a stray or missing
//! value cannot shift every later value. Anything after the declared elements (ascii: a line that
//! is not blank; binary: any byte, a trailing newline included) is an error too: the header
//! under-counts.

use super::ply::{ElementInfo, PlyInfo};
use crate::cloud::PointCloud;
use crate::error::{Error, Result};
use nalgebra::{Point3, Vector3};
use std::path::Path;

/// Scalar types of the PLY format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    #[default]
    F64,
}

impl Scalar {
    fn parse(s: &str) -> Option<Scalar> {
        Some(match s {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn name(self) -> &'static str {
        match self {
            Scalar::I8 => "char",
            Scalar::U8 => "uchar",
            Scalar::I16 => "short",
            Scalar::U16 => "ushort",
            Scalar::I32 => "int",
            Scalar::U32 => "uint",
            Scalar::F32 => "float",
            Scalar::F64 => "double",
        }
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    fn is_integer(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }

    /// Decodes one value from the start of `b`; `None` if `b` is too short.
    #[inline(always)]
    fn read(self, b: &[u8], be: bool) -> Option<f64> {
        macro_rules! get {
            ($t:ty, $n:literal) => {{
                let a = *b.first_chunk::<$n>()?;
                if be {
                    <$t>::from_be_bytes(a)
                } else {
                    <$t>::from_le_bytes(a)
                }
            }};
        }
        Some(match self {
            Scalar::I8 => f64::from(get!(i8, 1)),
            Scalar::U8 => f64::from(get!(u8, 1)),
            Scalar::I16 => f64::from(get!(i16, 2)),
            Scalar::U16 => f64::from(get!(u16, 2)),
            Scalar::I32 => f64::from(get!(i32, 4)),
            Scalar::U32 => f64::from(get!(u32, 4)),
            Scalar::F32 => f64::from(get!(f32, 4)),
            Scalar::F64 => get!(f64, 8),
        })
    }

    /// Parses one ascii token as this type (floats at their declared precision).
    fn parse_token(self, t: &str) -> Option<f64> {
        Some(match self {
            Scalar::I8 => f64::from(t.parse::<i8>().ok()?),
            Scalar::U8 => f64::from(t.parse::<u8>().ok()?),
            Scalar::I16 => f64::from(t.parse::<i16>().ok()?),
            Scalar::U16 => f64::from(t.parse::<u16>().ok()?),
            Scalar::I32 => f64::from(t.parse::<i32>().ok()?),
            Scalar::U32 => f64::from(t.parse::<u32>().ok()?),
            Scalar::F32 => f64::from(t.parse::<f32>().ok()?),
            Scalar::F64 => t.parse::<f64>().ok()?,
        })
    }
}

/// A property's type: one scalar, or a list with its count and item types.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Scalar(Scalar),
    List(Scalar, Scalar),
}

#[derive(Debug, Clone)]
struct Property {
    name: String,
    kind: Kind,
}

impl Property {
    fn describe(&self) -> String {
        match self.kind {
            Kind::Scalar(s) => format!("{} {}", s.name(), self.name),
            Kind::List(c, i) => format!("list {} {} {}", c.name(), i.name(), self.name),
        }
    }
}

#[derive(Debug, Clone)]
struct Element {
    name: String,
    count: u64,
    props: Vec<Property>,
}

impl Element {
    /// Record size when the element has no lists.
    fn fixed_stride(&self) -> Option<usize> {
        self.props
            .iter()
            .map(|p| match p.kind {
                Kind::Scalar(s) => Some(s.size()),
                Kind::List(..) => None,
            })
            .sum()
    }

    /// Smallest binary record (every list empty).
    fn min_binary_record(&self) -> u64 {
        self.props
            .iter()
            .map(|p| match p.kind {
                Kind::Scalar(s) | Kind::List(s, _) => s.size() as u64,
            })
            .sum()
    }

    fn find(&self, name: &str) -> Option<(usize, &Property)> {
        self.props.iter().enumerate().find(|(_, p)| p.name == name)
    }
}

/// The payload encoding named in the header.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Encoding {
    Ascii,
    BinaryLe,
    BinaryBe,
}

impl Encoding {
    fn name(self) -> &'static str {
        match self {
            Encoding::Ascii => "ascii",
            Encoding::BinaryLe => "binary_little_endian",
            Encoding::BinaryBe => "binary_big_endian",
        }
    }
}

struct Header {
    encoding: Encoding,
    elements: Vec<Element>,
    payload_start: usize,
}

/// Parses the header; `bytes` is the whole file. Errors are bare reasons (the caller adds the path).
fn parse_header(bytes: &[u8]) -> std::result::Result<Header, String> {
    let mut pos = 0usize;
    let next_line = |pos: &mut usize| -> Option<String> {
        if *pos >= bytes.len() {
            return None;
        }
        let rest = &bytes[*pos..];
        let end = rest.iter().position(|&b| b == b'\n');
        let (line, adv) = match end {
            Some(e) => (&rest[..e], e + 1),
            None => (rest, rest.len()),
        };
        *pos += adv;
        Some(String::from_utf8_lossy(line).trim_end_matches('\r').to_string())
    };
    match next_line(&mut pos) {
        None => return Err("empty file: no 'ply' magic line".into()),
        Some(l) if l.trim_end() == "ply" => {}
        Some(l) => {
            let shown: String = l.chars().take(20).collect();
            return Err(format!(
                "not a PLY file: bad magic (first line is '{}', expected 'ply')",
                shown.escape_default()
            ));
        }
    }
    let mut encoding = None;
    let mut elements: Vec<Element> = Vec::new();
    let mut line_no = 1usize;
    loop {
        let Some(line) = next_line(&mut pos) else {
            return Err("missing 'end_header': the header never ends".into());
        };
        line_no += 1;
        let at = |m: String| format!("header line {line_no}: {m}");
        let mut words = line.split_ascii_whitespace();
        let Some(keyword) = words.next() else {
            continue; // blank lines are tolerated
        };
        let rest: Vec<&str> = words.collect();
        match keyword {
            "end_header" if rest.is_empty() => break,
            "end_header" => {
                return Err(at(format!(
                    "'end_header' followed by '{}' on its line",
                    rest.join(" ").escape_default()
                )));
            }
            "comment" | "obj_info" => {}
            "format" => {
                if encoding.is_some() {
                    return Err(at("a second 'format' line".into()));
                }
                let enc = match rest.first().copied() {
                    Some("ascii") => Encoding::Ascii,
                    Some("binary_little_endian") => Encoding::BinaryLe,
                    Some("binary_big_endian") => Encoding::BinaryBe,
                    other => {
                        return Err(at(format!(
                            "unknown format '{}' (expected ascii, binary_little_endian or binary_big_endian)",
                            other.unwrap_or("").escape_default()
                        )));
                    }
                };
                match rest.get(1) {
                    Some(v) if v.parse::<f64>() == Ok(1.0) => {}
                    v => {
                        return Err(at(format!(
                            "unsupported format version '{}' (expected 1.0)",
                            v.unwrap_or(&"").escape_default()
                        )));
                    }
                }
                if rest.len() > 2 {
                    return Err(at(format!(
                        "malformed format line '{}' (expected 'format ENCODING 1.0')",
                        line.escape_default()
                    )));
                }
                encoding = Some(enc);
            }
            "element" => {
                let [name, count] = rest[..] else {
                    return Err(at(format!(
                        "malformed element line '{}' (expected 'element NAME COUNT')",
                        line.escape_default()
                    )));
                };
                let count: u64 = count.parse().map_err(|_| {
                    at(format!(
                        "element '{name}' count '{}' is not a non-negative integer",
                        count.escape_default()
                    ))
                })?;
                if elements.iter().any(|e| e.name == name) {
                    return Err(at(format!("duplicate element '{name}'")));
                }
                elements.push(Element {
                    name: name.to_string(),
                    count,
                    props: Vec::new(),
                });
            }
            "property" => {
                let Some(el) = elements.last_mut() else {
                    return Err(at("property before any element".into()));
                };
                let ty = |s: &str| {
                    Scalar::parse(s)
                        .ok_or_else(|| at(format!("unknown property type '{}'", s.escape_default())))
                };
                let (kind, name) = match rest[..] {
                    ["list", c, i, name] => {
                        let c = ty(c)?;
                        if !c.is_integer() {
                            return Err(at(format!(
                                "list '{name}' has a non-integer count type '{}'",
                                c.name()
                            )));
                        }
                        (Kind::List(c, ty(i)?), name)
                    }
                    [t, name] if t != "list" => (Kind::Scalar(ty(t)?), name),
                    _ => {
                        return Err(at(format!("malformed property line '{}'", line.escape_default())));
                    }
                };
                if el.find(name).is_some() {
                    return Err(at(format!(
                        "duplicate property '{name}' in element '{}'",
                        el.name
                    )));
                }
                el.props.push(Property {
                    name: name.to_string(),
                    kind,
                });
            }
            other if other.starts_with(|c: char| c.is_ascii_digit() || "+-.".contains(c)) => {
                let shown: String = line.chars().take(24).collect();
                return Err(format!(
                    "missing 'end_header': header line {line_no} looks like data ('{}')",
                    shown.escape_default()
                ));
            }
            other => {
                let shown: String = other.chars().take(24).collect();
                return Err(at(format!("unknown header keyword '{}'", shown.escape_default())));
            }
        }
    }
    let encoding = encoding.ok_or("the header has no 'format' line")?;
    Ok(Header {
        encoding,
        elements,
        payload_start: pos,
    })
}

/// Rejects headers whose element counts the payload cannot hold, before any allocation.
fn check_counts(h: &Header, payload_len: usize) -> std::result::Result<(), String> {
    let avail = payload_len as u128;
    let mut needed: u128 = 0;
    for e in &h.elements {
        let (per_record, unit, causes) = match h.encoding {
            Encoding::Ascii => (
                2 * e.props.len() as u128,
                "bytes of text",
                "truncated file, impossible count, or lines with fewer values than the properties",
            ),
            _ => (
                u128::from(e.min_binary_record()),
                "bytes",
                "truncated file or impossible count",
            ),
        };
        needed += u128::from(e.count) * per_record;
        // An ascii file's last value needs no separator.
        let slack = u128::from(h.encoding == Encoding::Ascii);
        if needed > avail + slack {
            return Err(format!(
                "payload too short: element '{}' declares {} records of at least {} {unit} each, \
                 but only {} bytes follow the header ({causes})",
                e.name, e.count, per_record, payload_len
            ));
        }
    }
    Ok(())
}

/// What to do with the `face` element.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Faces {
    /// Skip it (its records are still walked, so a truncated payload is caught).
    Skip,
    /// Read and validate it: indices in range, polygons fan-triangulated.
    Read,
}

/// Everything a PLY file holds that uvms uses.
pub(crate) struct Parsed {
    pub cloud: PointCloud,
    /// Triangles (fan-triangulated polygons), indices into `cloud.points`; empty when faces were
    /// skipped or the file has none.
    pub triangles: Vec<[u32; 3]>,
    pub info: PlyInfo,
    pub has_face_element: bool,
}

/// Where the vertex attributes sit in a record.
#[derive(Default, Clone, Copy)]
struct VertexLayout {
    xyz: [(usize, Scalar); 3],
    rgb: Option<[(usize, Scalar); 3]>,
    nxyz: Option<[(usize, Scalar); 3]>,
}

/// Colour scaling: uchar as is, ushort / 257, float or double in [0, 1] times 255 (rounded,
/// clamped).
#[inline]
fn colour(v: f64, s: Scalar) -> u8 {
    let c = match s {
        Scalar::U8 => v,
        Scalar::U16 => v / 257.0,
        _ => v * 255.0,
    };
    // `as` saturates and maps NaN to 0.
    c.round().clamp(0.0, 255.0) as u8
}

fn vertex_layout(e: &Element) -> std::result::Result<VertexLayout, String> {
    let find3 = |names: [&str; 3]| names.map(|n| e.find(n));
    let mut layout = VertexLayout::default();
    for (slot, found) in find3(["x", "y", "z"]).into_iter().enumerate() {
        let Some((i, p)) = found else {
            return Err(format!(
                "element 'vertex' has no '{}' property",
                ["x", "y", "z"][slot]
            ));
        };
        match p.kind {
            Kind::Scalar(s @ (Scalar::F32 | Scalar::F64)) => layout.xyz[slot] = (i, s),
            _ => {
                return Err(format!(
                    "vertex property '{}' has unsupported type '{}' (x, y, z must be float or double)",
                    p.name,
                    p.describe().rsplit_once(' ').map_or("", |(t, _)| t)
                ));
            }
        }
    }
    let typed = |names: [&str; 3], ok: &[Scalar], what: &str| -> std::result::Result<_, String> {
        let f = find3(names);
        if f.iter().any(Option::is_none) {
            return Ok(None);
        }
        let mut out = [(0usize, Scalar::U8); 3];
        for (slot, (i, p)) in f.into_iter().flatten().enumerate() {
            match p.kind {
                Kind::Scalar(s) if ok.contains(&s) => out[slot] = (i, s),
                _ => {
                    return Err(format!(
                        "vertex property '{}' has unsupported type '{}' for {what}",
                        p.name,
                        p.describe().rsplit_once(' ').map_or("", |(t, _)| t)
                    ));
                }
            }
        }
        Ok(Some(out))
    };
    layout.rgb = typed(
        ["red", "green", "blue"],
        &[Scalar::U8, Scalar::U16, Scalar::F32, Scalar::F64],
        "colours (uchar, ushort, float or double)",
    )?;
    layout.nxyz = typed(
        ["nx", "ny", "nz"],
        &[Scalar::F32, Scalar::F64],
        "normals (float or double)",
    )?;
    Ok(layout)
}

/// Accumulates decoded vertices, dropping non-finite positions.
struct Vertices {
    layout: VertexLayout,
    points: Vec<Point3<f64>>,
    colors: Option<Vec<[u8; 3]>>,
    normals: Option<Vec<Vector3<f64>>>,
    /// Old index -> new index (`u32::MAX` = dropped); filled only once a point is dropped.
    remap: Vec<u32>,
    read: usize,
    dropped: usize,
}

impl Vertices {
    fn new(layout: VertexLayout, capacity: usize) -> Self {
        Vertices {
            layout,
            points: Vec::with_capacity(capacity),
            colors: layout.rgb.map(|_| Vec::with_capacity(capacity)),
            normals: layout.nxyz.map(|_| Vec::with_capacity(capacity)),
            remap: Vec::new(),
            read: 0,
            dropped: 0,
        }
    }

    /// Decodes one record's attributes; `at(property index)` is the byte slice starting at that
    /// property (binary), `None` if the record is short.
    #[inline(always)]
    fn decode<'b>(
        &self,
        be: bool,
        at: impl Fn(usize) -> Option<&'b [u8]>,
    ) -> Option<(Point3<f64>, [u8; 3], Vector3<f64>)> {
        let l = &self.layout;
        let rd = |(k, s): (usize, Scalar)| s.read(at(k)?, be);
        let p = Point3::new(rd(l.xyz[0])?, rd(l.xyz[1])?, rd(l.xyz[2])?);
        let mut c = [0u8; 3];
        if let Some(rgb) = l.rgb {
            for (c, (k, s)) in c.iter_mut().zip(rgb) {
                *c = match s {
                    Scalar::U8 => *at(k)?.first()?,
                    _ => colour(s.read(at(k)?, be)?, s),
                };
            }
        }
        let mut n = Vector3::zeros();
        if let Some(nxyz) = l.nxyz {
            n = Vector3::new(rd(nxyz[0])?, rd(nxyz[1])?, rd(nxyz[2])?);
        }
        Some((p, c, n))
    }

    /// Adds one record (colour and normal ignored when the cloud has none).
    #[inline(always)]
    fn push(&mut self, (p, c, n): (Point3<f64>, [u8; 3], Vector3<f64>)) {
        let index = self.read;
        self.read += 1;
        if !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite()) {
            if self.dropped == 0 {
                self.remap = (0..index as u32).collect();
            }
            self.dropped += 1;
            self.remap.push(u32::MAX);
            return;
        }
        if self.dropped > 0 {
            self.remap.push(self.points.len() as u32);
        }
        self.points.push(p);
        if let Some(cs) = &mut self.colors {
            cs.push(c);
        }
        if let Some(ns) = &mut self.normals {
            ns.push(n);
        }
    }

    /// New index of old vertex `i`, `None` if it was dropped or out of range.
    fn new_index(&self, i: u64) -> Option<u32> {
        if self.dropped == 0 {
            return u32::try_from(i).ok().filter(|&i| (i as usize) < self.read);
        }
        let j = *self.remap.get(usize::try_from(i).ok()?)?;
        (j != u32::MAX).then_some(j)
    }
}

/// Accumulates triangles from polygons.
struct FaceSink {
    triangles: Vec<[u32; 3]>,
    polygon: Vec<u64>,
    dropped: usize,
}

impl FaceSink {
    fn finish_polygon(&mut self, verts: &Vertices, face: u64) -> std::result::Result<(), String> {
        let n = self.polygon.len();
        if n < 3 {
            return Err(format!(
                "face {face} has {n} vertex indices; a polygon needs at least 3 (impossible list length)"
            ));
        }
        for &i in &self.polygon {
            if i >= verts.read as u64 {
                return Err(format!(
                    "face {face} has vertex index {i} out of range (the file has {} vertices)",
                    verts.read
                ));
            }
        }
        for k in 1..n - 1 {
            let tri = [self.polygon[0], self.polygon[k], self.polygon[k + 1]].map(|i| verts.new_index(i));
            match tri {
                [Some(a), Some(b), Some(c)] => self.triangles.push([a, b, c]),
                _ => self.dropped += 1,
            }
        }
        Ok(())
    }
}

fn truncated(e: &Element, record: u64) -> String {
    format!(
        "truncated payload: element '{}' ends after {record} of {} records",
        e.name, e.count
    )
}

/// Binary payload walker.
struct Binary<'a> {
    data: &'a [u8],
    pos: usize,
    be: bool,
}

impl Binary<'_> {
    /// Walks one record of a list-bearing element, calling `on_scalar(prop, offset)` for scalars
    /// and `on_list(prop, count, items offset)` for lists. `None` when the data ends.
    fn walk_record(
        &mut self,
        e: &Element,
        record: u64,
        mut on_scalar: impl FnMut(usize, usize),
        mut on_list: impl FnMut(usize, u64, usize) -> std::result::Result<(), String>,
    ) -> std::result::Result<(), String> {
        for (k, p) in e.props.iter().enumerate() {
            match p.kind {
                Kind::Scalar(s) => {
                    on_scalar(k, self.pos);
                    self.pos += s.size();
                }
                Kind::List(c, item) => {
                    let n = c
                        .read(self.data.get(self.pos..).unwrap_or_default(), self.be)
                        .ok_or_else(|| truncated(e, record))?;
                    let n = list_len(n, e, record)?;
                    self.pos += c.size();
                    let bytes = n.saturating_mul(item.size() as u64);
                    let left = self.data.len().saturating_sub(self.pos) as u64;
                    if bytes > left {
                        // Longer than the whole payload: the count itself is wrong; otherwise
                        // the file was cut short.
                        let what = if bytes > self.data.len() as u64 {
                            "impossible list length"
                        } else {
                            "truncated payload: list length"
                        };
                        return Err(format!(
                            "{what} {n} in record {record} of element '{}' ('{}' needs {bytes} bytes, {left} remain)",
                            e.name, p.name
                        ));
                    }
                    on_list(k, n, self.pos)?;
                    self.pos += bytes as usize;
                }
            }
            if self.pos > self.data.len() {
                return Err(truncated(e, record));
            }
        }
        Ok(())
    }

    /// After the last element (`last`): any byte left over is an error, but for a line break
    /// (`\n` or `\r\n`) that a writer may end the file with.
    fn finish(&self, last: Option<&Element>) -> std::result::Result<(), String> {
        let rest = self.data.get(self.pos..).unwrap_or_default();
        let extra = rest.len();
        if matches!(rest, b"" | b"\n" | b"\r\n") {
            return Ok(());
        }
        let shown = &rest[..extra.min(8)];
        let more = if extra > 8 { "..." } else { "" };
        let records = last
            .and_then(|e| Some((e, e.fixed_stride()?)))
            .filter(|&(_, stride)| stride > 0 && extra.is_multiple_of(stride))
            .map_or(String::new(), |(e, stride)| {
                format!(", enough for {} more '{}' records", extra / stride, e.name)
            });
        Err(format!(
            "{} after the declared elements ('{}{more}'; the elements take {} of the {} payload bytes{records}): \
             does the header under-count?",
            plural(extra as u64, "byte", "bytes"),
            shown.escape_ascii(),
            self.pos,
            self.data.len()
        ))
    }
}

/// Ascii payload walker: every record is one line (blank lines are skipped).
struct Ascii<'a> {
    data: &'a [u8],
    pos: usize,
    /// Line number in the file of the line last taken (the header's lines counted).
    line: usize,
}

/// The values of one line, split at ascii whitespace.
struct Fields<'a> {
    rest: &'a [u8],
    /// Values taken so far.
    taken: u64,
}

impl<'a> Fields<'a> {
    #[inline]
    fn next(&mut self) -> Option<&'a [u8]> {
        let Some(start) = self.rest.iter().position(|b| !b.is_ascii_whitespace()) else {
            self.rest = &[];
            return None;
        };
        let rest = &self.rest[start..];
        let end = rest
            .iter()
            .position(u8::is_ascii_whitespace)
            .unwrap_or(rest.len());
        self.rest = &rest[end..];
        self.taken += 1;
        Some(&rest[..end])
    }
}

fn plural(n: u64, one: &str, many: &str) -> String {
    format!("{n} {}", if n == 1 { one } else { many })
}

impl<'a> Ascii<'a> {
    /// The next line that is not blank, without its line break; `None` at the end of the data.
    fn next_line(&mut self) -> Option<&'a [u8]> {
        let d = self.data;
        while self.pos < d.len() {
            let rest = &d[self.pos..];
            let len = rest.iter().position(|&b| b == b'\n').unwrap_or(rest.len());
            self.pos += (len + 1).min(rest.len());
            self.line += 1;
            let line = &rest[..len];
            if !line.iter().all(u8::is_ascii_whitespace) {
                return Some(line);
            }
        }
        None
    }

    /// Reads record `r` of `e`: one line holding exactly its values (a list: its length, then that
    /// many entries). Scalars are parsed at their declared type and stored in `scalars[k]` when
    /// `scalars` has a slot `k`; the entries of list property `keep.0` are parsed into `keep.1`;
    /// the entries of other lists are only counted.
    fn record(
        &mut self,
        e: &Element,
        r: u64,
        scalars: &mut [f64],
        mut keep: Option<(usize, &mut Vec<f64>)>,
    ) -> std::result::Result<(), String> {
        if e.props.is_empty() {
            return Ok(()); // nothing to read: a blank line at most
        }
        let line = self.next_line().ok_or_else(|| truncated(e, r))?;
        let mut f = Fields { rest: line, taken: 0 };
        // One value per property, plus the entries of the lists whose length is known.
        let mut expected = e.props.len() as u64;
        let mut last_list = None;
        for (k, p) in e.props.iter().enumerate() {
            match p.kind {
                Kind::Scalar(s) => {
                    let t = f
                        .next()
                        .ok_or_else(|| self.short(e, r, f.taken, expected, k, None))?;
                    let v = self.parse(t, s, e, r, p)?;
                    if let Some(slot) = scalars.get_mut(k) {
                        *slot = v;
                    }
                }
                Kind::List(c, item) => {
                    let t = f
                        .next()
                        .ok_or_else(|| self.short(e, r, f.taken, expected, k, None))?;
                    let n = list_len(self.parse(t, c, e, r, p)?, e, r)?;
                    expected = expected.saturating_add(n);
                    let mut out = match &mut keep {
                        Some((kept, buf)) if *kept == k => {
                            buf.clear();
                            Some(&mut **buf)
                        }
                        _ => None,
                    };
                    for got in 0..n {
                        let t = f
                            .next()
                            .ok_or_else(|| self.short(e, r, f.taken, expected, k, Some((n, got))))?;
                        if let Some(buf) = out.as_mut() {
                            buf.push(self.parse(t, item, e, r, p)?);
                        }
                    }
                    last_list = Some((p, n));
                }
            }
        }
        if f.next().is_some() {
            while f.next().is_some() {}
            let why = last_list.map_or(String::new(), |(p, n)| {
                format!(" (list '{}' declares length {n})", p.name)
            });
            return Err(format!(
                "line {}: record {r} of element '{}' has {}, expected {expected}{why}",
                self.line,
                e.name,
                plural(f.taken, "value", "values")
            ));
        }
        Ok(())
    }

    /// The error for record `r`'s line ending too soon: before property `k`, or inside list `k`
    /// after `got` of its `n` entries (`list = Some((n, got))`). When nothing but whitespace
    /// follows the line, the file was cut short: a truncated payload.
    fn short(
        &self,
        e: &Element,
        r: u64,
        found: u64,
        expected: u64,
        k: usize,
        list: Option<(u64, u64)>,
    ) -> String {
        let p = &e.props[k];
        // A list whose length is still unknown makes the expected count a lower bound.
        let unknown = e.props[k + usize::from(list.is_some())..]
            .iter()
            .any(|p| matches!(p.kind, Kind::List(..)));
        let at_least = if unknown { "at least " } else { "" };
        let why = match list {
            None => format!("no value for '{}'", p.name),
            Some((n, got)) => format!(
                "list '{}' declares length {n} but {} follow",
                p.name,
                plural(got, "entry", "entries")
            ),
        };
        let has = format!(
            "{}, expected {at_least}{expected} ({why})",
            plural(found, "value", "values")
        );
        if self.data[self.pos..].iter().all(u8::is_ascii_whitespace) {
            format!(
                "{}: the file ends after line {}, which has {has}",
                truncated(e, r),
                self.line
            )
        } else {
            format!("line {}: record {r} of element '{}' has {has}", self.line, e.name)
        }
    }

    /// Parses value `t` of property `p` (record `r` of `e`) as `s`.
    fn parse(
        &self,
        t: &[u8],
        s: Scalar,
        e: &Element,
        r: u64,
        p: &Property,
    ) -> std::result::Result<f64, String> {
        let t = std::str::from_utf8(t).unwrap_or("\u{fffd}");
        s.parse_token(t).ok_or_else(|| {
            let shown: String = t.chars().take(24).collect();
            format!(
                "line {}: '{}' is not a valid {} for property '{}' of element '{}' (record {r})",
                self.line,
                shown.escape_default(),
                s.name(),
                p.name,
                e.name
            )
        })
    }

    /// After the last element: anything but whitespace left over is an error.
    fn finish(&mut self) -> std::result::Result<(), String> {
        let Some(first) = self.next_line() else {
            return Ok(());
        };
        let at = self.line;
        let mut n = 1u64;
        while self.next_line().is_some() {
            n += 1;
        }
        let shown: String = String::from_utf8_lossy(first).trim().chars().take(24).collect();
        Err(format!(
            "{} after the declared elements (the first is line {at}: '{}'): does the header under-count?",
            plural(n, "more line", "more lines"),
            shown.escape_default()
        ))
    }
}

/// Reads a PLY file. Errors name `path` and the problem.
pub(crate) fn read(path: &Path, faces: Faces) -> Result<Parsed> {
    crate::config::regular_file(path, "a PLY file")?;
    let fail = |reason: String| Error::input(path.display(), reason);
    let bytes = std::fs::read(path).map_err(|e| fail(format!("cannot read: {e}")))?;
    parse(&bytes, faces).map_err(fail)
}

/// Parses a whole PLY file held in memory.
pub(crate) fn parse(bytes: &[u8], faces: Faces) -> std::result::Result<Parsed, String> {
    let h = parse_header(bytes)?;
    let payload = &bytes[h.payload_start..];
    check_counts(&h, payload.len())?;
    let vertex_el = h
        .elements
        .iter()
        .find(|e| e.name == "vertex")
        .ok_or("the header declares no 'vertex' element")?;
    let layout = vertex_layout(vertex_el)?;
    let face_el = h.elements.iter().find(|e| e.name == "face");
    let face_list = match face_el {
        Some(e) if faces == Faces::Read => {
            let found = e.find("vertex_indices").or_else(|| e.find("vertex_index"));
            let Some((k, p)) = found else {
                return Err("element 'face' has no 'vertex_indices' or 'vertex_index' list".into());
            };
            match p.kind {
                Kind::List(_, item) if item.is_integer() => Some(k),
                _ => {
                    return Err(format!(
                        "face property '{}' must be a list of integers, not '{}'",
                        p.name,
                        p.describe()
                    ));
                }
            }
        }
        _ => None,
    };
    // Bounded by check_counts: at most payload bytes / (record size) records.
    let cap = |e: &Element, min_record: usize| -> usize {
        (e.count as usize).min(payload.len() / min_record.max(1))
    };
    let mut verts: Option<Vertices> = None;
    let mut sink = FaceSink {
        triangles: Vec::new(),
        polygon: Vec::new(),
        dropped: 0,
    };
    let ascii = h.encoding == Encoding::Ascii;
    let mut bin = Binary {
        data: payload,
        pos: 0,
        be: h.encoding == Encoding::BinaryBe,
    };
    let mut txt = Ascii {
        data: payload,
        pos: 0,
        // The payload starts on the line after `end_header`.
        line: if ascii {
            bytes[..h.payload_start].iter().filter(|&&b| b == b'\n').count()
        } else {
            0
        },
    };
    for e in &h.elements {
        let is_vertex = std::ptr::eq(e, vertex_el);
        let is_face = face_list.is_some() && face_el.is_some_and(|f| std::ptr::eq(e, f));
        if is_face && verts.is_none() {
            return Err("element 'face' comes before element 'vertex'".into());
        }
        if is_vertex {
            let min = if ascii {
                2 * e.props.len()
            } else {
                e.min_binary_record() as usize
            };
            let mut v = Vertices::new(layout, cap(e, min));
            if ascii {
                read_vertices_ascii(&mut txt, e, &mut v)?;
            } else {
                read_vertices_binary(&mut bin, e, &mut v)?;
            }
            verts = Some(v);
        } else if is_face {
            let (Some(k), Some(v)) = (face_list, verts.as_ref()) else {
                continue;
            };
            let min_face = match e.props.get(k).map(|p| p.kind) {
                Some(Kind::List(c, i)) if !ascii => c.size() + 3 * i.size(),
                _ => 8,
            };
            sink.triangles.reserve(cap(e, min_face));
            if ascii {
                read_faces_ascii(&mut txt, e, k, v, &mut sink)?;
            } else {
                read_faces_binary(&mut bin, e, k, v, &mut sink)?;
            }
        } else if ascii {
            skip_ascii(&mut txt, e)?;
        } else {
            skip_binary(&mut bin, e)?;
        }
    }
    if ascii {
        txt.finish()?;
    } else {
        bin.finish(h.elements.last())?;
    }
    let v = verts.ok_or("the header declares no 'vertex' element")?;
    let cloud = PointCloud {
        points: v.points,
        colors: v.colors,
        normals: v.normals,
    };
    let bbox = cloud.bbox();
    let info = PlyInfo {
        encoding: h.encoding.name().to_string(),
        vertices_in_header: vertex_el.count,
        points: cloud.len(),
        non_finite_dropped: v.dropped,
        faces: face_el.map_or(0, |f| f.count),
        triangles: (faces == Faces::Read).then_some(sink.triangles.len()),
        triangles_dropped: sink.dropped,
        has_colors: cloud.colors.is_some(),
        has_normals: cloud.normals.is_some(),
        elements: h
            .elements
            .iter()
            .map(|e| ElementInfo {
                name: e.name.clone(),
                count: e.count,
                properties: e.props.iter().map(Property::describe).collect(),
            })
            .collect(),
        bbox_min: bbox.map(|b| [b.0.x, b.0.y, b.0.z]),
        bbox_max: bbox.map(|b| [b.1.x, b.1.y, b.1.z]),
    };
    Ok(Parsed {
        cloud,
        triangles: sink.triangles,
        info,
        has_face_element: face_el.is_some(),
    })
}

fn read_vertices_binary(bin: &mut Binary, e: &Element, v: &mut Vertices) -> std::result::Result<(), String> {
    let be = bin.be;
    if let Some(stride) = e.fixed_stride() {
        // Fast path: fixed-size records, sliced at a fixed stride.
        let mut offsets = Vec::with_capacity(e.props.len());
        let mut o = 0;
        for p in &e.props {
            offsets.push(o);
            if let Kind::Scalar(s) = p.kind {
                o += s.size();
            }
        }
        let avail = (bin.data.len() - bin.pos) / stride.max(1);
        let n = usize::try_from(e.count).unwrap_or(usize::MAX).min(avail);
        let data = &bin.data[bin.pos..bin.pos + n * stride];
        for rec in data.chunks_exact(stride) {
            let rec_values = v
                .decode(be, |k| rec.get(*offsets.get(k)?..))
                .ok_or_else(|| truncated(e, v.read as u64))?;
            v.push(rec_values);
        }
        bin.pos += n * stride;
        if (n as u64) < e.count {
            return Err(truncated(e, n as u64));
        }
        return Ok(());
    }
    let mut at = vec![0usize; e.props.len()];
    for r in 0..e.count {
        bin.walk_record(e, r, |k, o| at[k] = o, |_, _, _| Ok(()))?;
        let data = bin.data;
        let rec_values = v
            .decode(be, |k| data.get(*at.get(k)?..))
            .ok_or_else(|| truncated(e, r))?;
        v.push(rec_values);
    }
    Ok(())
}

fn read_vertices_ascii(txt: &mut Ascii, e: &Element, v: &mut Vertices) -> std::result::Result<(), String> {
    // Values are parsed at their declared type (a `float` as f32), then widened to f64.
    let mut vals = vec![0.0f64; e.props.len()];
    let l = v.layout;
    for r in 0..e.count {
        txt.record(e, r, &mut vals, None)?;
        let get = |(k, _): (usize, Scalar)| vals[k];
        let p = Point3::new(get(l.xyz[0]), get(l.xyz[1]), get(l.xyz[2]));
        let c = l.rgb.map_or([0; 3], |a| a.map(|(k, s)| colour(vals[k], s)));
        let n = l.nxyz.map_or(Vector3::zeros(), |a| {
            Vector3::new(get(a[0]), get(a[1]), get(a[2]))
        });
        v.push((p, c, n));
    }
    Ok(())
}

/// A list's length as read (binary or ascii); negative is impossible.
fn list_len(n: f64, e: &Element, r: u64) -> std::result::Result<u64, String> {
    if n < 0.0 {
        return Err(format!(
            "impossible list length {n} in record {r} of element '{}' (negative)",
            e.name
        ));
    }
    Ok(n as u64)
}

/// A face's vertex index as read (binary or ascii); negative is out of range.
fn face_index(x: f64, face: u64) -> std::result::Result<u64, String> {
    if x < 0.0 {
        return Err(format!(
            "face {face} has vertex index {x} out of range (negative)"
        ));
    }
    Ok(x as u64)
}

fn skip_ascii(txt: &mut Ascii, e: &Element) -> std::result::Result<(), String> {
    for r in 0..e.count {
        txt.record(e, r, &mut [], None)?;
    }
    Ok(())
}

fn skip_binary(bin: &mut Binary, e: &Element) -> std::result::Result<(), String> {
    if let Some(stride) = e.fixed_stride() {
        let bytes = e.count.saturating_mul(stride as u64);
        let left = (bin.data.len() - bin.pos) as u64;
        if bytes > left {
            return Err(truncated(e, left / stride.max(1) as u64));
        }
        bin.pos += bytes as usize;
        return Ok(());
    }
    for r in 0..e.count {
        bin.walk_record(e, r, |_, _| {}, |_, _, _| Ok(()))?;
    }
    Ok(())
}

fn read_faces_binary(
    bin: &mut Binary,
    e: &Element,
    list: usize,
    v: &Vertices,
    sink: &mut FaceSink,
) -> std::result::Result<(), String> {
    let Some(Kind::List(_, item)) = e.props.get(list).map(|p| p.kind) else {
        return Err("internal: face list property missing".into());
    };
    let (data, be) = (bin.data, bin.be);
    for r in 0..e.count {
        bin.walk_record(
            e,
            r,
            |_, _| {},
            |k, n, at| {
                if k != list {
                    return Ok(());
                }
                sink.polygon.clear();
                for j in 0..n as usize {
                    let x = item
                        .read(data.get(at + j * item.size()..).unwrap_or_default(), be)
                        .ok_or_else(|| truncated(e, r))?;
                    sink.polygon.push(face_index(x, r)?);
                }
                sink.finish_polygon(v, r)
            },
        )?;
    }
    Ok(())
}

fn read_faces_ascii(
    txt: &mut Ascii,
    e: &Element,
    list: usize,
    v: &Vertices,
    sink: &mut FaceSink,
) -> std::result::Result<(), String> {
    let mut entries = Vec::new();
    for r in 0..e.count {
        txt.record(e, r, &mut [], Some((list, &mut entries)))?;
        sink.polygon.clear();
        for &x in &entries {
            sink.polygon.push(face_index(x, r)?);
        }
        sink.finish_polygon(v, r)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ascii_file(body: &str) -> Vec<u8> {
        body.as_bytes().to_vec()
    }

    /// A little binary file: header text + payload bytes.
    fn binary(header: &str, payload: &[u8]) -> Vec<u8> {
        let mut b = header.as_bytes().to_vec();
        b.extend_from_slice(payload);
        b
    }

    #[test]
    fn ascii_quad_is_fan_triangulated_and_nan_vertex_dropped() {
        let f = ascii_file(
            "ply\nformat ascii 1.0\ncomment x\nelement vertex 5\nproperty float x\nproperty float y\n\
             property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n\
             element face 2\nproperty list uchar int vertex_indices\nend_header\n\
             0 0 0 1 2 3\n1 0 0 4 5 6\nnan 0 0 7 8 9\n1 1 0 10 11 12\n0 1 0 13 14 15\n\
             4 0 1 3 4\n3 0 1 2\n",
        );
        let p = parse(&f, Faces::Read).unwrap();
        assert_eq!(p.cloud.len(), 4);
        assert_eq!(p.info.non_finite_dropped, 1);
        assert_eq!(p.cloud.points[2], Point3::new(1.0, 1.0, 0.0));
        assert_eq!(p.cloud.colors.as_ref().unwrap()[2], [10, 11, 12]);
        // Quad (0,1,3,4) -> (0,1,3), (0,3,4); old 3, 4 are new 2, 3. Triangle (0,1,2) uses the
        // dropped vertex 2.
        assert_eq!(p.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(p.info.triangles_dropped, 1);
        assert_eq!(p.info.faces, 2);
        assert_eq!(p.info.bbox_max, Some([1.0, 1.0, 0.0]));
    }

    #[test]
    fn binary_big_and_little_endian_agree_with_values() {
        let head = |enc: &str| {
            format!(
                "ply\nformat {enc} 1.0\nelement vertex 2\nproperty double x\nproperty float y\n\
                 property short junk\nproperty double z\nproperty float nx\nproperty float ny\n\
                 property float nz\nend_header\n"
            )
        };
        let vals = [(0.25f64, -1.5f32, 7i16, 3.0f64), (1e-3, 2.0, -1, -4.5)];
        for be in [false, true] {
            let mut payload = Vec::new();
            for &(x, y, j, z) in &vals {
                let mut put = |b: &[u8]| {
                    let mut b = b.to_vec();
                    if be {
                        b.reverse();
                    }
                    payload.extend_from_slice(&b);
                };
                put(&x.to_le_bytes());
                put(&y.to_le_bytes());
                put(&j.to_le_bytes());
                put(&z.to_le_bytes());
                for n in [0.0f32, 0.0, 1.0] {
                    put(&n.to_le_bytes());
                }
            }
            let enc = if be {
                "binary_big_endian"
            } else {
                "binary_little_endian"
            };
            let p = parse(&binary(&head(enc), &payload), Faces::Skip).unwrap();
            assert_eq!(p.cloud.points[0], Point3::new(0.25, -1.5, 3.0));
            assert_eq!(p.cloud.points[1], Point3::new(1e-3, 2.0, -4.5));
            assert_eq!(p.cloud.normals.as_ref().unwrap()[1], Vector3::z());
            assert_eq!(p.info.encoding, enc);
        }
    }

    #[test]
    fn float_colours_are_scaled() {
        let f = ascii_file(
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n\
             property float red\nproperty float green\nproperty float blue\nend_header\n0 0 0 1 0.5 0\n",
        );
        let p = parse(&f, Faces::Skip).unwrap();
        assert_eq!(p.cloud.colors.unwrap()[0], [255, 128, 0]);
    }

    #[test]
    fn huge_count_is_rejected_before_allocation() {
        let f = binary(
            "ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\nproperty float x\n\
             property float y\nproperty float z\nend_header\n",
            &[0u8; 24],
        );
        let e = parse(&f, Faces::Skip).err().unwrap();
        assert!(e.contains("only 24 bytes follow"), "{e}");
    }

    #[test]
    fn binary_list_in_vertex_and_unknown_elements_are_walked() {
        let mut payload = Vec::new();
        // element extra 1: uchar
        payload.push(9u8);
        // vertex: list uchar float junk; float x y z
        for (n, xyz) in [(2u8, [1.0f32, 2.0, 3.0]), (0, [4.0, 5.0, 6.0])] {
            payload.push(n);
            for _ in 0..n {
                payload.extend_from_slice(&0.5f32.to_le_bytes());
            }
            for v in xyz {
                payload.extend_from_slice(&v.to_le_bytes());
            }
        }
        // face: list ushort uint vertex_index
        payload.extend_from_slice(&3u16.to_le_bytes());
        for i in [1u32, 0, 1] {
            payload.extend_from_slice(&i.to_le_bytes());
        }
        let f = binary(
            "ply\nformat binary_little_endian 1.0\nelement extra 1\nproperty uchar a\nelement vertex 2\n\
             property list uchar float junk\nproperty float x\nproperty float y\nproperty float z\n\
             element face 1\nproperty list ushort uint vertex_index\nend_header\n",
            &payload,
        );
        let p = parse(&f, Faces::Read).unwrap();
        assert_eq!(
            p.cloud.points,
            vec![Point3::new(1.0, 2.0, 3.0), Point3::new(4.0, 5.0, 6.0)]
        );
        assert_eq!(p.triangles, vec![[1, 0, 1]]);
        // One byte less: truncated.
        let e = parse(&f[..f.len() - 1], Faces::Read).err().unwrap();
        assert!(
            e.contains("impossible list length 3") || e.contains("truncated"),
            "{e}"
        );
    }

    /// A binary mesh with colours, a list in the vertex element and an unknown element.
    fn sample_binary() -> Vec<u8> {
        let mut payload = Vec::new();
        for i in 0..4u8 {
            for v in [f32::from(i), 1.0, -2.0] {
                payload.extend_from_slice(&v.to_le_bytes());
            }
            payload.extend_from_slice(&[i, 2 * i, 3 * i, 2, 7, 9]);
        }
        for poly in [&[0u32, 1, 2][..], &[0, 2, 3, 1]] {
            payload.push(poly.len() as u8);
            for &i in poly {
                payload.extend_from_slice(&i.to_le_bytes());
            }
        }
        payload.extend_from_slice(&5i16.to_le_bytes());
        binary(
            "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
             property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n\
             property list uchar uchar tags\nelement face 2\nproperty list uchar uint vertex_indices\n\
             element extra 1\nproperty short s\nend_header\n",
            &payload,
        )
    }

    #[test]
    fn sample_binary_reads() {
        let p = parse(&sample_binary(), Faces::Read).unwrap();
        assert_eq!(p.cloud.len(), 4);
        assert_eq!(p.cloud.colors.unwrap()[3], [3, 6, 9]);
        assert_eq!(p.triangles, vec![[0, 1, 2], [0, 2, 3], [0, 3, 1]]);
    }

    const XYZ3: &str = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                        property float z\nend_header\n";

    /// The error for an ascii file made of `head` and `body`; it must be one line.
    fn ascii_err(head: &str, body: &str, faces: Faces) -> String {
        let e = parse(&ascii_file(&format!("{head}{body}")), faces).err().unwrap();
        assert!(!e.contains('\n'), "not one line: {e}");
        e
    }

    /// The header's own lines are as strict as its element and property lines: words after
    /// the format or `end_header` (they were taken), a version not 1.0 (a NUL after it passed).
    #[test]
    fn header_lines_with_trailing_words_are_an_error() {
        let body = "0 0 0\n1 1 1\n2 2 2\n";
        for (head, why) in [
            (
                XYZ3.replace("ascii 1.0", "ascii 1.0 junk"),
                "header line 2: malformed format line",
            ),
            (
                XYZ3.replace("ascii 1.0", "ascii 1.0\0"),
                "header line 2: unsupported format version",
            ),
            (
                XYZ3.replace("ascii 1.0", "ascii 1.1"),
                "header line 2: unsupported format version",
            ),
            (
                XYZ3.replace("end_header", "end_header junk"),
                "header line 7: 'end_header' followed by 'junk'",
            ),
        ] {
            let e = ascii_err(&head, body, Faces::Skip);
            assert!(e.starts_with(why), "{e}");
        }
        assert!(
            parse(
                &ascii_file(&format!("{}{body}", XYZ3.replace("1.0", "1"))),
                Faces::Skip
            )
            .is_ok()
        );
    }

    #[test]
    fn ascii_line_with_an_extra_value_is_an_error() {
        // Read as a token stream this was vertex (9, 1, 1) and bbox_max [9, 2, 2].
        let e = ascii_err(XYZ3, "0 0 0 9\n1 1 1\n2 2 2\n", Faces::Skip);
        assert_eq!(e, "line 8: record 0 of element 'vertex' has 4 values, expected 3");
    }

    #[test]
    fn ascii_line_with_a_missing_value_is_an_error() {
        let e = ascii_err(XYZ3, "0 0\n1 1 1\n2 2 2 3\n", Faces::Skip);
        assert_eq!(
            e,
            "line 8: record 0 of element 'vertex' has 2 values, expected 3 (no value for 'z')"
        );
        let e = ascii_err(XYZ3, "0 0 0\n1 1\n2 2 2 3\n", Faces::Skip);
        assert!(
            e.starts_with("line 9: record 1 of element 'vertex' has 2 values"),
            "{e}"
        );
        // Too short to hold the declared records at all: the count check says so, and names
        // the short line among its causes.
        let e = ascii_err(XYZ3, "0 0\n1 1 1\n2 2 2\n", Faces::Skip);
        assert!(
            e.starts_with("payload too short") && e.contains("lines with fewer values than the properties"),
            "{e}"
        );
        // On the last line, the file was cut short.
        let e = ascii_err(XYZ3, "0.0 0.0 0.0\n1 1 1\n2 2\n", Faces::Skip);
        assert_eq!(
            e,
            "truncated payload: element 'vertex' ends after 2 of 3 records: the file ends after line 10, \
             which has 2 values, expected 3 (no value for 'z')"
        );
    }

    #[test]
    fn ascii_records_after_the_declared_elements_are_an_error() {
        let e = ascii_err(XYZ3, "0 0 0\n1 1 1\n2 2 2\n3 3 3\n4 4 4\n", Faces::Skip);
        assert_eq!(
            e,
            "2 more lines after the declared elements (the first is line 11: '3 3 3'): \
             does the header under-count?"
        );
        // Trailing blank lines are not records.
        let p = parse(
            &ascii_file(&format!("{XYZ3}0 0 0\n1 1 1\n2 2 2\n\n  \n")),
            Faces::Skip,
        )
        .unwrap();
        assert_eq!(p.cloud.len(), 3);
    }

    #[test]
    fn ascii_crlf_blank_lines_and_no_final_newline_are_accepted() {
        let head = XYZ3.replace('\n', "\r\n");
        let p = parse(
            &ascii_file(&format!("{head}0 0 0\r\n\r\n1 1 1 \r\n\t2 2 2")),
            Faces::Skip,
        )
        .unwrap();
        assert_eq!(p.cloud.points[2], Point3::new(2.0, 2.0, 2.0));
    }

    #[test]
    fn ascii_list_length_must_match_its_entries() {
        let head = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                    property float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n\
                    0 0 0\n1 1 1\n2 2 2\n";
        for faces in [Faces::Read, Faces::Skip] {
            let e = ascii_err(head, "3 0 1 2 2\n3 0 1 2\n", faces);
            assert_eq!(
                e,
                "line 13: record 0 of element 'face' has 5 values, expected 4 \
                 (list 'vertex_indices' declares length 3)"
            );
            let e = ascii_err(head, "4 0 1 2\n3 0 1 2\n", faces);
            assert_eq!(
                e,
                "line 13: record 0 of element 'face' has 4 values, expected 5 \
                 (list 'vertex_indices' declares length 4 but 3 entries follow)"
            );
            // A list before other properties: the expected count is a lower bound until it is read.
            let e = ascii_err(
                &head.replace("property list", "property list uchar int tags\nproperty list"),
                "\n2 7 8\n3 0 1 2\n",
                faces,
            );
            assert_eq!(
                e,
                "line 15: record 0 of element 'face' has 3 values, expected at least 4 \
                 (no value for 'vertex_indices')"
            );
        }
    }

    /// A binary little-endian file of `float x y z` records: `declared` in the header, `points`
    /// in the payload, then `tail`.
    fn binary_xyz(declared: usize, points: &[[f32; 3]], tail: &[u8]) -> Vec<u8> {
        let mut payload: Vec<u8> = points.iter().flatten().flat_map(|v| v.to_le_bytes()).collect();
        payload.extend_from_slice(tail);
        binary(
            &format!(
                "ply\nformat binary_little_endian 1.0\nelement vertex {declared}\nproperty float x\n\
                 property float y\nproperty float z\nend_header\n"
            ),
            &payload,
        )
    }

    #[test]
    fn binary_records_after_the_declared_elements_are_an_error() {
        let pts = [[0.0, 0.0, 0.0], [1.0, 1.0, 1.0], [2.0, 2.0, 2.0], [3.0, 3.0, 3.0]];
        assert_eq!(
            parse(&binary_xyz(4, &pts, b""), Faces::Skip).unwrap().cloud.len(),
            4
        );
        let e = parse(&binary_xyz(2, &pts, b""), Faces::Skip).err().unwrap();
        assert!(!e.contains('\n'), "{e}");
        assert!(
            e.starts_with("24 bytes after the declared elements ('")
                && e.ends_with(
                    "...'; the elements take 24 of the 48 payload bytes, enough for 2 more 'vertex' records): \
                     does the header under-count?"
                ),
            "{e}"
        );
        // Not a whole record: no record count offered.
        let e = parse(&binary_xyz(4, &pts, b"junk"), Faces::Read).err().unwrap();
        assert_eq!(
            e,
            "4 bytes after the declared elements ('junk'; the elements take 48 of the 52 payload bytes): \
             does the header under-count?"
        );
        // After a list-bearing element too.
        let mut f = sample_binary();
        f.push(0);
        let e = parse(&f, Faces::Skip).err().unwrap();
        assert!(
            e.starts_with("1 byte after the declared elements ('\\x00'"),
            "{e}"
        );
    }

    #[test]
    fn binary_trailing_line_break_is_accepted_and_nothing_more() {
        // A writer may end the file with a line break; two are already data.
        for end in [&b"\n"[..], b"\r\n"] {
            let p = parse(&binary_xyz(1, &[[1.0, 2.0, 3.0]], end), Faces::Skip).unwrap();
            assert_eq!(p.cloud.points.len(), 1);
        }
        let e = parse(&binary_xyz(1, &[[1.0, 2.0, 3.0]], b"\n\n"), Faces::Skip)
            .err()
            .unwrap();
        assert_eq!(
            e,
            "2 bytes after the declared elements ('\\n\\n'; the elements take 12 of the 14 payload bytes): \
             does the header under-count?"
        );
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(2000))]
        /// Any byte changed, any truncation: an error or a cloud, never a panic.
        #[test]
        fn corrupted_files_never_panic(
            edits in proptest::collection::vec((0usize..400, proptest::prelude::any::<u8>()), 0..4),
            cut in 0usize..400,
            ascii in proptest::prelude::any::<bool>(),
        ) {
            let mut f = if ascii {
                b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                  property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n\
                  element face 1\nproperty list uchar int vertex_indices\nend_header\n\
                  0 0 0 1 2 3\n1 0 0 4 5 6\n0 1 0 7 8 9\n3 0 1 2\n".to_vec()
            } else {
                sample_binary()
            };
            for (at, b) in edits {
                let n = f.len();
                f[at % n] = b;
            }
            f.truncate(cut.max(f.len() / 2));
            for faces in [Faces::Read, Faces::Skip] {
                if let Ok(p) = parse(&f, faces) {
                    let n = p.cloud.len() as u32;
                    proptest::prop_assert!(p.triangles.iter().flatten().all(|&i| i < n));
                    proptest::prop_assert!(p.cloud.points.iter().all(|q| q.coords.iter().all(|v| v.is_finite())));
                }
            }
        }
    }
}
