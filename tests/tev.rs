//! `--display HOST:PORT` streams the image to tev: checked against a small
//! fake tev that parses the protocol (CreateImage, then UpdateImageV3
//! blocks) and assembles the picture, which must be the render's EXR.

use crate::common;

use std::io::Read;
use std::net::TcpListener;
use std::process::Command;

struct Reader<'a>(&'a [u8], usize);

impl Reader<'_> {
    fn u8(&mut self) -> u8 {
        self.1 += 1;
        self.0[self.1 - 1]
    }
    fn take<const N: usize>(&mut self) -> [u8; N] {
        self.1 += N;
        self.0[self.1 - N..self.1].try_into().unwrap()
    }
    fn i32(&mut self) -> i32 {
        i32::from_le_bytes(self.take())
    }
    fn i64(&mut self) -> i64 {
        i64::from_le_bytes(self.take())
    }
    fn f32(&mut self) -> f32 {
        f32::from_le_bytes(self.take())
    }
    fn str(&mut self) -> String {
        let end = self.0[self.1..].iter().position(|&b| b == 0).unwrap();
        let s = String::from_utf8(self.0[self.1..self.1 + end].to_vec()).unwrap();
        self.1 += end + 1;
        s
    }
}

/// A fake tev: returns (image name, width, height, last RGB) once the
/// connection closes.
fn fake_tev(listener: TcpListener) -> (String, usize, usize, Vec<[f32; 3]>, usize) {
    let (mut stream, _) = listener.accept().unwrap();
    let mut bytes = Vec::new();
    stream.read_to_end(&mut bytes).unwrap();
    let (mut name, mut width, mut height) = (String::new(), 0, 0);
    let mut image = Vec::new();
    let mut updates = 0;
    let mut at = 0;
    while at < bytes.len() {
        let len = u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()) as usize;
        let mut r = Reader(&bytes[at + 4..at + len], 0);
        match r.u8() {
            4 => {
                r.u8();
                name = r.str();
                width = r.i32() as usize;
                height = r.i32() as usize;
                let n = r.i32();
                let channels: Vec<String> = (0..n).map(|_| r.str()).collect();
                assert_eq!(channels, ["R", "G", "B"]);
                image = vec![[0.0; 3]; width * height];
            }
            6 => {
                r.u8();
                assert_eq!(r.str(), name);
                let n = r.i32() as usize;
                let channels: Vec<String> = (0..n).map(|_| r.str()).collect();
                assert_eq!(channels, ["R", "G", "B"]);
                let (x, y, w, h) = (r.i32(), r.i32(), r.i32() as usize, r.i32() as usize);
                let offsets: Vec<i64> = (0..n).map(|_| r.i64()).collect();
                let strides: Vec<i64> = (0..n).map(|_| r.i64()).collect();
                let data: Vec<f32> = (0..w * h * n).map(|_| r.f32()).collect();
                for i in 0..w * h {
                    let (px, py) = (x as usize + i % w, y as usize + i / w);
                    for c in 0..n {
                        image[py * width + px][c] =
                            data[(offsets[c] + i as i64 * strides[c]) as usize];
                    }
                }
                updates += 1;
            }
            other => panic!("unexpected packet type {other}"),
        }
        assert_eq!(r.1, len - 4, "packet length");
        at += len;
    }
    (name, width, height, image, updates)
}

#[test]
fn the_display_stream_is_the_rendered_image() {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let address = listener.local_addr().unwrap().to_string();
    let server = std::thread::spawn(move || fake_tev(listener));
    let dir = tempfile::tempdir().unwrap();
    let stem = dir.path().join("box");
    let out = Command::new(env!("CARGO_BIN_EXE_prism"))
        .args([
            "render",
            "scenes/cornell-box.toml",
            "-q",
            "--resolution",
            "40x70",
            "--spp",
            "16",
        ])
        .args(["--no-spectral", "--display", &address, "-o"])
        .arg(&stem)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let (name, width, height, image, updates) = server.join().unwrap();
    assert_eq!((name.as_str(), width, height), ("box", 40, 70));
    // 16 spp: passes of one sample (a sixteenth), each sent in two blocks
    // of rows (64 and 6).
    assert_eq!(updates, 16 * 2);
    let (_, exr) = common::exr_channels(&stem.with_extension("exr"));
    for (c, name) in ["R", "G", "B"].iter().enumerate() {
        for (i, v) in exr[*name].iter().enumerate() {
            assert_eq!(image[i][c], *v, "pixel {i} channel {name}");
        }
    }
}

#[test]
fn an_unreachable_display_is_a_warning_not_an_error() {
    // A port nothing listens on: bind one, then close it.
    let address = TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .to_string();
    let dir = tempfile::tempdir().unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_prism"))
        .args([
            "render",
            "scenes/cornell-box.toml",
            "-q",
            "--resolution",
            "16x16",
            "--spp",
            "2",
        ])
        .args(["--no-spectral", "--display", &address, "-o"])
        .arg(dir.path().join("box"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("cannot reach tev") && err.contains("rendering without a display"),
        "{err}"
    );
}
