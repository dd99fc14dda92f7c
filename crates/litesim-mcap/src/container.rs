//! The MCAP container itself (<https://mcap.dev/spec>, version 0): records,
//! zstd-compressed chunks with their message indexes (schemas and channels
//! in the first chunk, before the metadata), and a summary section
//! (schemas and channels repeated, statistics, chunk and metadata indexes,
//! summary offsets) whose CRCs readers check.
//!
//! Why not the `mcap` crate's writer: it feeds every record field through a
//! streaming zstd encoder and two CRC writers one small write at a time,
//! which made a short run's file cost three times its simulation. Here a
//! chunk's records are appended to a buffer and compressed in one call when
//! the chunk is full; the same file structure, checked by the `mcap`
//! crate's reader (tests) and the Python `mcap` reader (CLI tests).

use std::io::Write;

/// The magic at both ends of a file.
const MAGIC: &[u8; 8] = b"\x89MCAP0\r\n";

/// Record opcodes.
mod op {
    pub const HEADER: u8 = 0x01;
    pub const FOOTER: u8 = 0x02;
    pub const SCHEMA: u8 = 0x03;
    pub const CHANNEL: u8 = 0x04;
    pub const MESSAGE: u8 = 0x05;
    pub const CHUNK: u8 = 0x06;
    pub const MESSAGE_INDEX: u8 = 0x07;
    pub const CHUNK_INDEX: u8 = 0x08;
    pub const STATISTICS: u8 = 0x0B;
    pub const METADATA: u8 = 0x0C;
    pub const METADATA_INDEX: u8 = 0x0D;
    pub const SUMMARY_OFFSET: u8 = 0x0E;
    pub const DATA_END: u8 = 0x0F;
}

/// Uncompressed bytes of records after which a chunk is compressed and
/// written: small enough that a streamed run's chunks are compressed while
/// it goes on, large enough for zstd to find the repetition between ticks
/// (~40 ticks of two actors). 64 KiB rather than 256: the writer's buffers
/// and zstd's workspace then fit in less fresh memory — one transparent
/// huge page fewer to zero per `litesim run --mcap`, −0.22 ms end to end —
/// for a file 4.6 % larger (README example: 233 → 244 KB).
const CHUNK_LIMIT: usize = 64 * 1024;

/// zstd level of the chunks: one of its fast (negative) levels. On a run's
/// messages (`zstd -b` on the README example's 1 MB) it compresses 10×
/// at 1.9 GB/s, against 13× at 1.25 GB/s at level 1: the ticks repeat each
/// other, and the writer's time is what a run pays.
const ZSTD_LEVEL: i32 = -3;

/// A record body being assembled: little-endian fields as the spec lays
/// them out.
#[derive(Default)]
struct Body(Vec<u8>);

impl Body {
    fn u8(&mut self, v: u8) -> &mut Self {
        self.0.push(v);
        self
    }
    fn u16(&mut self, v: u16) -> &mut Self {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }
    fn u32(&mut self, v: u32) -> &mut Self {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }
    fn u64(&mut self, v: u64) -> &mut Self {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }
    /// A string or byte array with its u32 length.
    fn bytes(&mut self, v: &[u8]) -> &mut Self {
        self.u32(len32(v.len()));
        self.0.extend_from_slice(v);
        self
    }
    fn str(&mut self, v: &str) -> &mut Self {
        self.bytes(v.as_bytes())
    }
    /// A map of strings: its entries' byte length, then key, value, ….
    fn str_map<'a>(&mut self, m: impl Iterator<Item = (&'a str, &'a str)>) -> &mut Self {
        let at = self.0.len();
        self.u32(0);
        for (k, v) in m {
            self.str(k).str(v);
        }
        let n = len32(self.0.len() - at - 4);
        self.0[at..at + 4].copy_from_slice(&n.to_le_bytes());
        self
    }
    /// The body as a whole record: opcode, u64 length, body.
    fn record(&self, opcode: u8, out: &mut Vec<u8>) {
        out.push(opcode);
        out.extend_from_slice(&(self.0.len() as u64).to_le_bytes());
        out.extend_from_slice(&self.0);
    }
}

/// A length as MCAP's u32 prefix. Every prefixed field here is far below
/// 4 GiB (schemas, names, one tick's message index); saturating instead of
/// wrapping keeps a corrupt length from aliasing a valid one.
fn len32(n: usize) -> u32 {
    u32::try_from(n).unwrap_or(u32::MAX)
}

/// Bytes written so far, the position, and a CRC over a stretch of them
/// (the data section, then the summary section).
struct Out<W: Write> {
    w: W,
    pos: u64,
    crc: crc32fast::Hasher,
}

impl<W: Write> Out<W> {
    fn put(&mut self, b: &[u8]) -> std::io::Result<()> {
        self.w.write_all(b)?;
        self.crc.update(b);
        self.pos += b.len() as u64;
        Ok(())
    }
}

/// Where a compressed chunk's index points.
struct ChunkIndex {
    start: u64,
    end: u64,
    offset: u64,
    length: u64,
    message_index_offsets: Vec<(u16, u64)>,
    message_index_length: u64,
    compressed: u64,
    uncompressed: u64,
}

/// An MCAP file being written: schemas, channels and metadata as they are
/// added, messages into chunks, then [`Container::finish`]. Channel and
/// schema ids are dense (schemas from 1: 0 means "no schema").
pub(crate) struct Container<W: Write> {
    out: Out<W>,
    /// Schema and channel records as written, repeated in the summary.
    schemas: Vec<Vec<u8>>,
    channels: Vec<Vec<u8>>,
    /// Messages per channel id.
    counts: Vec<u64>,
    /// First and last message time of the file.
    bounds: Option<(u64, u64)>,
    /// The open chunk's records, uncompressed, its message time bounds and,
    /// per channel id, (log time, offset in `chunk`) of its messages.
    chunk: Vec<u8>,
    chunk_bounds: Option<(u64, u64)>,
    chunk_messages: Vec<Vec<(u64, u64)>>,
    chunk_indexes: Vec<ChunkIndex>,
    /// (offset, length, name) of each metadata record.
    metadata: Vec<(u64, u64, String)>,
    zstd: zstd::bulk::Compressor<'static>,
    compressed: Vec<u8>,
    scratch: Vec<u8>,
}

impl<W: Write> Container<W> {
    /// Starts a file: magic and header.
    pub(crate) fn new(w: W, profile: &str, library: &str) -> std::io::Result<Self> {
        let mut c = Container {
            out: Out {
                w,
                pos: 0,
                crc: crc32fast::Hasher::new(),
            },
            schemas: Vec::new(),
            channels: Vec::new(),
            counts: Vec::new(),
            bounds: None,
            // Room for the record that crosses the limit (a tick's
            // messages are a few KB; the schemas, in the first chunk, ~60 KB).
            chunk: Vec::with_capacity(CHUNK_LIMIT + 64 * 1024),
            chunk_bounds: None,
            chunk_messages: Vec::new(),
            chunk_indexes: Vec::new(),
            metadata: Vec::new(),
            zstd: zstd::bulk::Compressor::new(ZSTD_LEVEL)?,
            compressed: Vec::new(),
            scratch: Vec::new(),
        };
        c.out.put(MAGIC)?;
        let mut b = Body::default();
        b.str(profile).str(library);
        c.emit(op::HEADER, &b)?;
        Ok(c)
    }

    /// A record straight into the file (outside chunks).
    fn emit(&mut self, opcode: u8, b: &Body) -> std::io::Result<()> {
        self.scratch.clear();
        b.record(opcode, &mut self.scratch);
        self.out.put(&self.scratch)
    }

    /// Adds a schema; its id.
    pub(crate) fn add_schema(
        &mut self,
        name: &str,
        encoding: &str,
        data: &[u8],
    ) -> std::io::Result<u16> {
        let id = u16::try_from(self.schemas.len() + 1).map_err(|_| too_many("schemas"))?;
        let mut b = Body::default();
        b.u16(id).str(name).str(encoding).bytes(data);
        // Into the chunk, compressed: the OSI schema alone is 52 KB, and it
        // is repeated in the summary anyway.
        b.record(op::SCHEMA, &mut self.chunk);
        self.schemas.push(b.0);
        Ok(id)
    }

    /// Adds a channel of schema `schema` (no metadata); its id.
    pub(crate) fn add_channel(
        &mut self,
        schema: u16,
        topic: &str,
        message_encoding: &str,
    ) -> std::io::Result<u16> {
        let id = u16::try_from(self.channels.len()).map_err(|_| too_many("channels"))?;
        let mut b = Body::default();
        b.u16(id)
            .u16(schema)
            .str(topic)
            .str(message_encoding)
            .str_map(std::iter::empty());
        b.record(op::CHANNEL, &mut self.chunk);
        self.channels.push(b.0);
        self.counts.push(0);
        self.chunk_messages.push(Vec::new());
        Ok(id)
    }

    /// A metadata record (outside chunks, as the spec requires).
    pub(crate) fn write_metadata<'a>(
        &mut self,
        name: &str,
        entries: impl Iterator<Item = (&'a str, &'a str)>,
    ) -> std::io::Result<()> {
        self.flush_chunk()?;
        let mut b = Body::default();
        b.str(name).str_map(entries);
        let offset = self.out.pos;
        self.emit(op::METADATA, &b)?;
        self.metadata
            .push((offset, self.out.pos - offset, name.to_string()));
        Ok(())
    }

    /// A message on channel `ch` (added before), logged and published at
    /// `time`, numbered 1, 2, … per channel (the sequence wraps after
    /// 2³² messages, as MCAP allows).
    pub(crate) fn message(&mut self, ch: u16, time: u64, data: &[u8]) -> std::io::Result<()> {
        let k = usize::from(ch);
        if k >= self.channels.len() {
            return Err(std::io::Error::other(format!("MCAP: no channel {ch}")));
        }
        self.counts[k] += 1;
        let sequence = self.counts[k] as u32;
        let (log_time, publish_time) = (time, time);
        let offset = self.chunk.len() as u64;
        let c = &mut self.chunk;
        c.push(op::MESSAGE);
        c.extend_from_slice(&(2 + 4 + 8 + 8 + data.len() as u64).to_le_bytes());
        c.extend_from_slice(&ch.to_le_bytes());
        c.extend_from_slice(&sequence.to_le_bytes());
        c.extend_from_slice(&log_time.to_le_bytes());
        c.extend_from_slice(&publish_time.to_le_bytes());
        c.extend_from_slice(data);
        self.chunk_messages[k].push((log_time, offset));
        let widen = |b: Option<(u64, u64)>| match b {
            None => Some((log_time, log_time)),
            Some((s, e)) => Some((s.min(log_time), e.max(log_time))),
        };
        self.chunk_bounds = widen(self.chunk_bounds);
        self.bounds = widen(self.bounds);
        if self.chunk.len() >= CHUNK_LIMIT {
            self.flush_chunk()?;
        }
        Ok(())
    }

    /// Compresses and writes the open chunk and its message indexes.
    fn flush_chunk(&mut self) -> std::io::Result<()> {
        if self.chunk.is_empty() {
            return Ok(());
        }
        let (start, end) = self.chunk_bounds.take().unwrap_or((0, 0));
        let uncompressed_crc = crc32fast::hash(&self.chunk);
        self.compressed.clear();
        self.compressed
            .reserve(zstd::zstd_safe::compress_bound(self.chunk.len()));
        self.zstd
            .compress_to_buffer(&self.chunk[..], &mut self.compressed)?;
        let offset = self.out.pos;
        let mut head = Body::default();
        head.u64(start)
            .u64(end)
            .u64(self.chunk.len() as u64)
            .u32(uncompressed_crc)
            .str("zstd")
            .u64(self.compressed.len() as u64);
        let mut rec = Vec::with_capacity(9 + head.0.len());
        rec.push(op::CHUNK);
        rec.extend_from_slice(&((head.0.len() + self.compressed.len()) as u64).to_le_bytes());
        rec.extend_from_slice(&head.0);
        self.out.put(&rec)?;
        self.out.put(&self.compressed)?;
        let length = self.out.pos - offset;

        let mut index_offsets = Vec::new();
        let index_start = self.out.pos;
        for (ch, entries) in self.chunk_messages.iter_mut().enumerate() {
            if entries.is_empty() {
                continue;
            }
            let mut b = Body::default();
            b.u16(ch as u16).u32(len32(entries.len() * 16));
            for &(t, o) in entries.iter() {
                b.u64(t).u64(o);
            }
            entries.clear();
            index_offsets.push((ch as u16, self.out.pos));
            self.scratch.clear();
            b.record(op::MESSAGE_INDEX, &mut self.scratch);
            self.out.put(&self.scratch)?;
        }
        self.chunk_indexes.push(ChunkIndex {
            start,
            end,
            offset,
            length,
            message_index_offsets: index_offsets,
            message_index_length: self.out.pos - index_start,
            compressed: self.compressed.len() as u64,
            uncompressed: self.chunk.len() as u64,
        });
        self.chunk.clear();
        Ok(())
    }

    /// Messages written so far on channel `ch`.
    pub(crate) fn messages(&self, ch: u16) -> u64 {
        self.counts.get(usize::from(ch)).copied().unwrap_or(0)
    }

    /// Ends the data section and writes the summary, the footer and the
    /// closing magic; the writer back.
    pub(crate) fn finish(mut self) -> std::io::Result<W> {
        self.flush_chunk()?;
        let data_crc = std::mem::replace(&mut self.out.crc, crc32fast::Hasher::new()).finalize();
        let mut b = Body::default();
        b.u32(data_crc);
        self.emit(op::DATA_END, &b)?;

        // The summary section, its CRC from here to the footer's offsets.
        self.out.crc = crc32fast::Hasher::new();
        let summary_start = self.out.pos;
        let mut offsets: Vec<(u8, u64, u64)> = Vec::new();
        let mut group = |c: &mut Self, opcode: u8, records: &[Body]| -> std::io::Result<()> {
            if records.is_empty() {
                return Ok(());
            }
            let start = c.out.pos;
            for r in records {
                c.emit(opcode, r)?;
            }
            offsets.push((opcode, start, c.out.pos - start));
            Ok(())
        };
        let schemas: Vec<Body> = self.schemas.iter().cloned().map(Body).collect();
        group(&mut self, op::SCHEMA, &schemas)?;
        let channels: Vec<Body> = self.channels.iter().cloned().map(Body).collect();
        group(&mut self, op::CHANNEL, &channels)?;

        let (first, last) = self.bounds.unwrap_or((0, 0));
        let mut stats = Body::default();
        stats
            .u64(self.counts.iter().sum())
            .u16(self.schemas.len() as u16)
            .u32(len32(self.channels.len()))
            .u32(0)
            .u32(len32(self.metadata.len()))
            .u32(len32(self.chunk_indexes.len()))
            .u64(first)
            .u64(last);
        let with: Vec<(u16, u64)> = (0..self.counts.len())
            .filter(|&c| self.counts[c] > 0)
            .map(|c| (c as u16, self.counts[c]))
            .collect();
        stats.u32(len32(with.len() * 10));
        for (c, n) in with {
            stats.u16(c).u64(n);
        }
        group(&mut self, op::STATISTICS, &[stats])?;

        let chunks: Vec<Body> = self
            .chunk_indexes
            .iter()
            .map(|ci| {
                let mut b = Body::default();
                b.u64(ci.start)
                    .u64(ci.end)
                    .u64(ci.offset)
                    .u64(ci.length)
                    .u32(len32(ci.message_index_offsets.len() * 10));
                for &(c, o) in &ci.message_index_offsets {
                    b.u16(c).u64(o);
                }
                b.u64(ci.message_index_length)
                    .str("zstd")
                    .u64(ci.compressed)
                    .u64(ci.uncompressed);
                b
            })
            .collect();
        group(&mut self, op::CHUNK_INDEX, &chunks)?;
        let metadata: Vec<Body> = self
            .metadata
            .iter()
            .map(|(o, l, n)| {
                let mut b = Body::default();
                b.u64(*o).u64(*l).str(n);
                b
            })
            .collect();
        group(&mut self, op::METADATA_INDEX, &metadata)?;

        let summary_offset_start = self.out.pos;
        for (opcode, start, length) in offsets {
            let mut b = Body::default();
            b.u8(opcode).u64(start).u64(length);
            self.emit(op::SUMMARY_OFFSET, &b)?;
        }
        // The footer: its CRC covers the summary section and the footer up
        // to (not including) the CRC itself.
        let mut footer = Vec::with_capacity(29);
        footer.push(op::FOOTER);
        footer.extend_from_slice(&20u64.to_le_bytes());
        footer.extend_from_slice(&summary_start.to_le_bytes());
        footer.extend_from_slice(&summary_offset_start.to_le_bytes());
        self.out.crc.update(&footer);
        let summary_crc = self.out.crc.clone().finalize();
        footer.extend_from_slice(&summary_crc.to_le_bytes());
        self.out.w.write_all(&footer)?;
        self.out.w.write_all(MAGIC)?;
        self.out.w.flush()?;
        Ok(self.out.w)
    }
}

fn too_many(what: &str) -> std::io::Error {
    std::io::Error::other(format!("MCAP: more than 65,535 {what}"))
}
