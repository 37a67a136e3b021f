//! The one way `advise` opens a Parquet file (issue 47): demonstrations
//! ([`super::parquet_demos`]), LeRobot frames ([`super::lerobot_in`]) and a journal's sidecar
//! (`session::sidecar`) all come through [`open`] or [`reader`].
//!
//! The parquet crate trusts its footer: a column chunk's negative offset or size panics in it
//! ("column start and length should not be negative"), and a schema element declaring 2^31-1
//! children makes it reserve 17 GB before it finds the children missing. So the footer is read
//! here first, by a small Thrift compact-protocol walker that allocates nothing a count in the
//! file asks for, and held to what a file of its length can hold: a schema tree whose declared
//! children are all there (at most [`MAX_SCHEMA_ELEMENTS`] elements, [`MAX_LEAVES`] columns,
//! [`MAX_DEPTH`] deep), every column chunk inside the file before its footer, sizes and counts
//! that are not negative, no chunk larger than [`MAX_CHUNK_BYTES`] uncompressed, a non-repeated
//! column holding no more values than its row group has rows, row groups holding no more rows
//! than the file says, and a codec this build reads. Only then is the parquet crate given the
//! file. A file that is not a regular file is refused before it is opened (a FIFO would block).
//!
//! [`guarded`] runs a whole read under `catch_unwind` as a last line: a panic the checks above
//! did not foresee becomes `advise::parquet::panicked`, never a crash. It is not the defence:
//! every shape of lie found so far is refused by a check before the crate sees it.
//!
//! This module knows no column's meaning; its callers check names, types and values.

use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::path::Path;

use miette::Diagnostic;
use parquet::file::reader::SerializedFileReader;
use thiserror::Error;

/// The longest footer read (its metadata): thousands of row groups of hundreds of columns.
pub const MAX_FOOTER_BYTES: u64 = 16 << 20;
/// The most schema elements (columns and the groups holding them) a file may declare.
pub const MAX_SCHEMA_ELEMENTS: usize = 100_000;
/// The most leaf columns a file may have.
pub const MAX_LEAVES: usize = 10_000;
/// How deep groups may nest in a schema (and Thrift structs in the footer).
pub const MAX_DEPTH: usize = 64;
/// The most one column chunk may hold uncompressed (its declared size).
pub const MAX_CHUNK_BYTES: i64 = 1 << 30;

/// Why a Parquet file is refused before (or while) it is read.
#[derive(Debug, Error, Diagnostic)]
pub enum ParquetGuardError {
    #[error(transparent)]
    #[diagnostic(transparent)]
    File(#[from] crate::files::FileError),

    #[error("{path}: not a readable Parquet file: {message}")]
    #[diagnostic(
        code(advise::parquet::unreadable),
        help(
            "write it with a Parquet writer (pyarrow's `pq.write_table`, pandas' `to_parquet`, polars' `write_parquet`)"
        )
    )]
    Unreadable { path: String, message: String },

    #[error("{path}: its footer lies: {what}")]
    #[diagnostic(
        code(advise::parquet::footer),
        help(
            "the file's metadata describes data it does not hold (it was cut, edited or written wrongly); nothing of it was read: write it again with a Parquet writer"
        )
    )]
    Footer { path: String, what: String },

    #[error("{path}: {what}, more than the {limit} `advise` reads")]
    #[diagnostic(
        code(advise::parquet::too_large),
        help(
            "the file declares more than any demonstrations table needs; nothing was allocated for it: split the table or drop the columns not needed"
        )
    )]
    TooLarge {
        path: String,
        what: String,
        limit: String,
    },

    #[error("{path}: column `{column}` is compressed with {codec}, which `advise` does not read")]
    #[diagnostic(
        code(advise::parquet::codec),
        help(
            "`advise` reads uncompressed, snappy, gzip, brotli, lz4, lz4_raw and zstd columns: write it again with one of them (pyarrow: `compression=\"zstd\"`)"
        )
    )]
    Codec {
        path: String,
        column: String,
        codec: String,
    },

    #[error("{path} is encrypted")]
    #[diagnostic(
        code(advise::parquet::encrypted),
        help("`advise` reads plain Parquet files: write it without encryption")
    )]
    Encrypted { path: String },

    #[error("{path}: the Parquet reader failed on it ({message})")]
    #[diagnostic(
        code(advise::parquet::panicked),
        help(
            "the file passed `advise`'s checks but the reader could not read it: nothing of it was used; please report the file"
        )
    )]
    Panicked { path: String, message: String },
}

/// Open the Parquet file at `path` (a regular file of at most `max_bytes`) once its footer is
/// checked ([`reader`]).
pub fn open(path: &Path, max_bytes: u64) -> Result<SerializedFileReader<File>, ParquetGuardError> {
    let (file, len) = crate::files::open_regular(path, max_bytes)?;
    reader(file, len, &path.display().to_string())
}

/// The parquet crate's reader of `file` (`len` bytes, shown as `path`) once its footer is
/// checked by [`check_footer`].
pub fn reader(
    mut file: File,
    len: u64,
    path: &str,
) -> Result<SerializedFileReader<File>, ParquetGuardError> {
    let unreadable = |message: String| ParquetGuardError::Unreadable {
        path: path.to_string(),
        message,
    };
    if len < 12 {
        return Err(unreadable(format!(
            "it is {len} bytes long, shorter than any Parquet file"
        )));
    }
    let mut tail = [0u8; 8];
    file.seek(SeekFrom::Start(len - 8))
        .and_then(|_| file.read_exact(&mut tail))
        .map_err(|e| unreadable(e.to_string()))?;
    match &tail[4..] {
        b"PAR1" => {}
        b"PARE" => {
            return Err(ParquetGuardError::Encrypted {
                path: path.to_string(),
            });
        }
        _ => return Err(unreadable("it does not end in `PAR1`".into())),
    }
    let footer_len = u64::from(u32::from_le_bytes([tail[0], tail[1], tail[2], tail[3]]));
    if footer_len > len - 12 {
        return Err(ParquetGuardError::Footer {
            path: path.to_string(),
            what: format!("its metadata is {footer_len} bytes long, in a file of {len} bytes"),
        });
    }
    if footer_len > MAX_FOOTER_BYTES {
        return Err(ParquetGuardError::TooLarge {
            path: path.to_string(),
            what: format!("its metadata is {footer_len} bytes long"),
            limit: crate::files::fmt_bytes(MAX_FOOTER_BYTES),
        });
    }
    let footer_start = len - 8 - footer_len;
    let mut footer = vec![0u8; footer_len as usize];
    file.seek(SeekFrom::Start(footer_start))
        .and_then(|_| file.read_exact(&mut footer))
        .map_err(|e| unreadable(e.to_string()))?;
    check_footer(&footer, footer_start).map_err(|e| e.at(path))?;
    file.seek(SeekFrom::Start(0))
        .map_err(|e| unreadable(e.to_string()))?;
    guarded(path, || {
        SerializedFileReader::new(file).map_err(|e| unreadable(e.to_string()))
    })
}

/// Run `read` (a read of the Parquet file `path`), turning a panic inside it into
/// `advise::parquet::panicked`: the last line behind the footer checks, not the defence.
pub fn guarded<T, E: From<ParquetGuardError>>(
    path: &str,
    read: impl FnOnce() -> Result<T, E>,
) -> Result<T, E> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(read)).unwrap_or_else(|panic| {
        let message = panic
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| panic.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "a panic".into());
        Err(ParquetGuardError::Panicked {
            path: path.to_string(),
            message,
        }
        .into())
    })
}

/// A refusal of the footer, before the path is known.
#[derive(Debug, PartialEq)]
pub enum FooterFault {
    /// Bytes that are not the Thrift the metadata should be.
    Malformed(String),
    /// Well-formed metadata describing what the file cannot hold.
    Lies(String),
    /// More than `advise` reads: what, and the limit.
    TooLarge(String, String),
    /// A column compressed with a codec this build does not read: column, codec.
    Codec(String, String),
    Encrypted,
}

impl FooterFault {
    fn at(self, path: &str) -> ParquetGuardError {
        let path = path.to_string();
        match self {
            FooterFault::Malformed(m) => ParquetGuardError::Unreadable {
                path,
                message: format!("its metadata cannot be decoded: {m}"),
            },
            FooterFault::Lies(what) => ParquetGuardError::Footer { path, what },
            FooterFault::TooLarge(what, limit) => ParquetGuardError::TooLarge { path, what, limit },
            FooterFault::Codec(column, codec) => ParquetGuardError::Codec {
                path,
                column,
                codec,
            },
            FooterFault::Encrypted => ParquetGuardError::Encrypted { path },
        }
    }
}

// Thrift compact protocol type ids.
const T_STOP: u8 = 0;
const T_TRUE: u8 = 1;
const T_FALSE: u8 = 2;
const T_BYTE: u8 = 3;
const T_I16: u8 = 4;
const T_I32: u8 = 5;
const T_I64: u8 = 6;
const T_DOUBLE: u8 = 7;
const T_BINARY: u8 = 8;
const T_LIST: u8 = 9;
const T_SET: u8 = 10;
const T_MAP: u8 = 11;
const T_STRUCT: u8 = 12;
const T_UUID: u8 = 13;

/// A reader of Thrift's compact protocol over a byte slice: every count is checked against the
/// bytes left before it is used, and nothing is allocated for one.
struct Thrift<'a> {
    buf: &'a [u8],
    pos: usize,
    depth: usize,
}

type Walk<T> = Result<T, FooterFault>;

fn malformed(what: &str) -> FooterFault {
    FooterFault::Malformed(what.to_string())
}

impl Thrift<'_> {
    fn left(&self) -> usize {
        self.buf.len() - self.pos
    }

    fn byte(&mut self) -> Walk<u8> {
        let b = *self
            .buf
            .get(self.pos)
            .ok_or_else(|| malformed("it ends inside a value"))?;
        self.pos += 1;
        Ok(b)
    }

    fn varint(&mut self) -> Walk<u64> {
        let mut v = 0u64;
        for shift in (0..70).step_by(7) {
            let b = self.byte()?;
            v |= u64::from(b & 0x7f) << shift.min(63);
            if b & 0x80 == 0 {
                return Ok(v);
            }
        }
        Err(malformed("a number longer than ten bytes"))
    }

    fn zigzag(&mut self) -> Walk<i64> {
        let v = self.varint()?;
        Ok((v >> 1) as i64 ^ -((v & 1) as i64))
    }

    /// An integer field of type `ty` (byte, i16, i32 or i64).
    fn int(&mut self, ty: u8) -> Walk<i64> {
        match ty {
            T_BYTE => Ok(i64::from(self.byte()? as i8)),
            T_I16 | T_I32 | T_I64 => self.zigzag(),
            _ => Err(malformed("an integer field of another type")),
        }
    }

    /// The next field's id and type, or `None` at the struct's end.
    fn field(&mut self, last: &mut i16) -> Walk<Option<(i16, u8)>> {
        let b = self.byte()?;
        let ty = b & 0x0f;
        if ty == T_STOP {
            return Ok(None);
        }
        let delta = i16::from(b >> 4);
        let id = if delta == 0 {
            i16::try_from(self.zigzag()?).map_err(|_| malformed("a field id out of range"))?
        } else {
            last.saturating_add(delta)
        };
        *last = id;
        Ok(Some((id, ty)))
    }

    /// A list's (or set's) element type and length; the length is at most the bytes left (every
    /// element takes at least one).
    fn list(&mut self) -> Walk<(u8, usize)> {
        let b = self.byte()?;
        let short = usize::from(b >> 4);
        let n = if short == 15 {
            usize::try_from(self.varint()?).unwrap_or(usize::MAX)
        } else {
            short
        };
        if n > self.left() {
            return Err(FooterFault::Lies(format!(
                "a list declares {n} elements in {} bytes",
                self.left()
            )));
        }
        Ok((b & 0x0f, n))
    }

    fn enter(&mut self) -> Walk<()> {
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            return Err(FooterFault::TooLarge(
                "its metadata nests deeper".into(),
                format!("{MAX_DEPTH} levels"),
            ));
        }
        Ok(())
    }

    /// Skip a value of type `ty`.
    fn skip(&mut self, ty: u8) -> Walk<()> {
        match ty {
            T_TRUE | T_FALSE => Ok(()),
            T_BYTE => self.byte().map(drop),
            T_I16 | T_I32 | T_I64 => self.varint().map(drop),
            T_DOUBLE => self.bytes(8),
            T_UUID => self.bytes(16),
            T_BINARY => {
                let n = usize::try_from(self.varint()?).unwrap_or(usize::MAX);
                self.bytes(n)
            }
            T_LIST | T_SET => {
                let (elem, n) = self.list()?;
                self.enter()?;
                for _ in 0..n {
                    self.skip_element(elem)?;
                }
                self.depth -= 1;
                Ok(())
            }
            T_MAP => {
                let n = usize::try_from(self.varint()?).unwrap_or(usize::MAX);
                if n == 0 {
                    return Ok(());
                }
                if n > self.left() {
                    return Err(malformed("a map longer than the metadata"));
                }
                let kv = self.byte()?;
                self.enter()?;
                for _ in 0..n {
                    self.skip_element(kv >> 4)?;
                    self.skip_element(kv & 0x0f)?;
                }
                self.depth -= 1;
                Ok(())
            }
            T_STRUCT => self.structure(|t, _, ty| t.skip(ty)),
            _ => Err(malformed("an unknown Thrift type")),
        }
    }

    /// Skip a list element of type `ty` (a boolean takes a byte there).
    fn skip_element(&mut self, ty: u8) -> Walk<()> {
        if ty == T_TRUE || ty == T_FALSE {
            return self.byte().map(drop);
        }
        self.skip(ty)
    }

    fn bytes(&mut self, n: usize) -> Walk<()> {
        if n > self.left() {
            return Err(malformed("a value longer than the metadata"));
        }
        self.pos += n;
        Ok(())
    }

    /// A struct, each field given to `each` (which reads or skips it).
    fn structure(&mut self, mut each: impl FnMut(&mut Self, i16, u8) -> Walk<()>) -> Walk<()> {
        self.enter()?;
        let mut last = 0i16;
        while let Some((id, ty)) = self.field(&mut last)? {
            each(self, id, ty)?;
        }
        self.depth -= 1;
        Ok(())
    }

    /// A list of structs, each given to `each` with its index.
    fn struct_list(
        &mut self,
        ty: u8,
        mut each: impl FnMut(&mut Self, usize) -> Walk<()>,
    ) -> Walk<usize> {
        if ty != T_LIST {
            return Err(malformed("a list field of another type"));
        }
        let (elem, n) = self.list()?;
        if elem != T_STRUCT && n > 0 {
            return Err(malformed("a list of structs holds something else"));
        }
        self.enter()?;
        for i in 0..n {
            each(self, i)?;
        }
        self.depth -= 1;
        Ok(n)
    }
}

/// One schema element, as far as the tree's shape needs it.
#[derive(Default)]
struct Element {
    num_children: Option<i64>,
    repeated: bool,
    name: String,
}

/// One column chunk's metadata, as far as the checks need it.
#[derive(Default)]
struct Chunk {
    file_path: bool,
    has_meta: bool,
    codec: i64,
    num_values: i64,
    uncompressed: i64,
    compressed: i64,
    data_page_offset: i64,
    dictionary_page_offset: Option<i64>,
    encrypted: bool,
}

/// The codecs this build reads, by their Thrift number; the name of any other.
fn codec_fault(codec: i64) -> Option<String> {
    match codec {
        // UNCOMPRESSED, SNAPPY, GZIP, BROTLI, LZ4 (Hadoop's framing), ZSTD, LZ4_RAW.
        0 | 1 | 2 | 4 | 5 | 6 | 7 => None,
        3 => Some("LZO".into()),
        n => Some(format!("codec number {n}")),
    }
}

/// Check the footer `meta` (the Thrift `FileMetaData`) of a file whose data ends at
/// `data_end` (where the footer starts).
pub fn check_footer(meta: &[u8], data_end: u64) -> Result<(), FooterFault> {
    let mut t = Thrift {
        buf: meta,
        pos: 0,
        depth: 0,
    };
    let data_end = i64::try_from(data_end).unwrap_or(i64::MAX);
    // Whether each leaf column is repeated (inside a list), in schema order.
    let mut leaves: Vec<bool> = Vec::new();
    let mut leaf_names: Vec<String> = Vec::new();
    let mut schema_seen = false;
    let mut num_rows: Option<i64> = None;
    let mut group_rows: i64 = 0;
    t.structure(|t, id, ty| match id {
        2 => {
            schema_seen = true;
            walk_schema(t, ty, &mut leaves, &mut leaf_names)
        }
        3 => {
            let n = t.int(ty)?;
            if n < 0 {
                return Err(FooterFault::Lies(format!("it holds {n} rows")));
            }
            num_rows = Some(n);
            Ok(())
        }
        4 => {
            t.struct_list(ty, |t, g| {
                let rows = walk_row_group(t, g, data_end, &leaves, &leaf_names)?;
                group_rows = group_rows.saturating_add(rows);
                Ok(())
            })?;
            Ok(())
        }
        8 => Err(FooterFault::Encrypted),
        _ => t.skip(ty),
    })?;
    if !schema_seen || leaves.is_empty() {
        return Err(FooterFault::Lies("it declares no columns".into()));
    }
    let Some(num_rows) = num_rows else {
        return Err(malformed("no row count"));
    };
    if group_rows > num_rows {
        return Err(FooterFault::Lies(format!(
            "its row groups hold {group_rows} rows; it says {num_rows}"
        )));
    }
    Ok(())
}

/// The schema (field 2 of `FileMetaData`): its elements, depth first, each group followed by
/// its `num_children` children. Checked as it streams: every declared child is there, no
/// element is left over, and a group's children fit in the elements left.
fn walk_schema(
    t: &mut Thrift<'_>,
    ty: u8,
    leaves: &mut Vec<bool>,
    names: &mut Vec<String>,
) -> Walk<()> {
    if ty != T_LIST {
        return Err(malformed("the schema is not a list"));
    }
    let (elem, n) = t.list()?;
    if elem != T_STRUCT && n > 0 {
        return Err(malformed("the schema holds something other than elements"));
    }
    if n > MAX_SCHEMA_ELEMENTS {
        return Err(FooterFault::TooLarge(
            format!("its schema declares {n} elements"),
            MAX_SCHEMA_ELEMENTS.to_string(),
        ));
    }
    // For each open group: children still to come, whether it is inside a repeated field, and
    // its dotted path.
    let mut open: Vec<(i64, bool, String)> = Vec::new();
    t.enter()?;
    for i in 0..n {
        let mut e = Element::default();
        t.structure(|t, id, ty| match id {
            3 => {
                e.repeated = t.int(ty)? == 2;
                Ok(())
            }
            4 if ty == T_BINARY => {
                let len = usize::try_from(t.varint()?).unwrap_or(usize::MAX);
                let start = t.pos;
                t.bytes(len)?;
                e.name = String::from_utf8_lossy(&t.buf[start..start + len.min(256)]).into_owned();
                Ok(())
            }
            5 => {
                e.num_children = Some(t.int(ty)?);
                Ok(())
            }
            _ => t.skip(ty),
        })?;
        let left = (n - i - 1) as i64;
        let children = e.num_children.unwrap_or(0);
        if children < 0 {
            return Err(FooterFault::Lies(format!(
                "schema element `{}` declares {children} children",
                e.name
            )));
        }
        if children > left {
            return Err(FooterFault::Lies(format!(
                "schema element `{}` declares {children} children; {left} elements follow it",
                e.name
            )));
        }
        if i == 0 {
            if children == 0 {
                return Err(FooterFault::Lies(
                    "its schema's root holds no columns".into(),
                ));
            }
            open.push((children, false, String::new()));
            continue;
        }
        let Some((remaining, parent_repeated, parent_path)) = open.last_mut() else {
            return Err(FooterFault::Lies(format!(
                "its schema has {} elements after the root's last child",
                n - i
            )));
        };
        *remaining -= 1;
        let repeated = *parent_repeated || e.repeated;
        let path = if parent_path.is_empty() {
            e.name.clone()
        } else {
            format!("{parent_path}.{}", e.name)
        };
        if children > 0 {
            if open.len() >= MAX_DEPTH {
                return Err(FooterFault::TooLarge(
                    "its schema nests deeper".into(),
                    format!("{MAX_DEPTH} levels"),
                ));
            }
            open.push((children, repeated, path));
        } else {
            if leaves.len() >= MAX_LEAVES {
                return Err(FooterFault::TooLarge(
                    "it has more columns".into(),
                    MAX_LEAVES.to_string(),
                ));
            }
            leaves.push(repeated);
            names.push(path);
        }
        while open.last().is_some_and(|o| o.0 == 0) {
            open.pop();
        }
    }
    t.depth -= 1;
    if let Some((remaining, _, path)) = open.last() {
        let what = if path.is_empty() {
            "its root"
        } else {
            path.as_str()
        };
        return Err(FooterFault::Lies(format!(
            "schema group `{what}` lacks {remaining} of its declared children"
        )));
    }
    Ok(())
}

/// Row group `g`: each column chunk inside the file's data, its sizes and counts not negative
/// and within bounds; its row count.
fn walk_row_group(
    t: &mut Thrift<'_>,
    g: usize,
    data_end: i64,
    leaves: &[bool],
    names: &[String],
) -> Walk<i64> {
    let mut rows: Option<i64> = None;
    let mut chunks: Vec<Chunk> = Vec::new();
    t.structure(|t, id, ty| match id {
        1 => {
            t.struct_list(ty, |t, c| {
                if c >= leaves.len() {
                    return Err(FooterFault::Lies(format!(
                        "row group {g} has more column chunks than the schema's {} columns",
                        leaves.len()
                    )));
                }
                chunks.push(walk_chunk(t)?);
                Ok(())
            })?;
            Ok(())
        }
        3 => {
            rows = Some(t.int(ty)?);
            Ok(())
        }
        _ => t.skip(ty),
    })?;
    let Some(rows) = rows.filter(|r| *r >= 0) else {
        return Err(FooterFault::Lies(format!(
            "row group {g} has no row count, or a negative one"
        )));
    };
    if chunks.len() != leaves.len() {
        return Err(FooterFault::Lies(format!(
            "row group {g} has {} column chunks for the schema's {} columns",
            chunks.len(),
            leaves.len()
        )));
    }
    for (c, chunk) in chunks.iter().enumerate() {
        let lie = |what: String| -> Walk<i64> {
            Err(FooterFault::Lies(format!(
                "row group {g}, column `{}`: {what}",
                names[c]
            )))
        };
        if chunk.encrypted {
            return Err(FooterFault::Encrypted);
        }
        if chunk.file_path {
            return lie("its data is in another file".into());
        }
        if !chunk.has_meta {
            return lie("it has no column metadata".into());
        }
        if let Some(codec) = codec_fault(chunk.codec) {
            return Err(FooterFault::Codec(names[c].clone(), codec));
        }
        for (what, v) in [
            ("num_values", chunk.num_values),
            ("total_uncompressed_size", chunk.uncompressed),
            ("total_compressed_size", chunk.compressed),
            ("data_page_offset", chunk.data_page_offset),
        ] {
            if v < 0 {
                return lie(format!("{what} is {v}"));
            }
        }
        if let Some(d) = chunk.dictionary_page_offset.filter(|d| *d < 0) {
            return lie(format!("dictionary_page_offset is {d}"));
        }
        let start = chunk
            .dictionary_page_offset
            .unwrap_or(chunk.data_page_offset);
        let end = start.saturating_add(chunk.compressed);
        if start < 4 || end > data_end {
            return lie(format!(
                "its bytes {start}..{end} are not inside the file's data (4..{data_end})"
            ));
        }
        let first_page_inside = chunk.data_page_offset >= start && chunk.data_page_offset < end;
        // An empty chunk (pyarrow's of an empty table) has no data page: its offset is 0.
        if chunk.num_values > 0 && !first_page_inside {
            return lie(format!(
                "its first data page at {} is not among its bytes {start}..{end}",
                chunk.data_page_offset
            ));
        }
        if chunk.uncompressed > MAX_CHUNK_BYTES {
            return Err(FooterFault::TooLarge(
                format!(
                    "row group {g}, column `{}` declares {} bytes uncompressed",
                    names[c], chunk.uncompressed
                ),
                crate::files::fmt_bytes(MAX_CHUNK_BYTES as u64),
            ));
        }
        if !leaves[c] && chunk.num_values > rows {
            return lie(format!(
                "it holds {} values in {rows} rows, one value a row",
                chunk.num_values
            ));
        }
    }
    Ok(rows)
}

/// A `ColumnChunk` struct.
fn walk_chunk(t: &mut Thrift<'_>) -> Walk<Chunk> {
    let mut c = Chunk::default();
    t.structure(|t, id, ty| match id {
        1 => {
            c.file_path = true;
            t.skip(ty)
        }
        3 if ty == T_STRUCT => {
            c.has_meta = true;
            let mut have = [false; 4];
            t.structure(|t, id, ty| {
                match id {
                    4 => c.codec = t.int(ty)?,
                    5 => (c.num_values, have[0]) = (t.int(ty)?, true),
                    6 => (c.uncompressed, have[1]) = (t.int(ty)?, true),
                    7 => (c.compressed, have[2]) = (t.int(ty)?, true),
                    9 => (c.data_page_offset, have[3]) = (t.int(ty)?, true),
                    11 => c.dictionary_page_offset = Some(t.int(ty)?),
                    _ => t.skip(ty)?,
                }
                Ok(())
            })?;
            if have.contains(&false) {
                return Err(malformed("a column chunk lacks a required size or offset"));
            }
            Ok(())
        }
        8 | 9 => {
            c.encrypted = true;
            t.skip(ty)
        }
        _ => t.skip(ty),
    })?;
    Ok(c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use parquet::basic::{Repetition, Type as Physical};
    use parquet::data_type::DoubleType;
    use parquet::file::properties::WriterProperties;
    use parquet::file::reader::FileReader;
    use parquet::file::writer::SerializedFileWriter;
    use parquet::schema::types::Type;
    use std::sync::Arc;

    fn zigzag(v: i64) -> Vec<u8> {
        let mut u = ((v << 1) ^ (v >> 63)) as u64;
        let mut out = Vec::new();
        loop {
            let b = (u & 0x7f) as u8;
            u >>= 7;
            if u == 0 {
                out.push(b);
                return out;
            }
            out.push(b | 0x80);
        }
    }

    /// A small valid file of two required double columns, with or without dictionaries.
    fn written(dictionary: bool) -> Vec<u8> {
        let fields = ["a", "b"]
            .iter()
            .map(|n| {
                Arc::new(
                    Type::primitive_type_builder(n, Physical::DOUBLE)
                        .with_repetition(Repetition::REQUIRED)
                        .build()
                        .unwrap(),
                )
            })
            .collect();
        let schema = Arc::new(
            Type::group_type_builder("schema")
                .with_fields(fields)
                .build()
                .unwrap(),
        );
        let props = Arc::new(
            WriterProperties::builder()
                .set_dictionary_enabled(dictionary)
                .build(),
        );
        let mut buf = Vec::new();
        let mut w = SerializedFileWriter::new(&mut buf, schema, props).unwrap();
        let mut rg = w.next_row_group().unwrap();
        while let Some(mut c) = rg.next_column().unwrap() {
            c.typed::<DoubleType>()
                .write_batch(&[1.0, 2.0, 1.0, 2.0], None, None)
                .unwrap();
            c.close().unwrap();
        }
        rg.close().unwrap();
        w.close().unwrap();
        buf
    }

    /// The footer of `file` and where its data ends.
    fn footer(file: &[u8]) -> (Vec<u8>, u64) {
        let n = u32::from_le_bytes(file[file.len() - 8..file.len() - 4].try_into().unwrap());
        let start = file.len() - 8 - n as usize;
        (file[start..file.len() - 8].to_vec(), start as u64)
    }

    fn patched(footer: &[u8], old: &[u8], new: &[u8]) -> Vec<u8> {
        let at = footer
            .windows(old.len())
            .position(|w| w == old)
            .expect("the pattern is in the footer");
        [&footer[..at], new, &footer[at + old.len()..]].concat()
    }

    /// A written file passes; each lie the parquet crate would panic or over-allocate on is
    /// refused by its own fault, before the crate sees it.
    #[test]
    fn lies_in_a_footer_are_refused_and_a_true_one_passes() {
        let file = written(true);
        let (meta, end) = footer(&file);
        assert_eq!(check_footer(&meta, end), Ok(()));
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f.parquet");
        std::fs::write(&path, &file).unwrap();
        let reader = open(&path, u64::MAX).unwrap();
        let col = reader.metadata().row_group(0).column(0).clone();
        let (unc, comp) = (col.uncompressed_size(), col.compressed_size());
        let (data, dict) = (
            col.data_page_offset(),
            col.dictionary_page_offset().unwrap(),
        );
        let pair = |h: u8, a: i64, b: i64| [vec![h], zigzag(a), vec![h], zigzag(b)].concat();
        let lies = [
            (
                "total_compressed_size",
                pair(0x16, unc, comp),
                pair(0x16, unc, -1),
            ),
            (
                "dictionary_page_offset",
                pair(0x26, data, dict),
                pair(0x26, data, -1),
            ),
            ("inside", pair(0x26, data, dict), pair(0x26, data, 1 << 40)),
        ];
        for (what, old, new) in lies {
            let f = check_footer(&patched(&meta, &old, &new), end);
            assert!(matches!(f, Err(FooterFault::Lies(_))), "{what}: {f:?}");
        }
        let children = [b"schema\x15".to_vec(), zigzag(2)].concat();
        for n in [i64::from(i32::MAX), 3, -1] {
            let new = [b"schema\x15".to_vec(), zigzag(n)].concat();
            let f = check_footer(&patched(&meta, &children, &new), end);
            assert!(
                matches!(f, Err(FooterFault::Lies(_))),
                "{n} children: {f:?}"
            );
        }
        // Cut anywhere: a malformed footer, never a panic.
        for k in 0..meta.len() {
            assert!(check_footer(&meta[..k], end).is_err(), "cut at {k}");
        }
        assert!(check_footer(&meta, 10).is_err());
    }
}
