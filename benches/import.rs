//! Importing a large bag (issue 19): one hour of a base driven at 50 Hz, commands and odometry
//! each at 50 Hz (360,000 messages), in an MCAP file with zstd chunks as `ros2 bag record` writes
//! it. The bag is written once, outside the timed part; each iteration is `advise import`'s work
//! short of writing the output: read, decompress, decode the CDR, sort, pair, and build the
//! demonstration. The figure to compare with disk speed is the file's bytes over the time.
//! `bombs`: how long the refusal of issue 31's decompression bombs takes.

use std::collections::BTreeMap;
use std::io::Cursor;

use advise::backend::ros2::msg::{Odometry, Time, Twist};
use advise::recording::{ImportOptions, import};
use advise::trace::Pose;
use byteorder::LittleEndian;
use criterion::{Criterion, Throughput, criterion_group, criterion_main};

const HZ: u64 = 50;
const SECONDS: u64 = 3600;

fn cdr<T: serde::Serialize>(v: &T) -> Vec<u8> {
    let mut out = vec![0x00, 0x01, 0x00, 0x00];
    out.extend(cdr_encoding::to_vec::<T, LittleEndian>(v).unwrap());
    out
}

/// The hour's bag: an arc driven at 0.5 m/s, odometry 4 ms after each command.
fn bag() -> Vec<u8> {
    let mut w = mcap::WriteOptions::new()
        .profile("ros2")
        .compression(Some(mcap::Compression::Zstd))
        .create(Cursor::new(Vec::new()))
        .unwrap();
    let none = BTreeMap::new();
    let twist = w
        .add_schema("geometry_msgs/msg/Twist", "ros2msg", b"")
        .unwrap();
    let odom = w
        .add_schema("nav_msgs/msg/Odometry", "ros2msg", b"")
        .unwrap();
    let cmd_ch = w.add_channel(twist, "/cmd_vel", "cdr", &none).unwrap();
    let odom_ch = w.add_channel(odom, "/odom", "cdr", &none).unwrap();
    let step = 1_000_000_000 / HZ;
    for k in 0..SECONDS * HZ {
        let t = k * step;
        let s = t as f64 * 1e-9;
        let header = |channel_id, log_time| mcap::records::MessageHeader {
            channel_id,
            sequence: k as u32,
            log_time,
            publish_time: log_time,
        };
        let pose = Pose::new(s.cos(), s.sin(), 0.1 * s);
        let o = Odometry::planar(Time::from_secs_f64(s), "odom", "base_link", pose, 0.5, 0.1);
        w.write_to_known_channel(&header(odom_ch, t), &cdr(&o))
            .unwrap();
        w.write_to_known_channel(
            &header(cmd_ch, t + 4_000_000),
            &cdr(&Twist::planar(0.5, 0.1)),
        )
        .unwrap();
    }
    w.finish().unwrap();
    w.into_inner().into_inner()
}

fn bench(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("hour.mcap");
    let bytes = bag();
    std::fs::write(&path, &bytes).unwrap();
    eprintln!(
        "import_hour_50hz: {} messages, {:.1} MB",
        2 * SECONDS * HZ,
        bytes.len() as f64 / 1e6
    );
    let mut g = c.benchmark_group("import");
    g.sample_size(10);
    g.throughput(Throughput::Bytes(bytes.len() as u64));
    g.bench_function("import_hour_50hz", |b| {
        b.iter(|| {
            let (demos, _) = import(&path, &ImportOptions::default()).unwrap();
            assert_eq!(demos[0].trace.len(), (SECONDS * HZ) as usize);
            demos
        })
    });
    g.finish();
}

/// An MCAP file of one zstd chunk declaring `size` bytes and holding `data` (issue 31's bombs).
fn bomb(size: u64, data: &[u8]) -> Vec<u8> {
    const MAGIC: &[u8] = b"\x89MCAP0\r\n";
    let mut f = MAGIC.to_vec();
    let record = |f: &mut Vec<u8>, opcode: u8, body: &[u8]| {
        f.push(opcode);
        f.extend((body.len() as u64).to_le_bytes());
        f.extend(body);
    };
    record(
        &mut f,
        0x01,
        &[4, 0, 0, 0, b'r', b'o', b's', b'2', 0, 0, 0, 0],
    );
    let mut chunk = Vec::new();
    chunk.extend([0u8; 16]);
    chunk.extend(size.to_le_bytes());
    chunk.extend(0u32.to_le_bytes());
    chunk.extend(4u32.to_le_bytes());
    chunk.extend(b"zstd");
    chunk.extend((data.len() as u64).to_le_bytes());
    chunk.extend(data);
    record(&mut f, 0x06, &chunk);
    record(&mut f, 0x0F, &0u32.to_le_bytes());
    record(&mut f, 0x02, &[0u8; 20]);
    f.extend(MAGIC);
    f
}

/// Decompression bombs (issue 31): a chunk declaring 3.2 GB (refused from its header), a 32 MiB
/// chunk of zeros in a few KB (refused by the ratio), and a chunk declaring 1,000 bytes that
/// expands to 256 MiB (refused one byte past its declared size). Before, the first kept `advise
/// import` busy past 180 s and a 138 KB chunk cost 100 s.
fn bombs(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let zeros = |n: usize| zstd::encode_all(&vec![0u8; n][..], 3).unwrap();
    let cases = [
        ("bomb_3_2_gb_header", bomb(3_200_000_000, &zeros(1 << 20))),
        ("bomb_ratio_32_mib", bomb(32 << 20, &zeros(32 << 20))),
        ("bomb_lying_header_256_mib", bomb(1000, &zeros(256 << 20))),
    ];
    let mut g = c.benchmark_group("import");
    g.sample_size(10);
    for (name, bytes) in cases {
        let path = dir.path().join(format!("{name}.mcap"));
        std::fs::write(&path, &bytes).unwrap();
        eprintln!("{name}: {} bytes on disk", bytes.len());
        g.bench_function(name, |b| {
            b.iter(|| import(&path, &ImportOptions::default()).unwrap_err())
        });
    }
    g.finish();
}

criterion_group!(benches, bench, bombs);
criterion_main!(benches);
