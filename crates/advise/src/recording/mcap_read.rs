//! An MCAP file's messages, read record by record with every chunk's decompression bounded
//! (issue 31): the bag importer's only reader of MCAP ([`super::bag`] decodes the messages).
//!
//! The `mcap` crate's `MessageStream` decompresses a chunk whole, to whatever size its header
//! claims, and then walks every record in it: a 138 KB chunk of zeros that expands to 3.2 GB
//! kept `advise import` busy for 100 s before any refusal. Here the file's records are walked
//! directly (`mcap::parse_record` parses each one) and a chunk is decompressed only after its
//! header passes three bounds ([`Bounds`]): its declared size, its ratio to its compressed size,
//! and the bag's running total. The decompressor then reads through a `take` of the declared
//! size plus one byte, so a header that lies about the size is caught after at most one byte
//! more than it claimed. A bound exceeded is a refusal with its own code, naming the chunk's
//! byte offset, the sizes and the bound; it is never taken for a truncated file.
//!
//! A damaged file (a record cut short, a chunk that does not decompress, a message on an unknown
//! channel) is reported as [`Read::Damaged`] with the reader's words, so the importer can keep
//! the messages before the damage, as it did with `MessageStream`. This module knows nothing of
//! ROS 2 messages.

use std::borrow::Cow;
use std::collections::HashMap;
use std::io::Read as _;
use std::path::Path;

use mcap::records::{Record, op};

use super::ImportError;
use crate::files::fmt_bytes;

/// The largest MCAP file read (a bag splits its recording into files of a set size; an hour of a
/// base at 50 Hz is about 15 MB).
pub const MAX_BAG_FILE_BYTES: u64 = 4 * 1024 * 1024 * 1024;

/// How far chunks may expand: per chunk, by ratio, and over a whole bag.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Bounds {
    /// The most one chunk may decompress to. rosbag2 and the MCAP writers cut chunks at under
    /// 1 MiB; a chunk holding one large message (a 4K camera image, 24 MiB) stays under this.
    pub chunk_bytes: u64,
    /// The most a chunk may expand, decompressed over compressed, once it is larger than
    /// [`Bounds::ratio_free_bytes`]. Real messages compress 3-50 times with zstd or lz4 (idle
    /// odometry, mostly zero covariances, is the most compressible); a run of zeros compresses
    /// thousands of times.
    pub ratio: u64,
    /// Chunks up to this size decompressed are not held to the ratio: a few small chunks cannot
    /// cost much, and a short chunk's header dominates its compressed size.
    pub ratio_free_bytes: u64,
    /// The most all the chunks of a bag may decompress to together: what `advise` reads of an
    /// uncompressed bag file ([`MAX_BAG_FILE_BYTES`]).
    pub total_bytes: u64,
}

impl Bounds {
    /// The bounds `advise import` and `load demos BAG` read with.
    pub const DEFAULT: Bounds = Bounds {
        chunk_bytes: 64 * 1024 * 1024,
        ratio: 1000,
        ratio_free_bytes: 64 * 1024,
        total_bytes: MAX_BAG_FILE_BYTES,
    };
}

/// A channel as its records declare it.
#[derive(Clone, Debug)]
pub struct Channel {
    pub topic: String,
    /// The schema's name (`geometry_msgs/msg/Twist`), or `(no schema)`.
    pub schema: String,
    pub message_encoding: String,
}

/// How a file's reading ended.
#[derive(Debug)]
pub enum Read {
    /// Every record read, up to the data end (or the file's end after its footer).
    Whole,
    /// The file is damaged after some messages were read: the reader's words.
    Damaged(String),
}

/// Bytes decompressed so far, over all the files of a bag.
#[derive(Debug, Default)]
pub struct Budget {
    pub decompressed: u64,
}

/// Why the walk stopped early.
enum Stop {
    Damaged(String),
    Refused(ImportError),
}

/// The callback for each message: its channel's id, the channel, its log time (ns), its data.
pub type OnMessage<'a> = dyn FnMut(u16, &Channel, u64, &[u8]) -> Result<(), ImportError> + 'a;

/// Read `bytes`, the MCAP file `path`, calling `on` for each message in file order; chunks are
/// decompressed within `bounds`, their sizes counted in `budget`. A damaged file before any
/// message is [`ImportError::NotMcap`]; after one, [`Read::Damaged`].
pub fn read_messages(
    path: &Path,
    bytes: &[u8],
    bounds: &Bounds,
    budget: &mut Budget,
    on: &mut OnMessage<'_>,
) -> Result<Read, ImportError> {
    let not_mcap = |reason: String| ImportError::NotMcap {
        path: path.to_path_buf(),
        reason,
    };
    let Some(records) = bytes.strip_prefix(mcap::MAGIC) else {
        return Err(not_mcap("Bad magic number".into()));
    };
    let mut walker = Walker {
        path,
        bounds,
        budget,
        on,
        schemas: HashMap::new(),
        channels: HashMap::new(),
        messages: 0,
    };
    let offset = mcap::MAGIC.len() as u64;
    match walker.walk(records, offset, false) {
        Ok(()) => Ok(Read::Whole),
        Err(Stop::Refused(e)) => Err(e),
        Err(Stop::Damaged(why)) if walker.messages > 0 => Ok(Read::Damaged(why)),
        Err(Stop::Damaged(why)) => Err(not_mcap(why)),
    }
}

struct Walker<'p, 'b, 'o> {
    path: &'p Path,
    bounds: &'b Bounds,
    budget: &'b mut Budget,
    on: &'b mut OnMessage<'o>,
    schemas: HashMap<u16, String>,
    channels: HashMap<u16, Channel>,
    messages: usize,
}

/// An MCAP record's opcode and length before its body.
const RECORD_HEAD: usize = 1 + 8;

impl Walker<'_, '_, '_> {
    /// Walk the records of `buf` (a file's after its magic, at byte `offset`, or a chunk's),
    /// to the data end record (a file) or the end (a chunk).
    fn walk(&mut self, buf: &[u8], offset: u64, in_chunk: bool) -> Result<(), Stop> {
        let cut = || {
            Stop::Damaged(
                if in_chunk {
                    mcap::McapError::UnexpectedEoc
                } else {
                    mcap::McapError::UnexpectedEof
                }
                .to_string(),
            )
        };
        let mut pos = 0usize;
        while pos < buf.len() {
            let Some(head) = buf.get(pos..pos + RECORD_HEAD) else {
                return Err(cut());
            };
            let opcode = head[0];
            let mut len = [0u8; 8];
            len.copy_from_slice(&head[1..]);
            let len = u64::from_le_bytes(len);
            let start = pos + RECORD_HEAD;
            let Some(body) = usize::try_from(len)
                .ok()
                .and_then(|len| buf.get(start..start.checked_add(len)?))
            else {
                return Err(cut());
            };
            let at = offset + pos as u64;
            pos = start + body.len();
            match opcode {
                op::DATA_END | op::FOOTER if !in_chunk => return Ok(()),
                op::SCHEMA | op::CHANNEL | op::MESSAGE => self.record(opcode, body)?,
                op::CHUNK if !in_chunk => self.chunk(at, body)?,
                // Indexes, attachments, metadata and private records say nothing the import
                // needs.
                _ => {}
            }
        }
        if in_chunk { Ok(()) } else { Err(cut()) }
    }

    fn record(&mut self, opcode: u8, body: &[u8]) -> Result<(), Stop> {
        let damaged = |e: mcap::McapError| Stop::Damaged(e.to_string());
        match mcap::parse_record(opcode, body).map_err(damaged)? {
            Record::Schema { header, .. } => {
                self.schemas.entry(header.id).or_insert(header.name);
            }
            Record::Channel(c) => {
                let schema = match c.schema_id {
                    0 => "(no schema)".to_string(),
                    id => match self.schemas.get(&id) {
                        Some(name) => name.clone(),
                        None => return Err(damaged(mcap::McapError::UnknownSchema(c.topic, id))),
                    },
                };
                self.channels.entry(c.id).or_insert(Channel {
                    topic: c.topic,
                    schema,
                    message_encoding: c.message_encoding,
                });
            }
            Record::Message { header, data } => {
                let Some(channel) = self.channels.get(&header.channel_id) else {
                    return Err(damaged(mcap::McapError::UnknownChannel(
                        header.sequence,
                        header.channel_id,
                    )));
                };
                self.messages += 1;
                (self.on)(header.channel_id, channel, header.log_time, &data)
                    .map_err(Stop::Refused)?;
            }
            _ => {}
        }
        Ok(())
    }

    /// A chunk at byte `at` of the file: its header checked against the bounds before anything is
    /// decompressed, then decompressed through a bounded reader and walked.
    fn chunk(&mut self, at: u64, body: &[u8]) -> Result<(), Stop> {
        let Record::Chunk { header, data } =
            mcap::parse_record(op::CHUNK, body).map_err(|e| Stop::Damaged(e.to_string()))?
        else {
            return Err(Stop::Damaged("a chunk record that is not a chunk".into()));
        };
        let size = header.uncompressed_size;
        let compressed = data.len() as u64;
        let file = self.path;
        let path = || file.to_path_buf();
        let b = self.bounds;
        if size > b.chunk_bytes {
            return Err(Stop::Refused(ImportError::ChunkTooLarge {
                path: path(),
                offset: at,
                size: sized(size),
                compressed: sized(compressed),
                cap: fmt_bytes(b.chunk_bytes),
            }));
        }
        if size > b.ratio_free_bytes && size / compressed.max(1) >= b.ratio {
            return Err(Stop::Refused(ImportError::ChunkRatio {
                path: path(),
                offset: at,
                size: sized(size),
                compressed: sized(compressed),
                ratio: b.ratio,
            }));
        }
        let total = self.budget.decompressed.saturating_add(size);
        if total > b.total_bytes {
            return Err(Stop::Refused(ImportError::DecompressedTooLarge {
                path: path(),
                offset: at,
                cap: fmt_bytes(b.total_bytes),
            }));
        }
        self.budget.decompressed = total;
        let records = decompress(&header.compression, &data, size).map_err(|d| match d {
            Decompressed::Damaged(why) => Stop::Damaged(why),
            Decompressed::Longer => Stop::Refused(ImportError::ChunkSizeLies {
                path: path(),
                offset: at,
                size: sized(size),
            }),
        })?;
        self.walk(&records, 0, true)
    }
}

/// A size as a person reads it: `1000 bytes`, `32 MiB`, `3.0 GiB (3200000000 bytes)`.
fn sized(n: u64) -> String {
    const MIB: u64 = 1024 * 1024;
    if n < MIB || n.is_multiple_of(MIB) {
        fmt_bytes(n)
    } else if n < 1024 * MIB {
        format!("{:.1} MiB ({n} bytes)", n as f64 / MIB as f64)
    } else {
        format!("{:.1} GiB ({n} bytes)", n as f64 / (1024 * MIB) as f64)
    }
}

/// Why a chunk's data did not decompress to its declared size.
enum Decompressed {
    Damaged(String),
    /// More bytes than the header said.
    Longer,
}

/// A chunk's records: `data` decompressed with `compression`, read to at most `size` + 1 bytes
/// (the header's size was checked against the bounds; one byte more shows it lied).
fn decompress<'d>(
    compression: &str,
    data: &'d [u8],
    size: u64,
) -> Result<Cow<'d, [u8]>, Decompressed> {
    let fault =
        |e: std::io::Error| Decompressed::Damaged(format!("Error during decompression: `{e}`"));
    // `size` is at most the per-chunk bound, so it fits memory and `usize`.
    let mut out = Vec::with_capacity(usize::try_from(size).unwrap_or(0));
    match compression {
        "" => {
            return match (data.len() as u64).cmp(&size) {
                std::cmp::Ordering::Equal => Ok(Cow::Borrowed(data)),
                std::cmp::Ordering::Greater => Err(Decompressed::Longer),
                std::cmp::Ordering::Less => Err(short(data.len() as u64, size)),
            };
        }
        "zstd" => zstd_frames(data, size + 1, &mut out).map_err(fault)?,
        "lz4" => lz4_flex::frame::FrameDecoder::new(data)
            .take(size + 1)
            .read_to_end(&mut out)
            .map(drop)
            .map_err(fault)?,
        other => {
            return Err(Decompressed::Damaged(
                mcap::McapError::UnsupportedCompression(other.to_string()).to_string(),
            ));
        }
    };
    match (out.len() as u64).cmp(&size) {
        std::cmp::Ordering::Equal => Ok(Cow::Owned(out)),
        std::cmp::Ordering::Greater => Err(Decompressed::Longer),
        std::cmp::Ordering::Less => Err(short(out.len() as u64, size)),
    }
}

/// The zstd frames of `data`, one after another as the format allows (skippable frames
/// skipped, each frame's checksum checked), decompressed into `out` until it holds `limit`
/// bytes: the decoder never produces more than that, whatever the frames hold.
fn zstd_frames(mut data: &[u8], limit: u64, out: &mut Vec<u8>) -> std::io::Result<()> {
    use ruzstd::decoding::StreamingDecoder;
    use ruzstd::decoding::errors::{FrameDecoderError, ReadFrameHeaderError};
    let invalid = |why: String| std::io::Error::new(std::io::ErrorKind::InvalidData, why);
    while !data.is_empty() && (out.len() as u64) < limit {
        let mut frame = match StreamingDecoder::new(&mut data) {
            Ok(frame) => frame,
            Err(FrameDecoderError::ReadFrameHeaderError(ReadFrameHeaderError::SkipFrame {
                length,
                ..
            })) => {
                data = data
                    .get(length as usize..)
                    .ok_or_else(|| invalid("a skippable frame runs past the chunk".into()))?;
                continue;
            }
            Err(e) => return Err(invalid(e.to_string())),
        };
        let room = limit - out.len() as u64;
        (&mut frame).take(room).read_to_end(out)?;
        // A frame read to its end (not cut at the limit) has all its content hashed.
        let decoder = &frame.decoder;
        if (out.len() as u64) < limit
            && decoder.is_finished()
            && let Some(expected) = decoder.get_checksum_from_data()
            && decoder.get_calculated_checksum() != Some(expected)
        {
            return Err(invalid(
                "a frame's checksum does not match its content".into(),
            ));
        }
    }
    Ok(())
}

fn short(got: u64, size: u64) -> Decompressed {
    Decompressed::Damaged(format!(
        "a chunk decompresses to {got} bytes where its header says {size}"
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An MCAP file of `chunks`, each (compression, declared size, data), after a header record.
    pub(crate) fn file_of(chunks: &[(&str, u64, Vec<u8>)]) -> Vec<u8> {
        let mut f = mcap::MAGIC.to_vec();
        let record = |f: &mut Vec<u8>, opcode: u8, body: &[u8]| {
            f.push(opcode);
            f.extend((body.len() as u64).to_le_bytes());
            f.extend(body);
        };
        // Header: profile "ros2", library "".
        let mut header = Vec::new();
        for s in ["ros2", ""] {
            header.extend((s.len() as u32).to_le_bytes());
            header.extend(s.as_bytes());
        }
        record(&mut f, op::HEADER, &header);
        for (compression, size, data) in chunks {
            let mut body = Vec::new();
            body.extend(0u64.to_le_bytes());
            body.extend(0u64.to_le_bytes());
            body.extend(size.to_le_bytes());
            body.extend(0u32.to_le_bytes());
            body.extend((compression.len() as u32).to_le_bytes());
            body.extend(compression.as_bytes());
            body.extend((data.len() as u64).to_le_bytes());
            body.extend(data);
            record(&mut f, op::CHUNK, &body);
        }
        record(&mut f, op::DATA_END, &0u32.to_le_bytes());
        f
    }

    fn read(bytes: &[u8], bounds: &Bounds, budget: &mut Budget) -> Result<Read, ImportError> {
        read_messages(
            Path::new("b.mcap"),
            bytes,
            bounds,
            budget,
            &mut |_, _, _, _| Ok(()),
        )
    }

    fn zeros_zstd(n: usize) -> Vec<u8> {
        zstd::encode_all(&vec![0u8; n][..], 1).unwrap()
    }

    #[test]
    fn chunks_within_the_bounds_are_read_and_counted() {
        // Zeros are records of opcode 0 and no body, 9 bytes each: a chunk holds whole ones.
        let small = 999;
        let f = file_of(&[
            ("zstd", small as u64, zeros_zstd(small)),
            ("", 9, vec![0x80, 0, 0, 0, 0, 0, 0, 0, 0]),
        ]);
        let mut budget = Budget::default();
        assert!(matches!(
            read(&f, &Bounds::DEFAULT, &mut budget),
            Ok(Read::Whole)
        ));
        assert_eq!(budget.decompressed, 1008);
    }

    #[test]
    fn the_total_bound_holds_over_chunks_and_files() {
        let bounds = Bounds {
            total_bytes: 150_000,
            ..Bounds::DEFAULT
        };
        let one = file_of(&[("zstd", 59_994, zeros_zstd(59_994))]);
        let mut budget = Budget::default();
        assert!(read(&one, &bounds, &mut budget).is_ok());
        assert!(read(&one, &bounds, &mut budget).is_ok());
        let err = read(&one, &bounds, &mut budget).unwrap_err();
        assert!(
            matches!(err, ImportError::DecompressedTooLarge { offset: 29, .. }),
            "{err:?}"
        );
    }

    #[test]
    fn a_header_that_understates_the_size_is_caught_after_one_byte_more() {
        let f = file_of(&[("zstd", 100, zeros_zstd(5_000_000))]);
        let err = read(&f, &Bounds::DEFAULT, &mut Budget::default()).unwrap_err();
        assert!(matches!(err, ImportError::ChunkSizeLies { .. }), "{err:?}");
        let f = file_of(&[("", 3, vec![0; 9])]);
        let err = read(&f, &Bounds::DEFAULT, &mut Budget::default()).unwrap_err();
        assert!(matches!(err, ImportError::ChunkSizeLies { .. }), "{err:?}");
    }

    /// A chunk may hold several zstd frames, skippable ones among them (the format allows it;
    /// libzstd reads them all): each is read, in order.
    #[test]
    fn a_chunk_of_several_zstd_frames_is_read_whole() {
        let mut data = zeros_zstd(900);
        data.extend(0x184D_2A50u32.to_le_bytes());
        data.extend(3u32.to_le_bytes());
        data.extend([1, 2, 3]);
        data.extend(zeros_zstd(99));
        let f = file_of(&[("zstd", 999, data)]);
        let mut budget = Budget::default();
        let read = read(&f, &Bounds::DEFAULT, &mut budget);
        assert!(matches!(read, Ok(Read::Whole)), "{read:?}");
    }

    /// A zstd frame's content checksum is checked: a chunk whose content does not match it is
    /// damaged, not read.
    #[test]
    fn a_zstd_frame_whose_checksum_does_not_match_is_damaged() {
        let mut enc = zstd::stream::Encoder::new(Vec::new(), 1).unwrap();
        enc.include_checksum(true).unwrap();
        std::io::Write::write_all(&mut enc, &[0u8; 999]).unwrap();
        let mut data = enc.finish().unwrap();
        let f = file_of(&[("zstd", 999, data.clone())]);
        assert!(read(&f, &Bounds::DEFAULT, &mut Budget::default()).is_ok());
        let last = data.len() - 1;
        data[last] ^= 1;
        let f = file_of(&[("zstd", 999, data)]);
        let err = read(&f, &Bounds::DEFAULT, &mut Budget::default()).unwrap_err();
        assert!(err.to_string().contains("checksum"), "{err}");
    }

    #[test]
    fn lz4_chunks_are_read_within_their_size() {
        let mut enc = lz4::EncoderBuilder::new().build(Vec::new()).unwrap();
        std::io::Write::write_all(&mut enc, &[0u8; 999]).unwrap();
        let (data, r) = enc.finish();
        r.unwrap();
        let f = file_of(&[("lz4", 999, data.clone())]);
        assert!(matches!(
            read(&f, &Bounds::DEFAULT, &mut Budget::default()),
            Ok(Read::Whole)
        ));
        let f = file_of(&[("lz4", 990, data)]);
        let err = read(&f, &Bounds::DEFAULT, &mut Budget::default()).unwrap_err();
        assert!(matches!(err, ImportError::ChunkSizeLies { .. }), "{err:?}");
    }

    #[test]
    fn a_damaged_chunk_before_any_message_is_not_mcap() {
        let f = file_of(&[("zstd", 100, b"not zstd at all".to_vec())]);
        let err = read(&f, &Bounds::DEFAULT, &mut Budget::default()).unwrap_err();
        assert!(matches!(err, ImportError::NotMcap { .. }), "{err:?}");
        let f = file_of(&[("brotli", 1, vec![0])]);
        let err = read(&f, &Bounds::DEFAULT, &mut Budget::default()).unwrap_err();
        assert!(err.to_string().contains("brotli"), "{err}");
    }
}
