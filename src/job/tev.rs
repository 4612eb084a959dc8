//! Streaming the image to the tev HDR viewer (`--display HOST:PORT`) over
//! its TCP protocol, as pbrt-v4's `--display-server` does: a CreateImage
//! packet, then UpdateImageV3 packets of linear RGB after every pass.
//!
//! Wire format (little-endian): every packet is a u32 length (the whole
//! packet's, these four bytes included), a u8 type, and its payload.
//! - CreateImage (4): u8 grab focus, image name (NUL-terminated), i32 width,
//!   i32 height, i32 channel count, the channel names (NUL-terminated).
//! - UpdateImageV3 (6): u8 grab focus, image name, i32 channel count, the
//!   channel names, i32 x, y, width, height of the block, i64 offset and
//!   i64 stride of each channel into the data, then the f32 data (here
//!   interleaved: channel c of pixel i at c + 3 i).

use std::io::Write;
use std::net::TcpStream;
use std::time::Duration;

use anyhow::{Context, Result};
use glam::Vec3;

const CREATE_IMAGE: u8 = 4;
const UPDATE_IMAGE_V3: u8 = 6;
const CHANNELS: [&str; 3] = ["R", "G", "B"];
/// Rows per update packet: bounds a packet to a few MB.
const ROWS_PER_PACKET: u32 = 64;

/// A connection to tev showing one image.
pub struct Tev {
    stream: TcpStream,
    name: String,
    width: u32,
    height: u32,
}

/// A packet under construction.
struct Packet(Vec<u8>);

impl Packet {
    fn new(kind: u8) -> Self {
        let mut bytes = vec![0; 4];
        bytes.push(kind);
        Packet(bytes)
    }
    fn u8(&mut self, v: u8) -> &mut Self {
        self.0.push(v);
        self
    }
    fn i32(&mut self, v: i32) -> &mut Self {
        self.0.extend(v.to_le_bytes());
        self
    }
    fn i64(&mut self, v: i64) -> &mut Self {
        self.0.extend(v.to_le_bytes());
        self
    }
    fn f32(&mut self, v: f32) -> &mut Self {
        self.0.extend(v.to_le_bytes());
        self
    }
    fn str(&mut self, s: &str) -> &mut Self {
        // A NUL inside would end the string early: tev names never hold one.
        self.0.extend(s.bytes().filter(|&b| b != 0));
        self.0.push(0);
        self
    }
    fn finish(&mut self) -> &[u8] {
        let n = self.0.len() as u32;
        self.0[..4].copy_from_slice(&n.to_le_bytes());
        &self.0
    }
}

impl Tev {
    /// Connects to tev at `address` (HOST:PORT) and creates the image.
    pub fn connect(address: &str, name: &str, width: u32, height: u32) -> Result<Self> {
        let stream = TcpStream::connect(address)
            .with_context(|| format!("cannot reach tev at {address}"))?;
        stream.set_write_timeout(Some(Duration::from_secs(10)))?;
        let mut tev = Self {
            stream,
            name: name.to_string(),
            width,
            height,
        };
        let mut p = Packet::new(CREATE_IMAGE);
        p.u8(1)
            .str(name)
            .i32(width as i32)
            .i32(height as i32)
            .i32(CHANNELS.len() as i32);
        for c in CHANNELS {
            p.str(c);
        }
        tev.stream.write_all(p.finish())?;
        Ok(tev)
    }

    /// Sends the whole image (row-major linear RGB).
    pub fn update(&mut self, rgb: &[Vec3]) -> Result<()> {
        for y0 in (0..self.height).step_by(ROWS_PER_PACKET as usize) {
            let rows = ROWS_PER_PACKET.min(self.height - y0);
            let mut p = Packet::new(UPDATE_IMAGE_V3);
            p.u8(0).str(&self.name).i32(CHANNELS.len() as i32);
            for c in CHANNELS {
                p.str(c);
            }
            p.i32(0)
                .i32(y0 as i32)
                .i32(self.width as i32)
                .i32(rows as i32);
            for c in 0..CHANNELS.len() {
                p.i64(c as i64);
            }
            for _ in CHANNELS {
                p.i64(CHANNELS.len() as i64);
            }
            let start = (y0 * self.width) as usize;
            for c in &rgb[start..start + (rows * self.width) as usize] {
                p.f32(c.x).f32(c.y).f32(c.z);
            }
            self.stream.write_all(p.finish())?;
        }
        Ok(())
    }
}
