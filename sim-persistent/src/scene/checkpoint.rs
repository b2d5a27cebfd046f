//! Checkpoints of a scene run (`sim-persistent run --resume`): what a killed run needs to go
//! on from its last checkpoint with the same result as an uninterrupted run.
//!
//! A checkpoint holds the steps done, the frames written and the PNG framing of the first
//! frame (so that the frames keep one scale), the simulator's [`Snapshot`] and the nodes the
//! sticking obstacles hold. Taking one empties the simulator's caches
//! ([`crate::integrator::Simulator::flush_caches`]), which a restored simulator starts without, so the resumed
//! run and the uninterrupted one take every step from the same state, bit for bit; for the
//! same reason the checkpoint interval is part of the run's fingerprint.
//!
//! **File.** `checkpoint.bin` in the output folder, replaced atomically (temporary file,
//! then rename): the magic `YWPCKPT1`, the payload length (u64), the payload, and the FNV-1a
//! checksum of the payload ([`solver::checksum::fnv1a`]); all numbers little endian. The
//! payload: the run's fingerprint, steps, frames, the framing (tag 0 none, 1 auto with its
//! margin, 2 fixed with centre and scale; three f64), the time, `n` and the `n` coordinates,
//! velocities and fixed flags, the friction anchors, the held nodes and the time of the
//! first hold. A file with another magic, a short or long payload, a wrong checksum or
//! another fingerprint is refused with what is wrong, never used.

use std::path::{Path, PathBuf};

use yarn_output::render::Framing;

use super::{SceneError, SceneRun};
use crate::integrator::Snapshot;

/// The checkpoint file's name in the output folder.
pub const CHECKPOINT_FILE: &str = "checkpoint.bin";

const MAGIC: &[u8; 8] = b"YWPCKPT1";

/// A checkpoint of a scene run (module documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct RunCheckpoint {
    /// Steps done.
    pub steps: usize,
    /// Frames written (frame 0 is the initial state).
    pub frames: usize,
    /// The framing of the PNG frames, once the first has been drawn.
    pub framing: Option<Framing>,
    /// The simulator's state.
    pub snapshot: Snapshot,
    /// Per node: held by a sticking obstacle.
    pub held: Vec<bool>,
    /// Time of the first hold (s).
    pub first_hold: Option<f64>,
}

impl SceneRun {
    /// A checkpoint after `steps` steps and `frames` frames; empties the simulator's caches
    /// (module documentation).
    pub fn checkpoint(
        &mut self,
        steps: usize,
        frames: usize,
        framing: Option<Framing>,
    ) -> RunCheckpoint {
        self.sim.flush_caches();
        RunCheckpoint {
            steps,
            frames,
            framing,
            snapshot: self.sim.snapshot(),
            held: self.sticky.contacts.held.clone(),
            first_hold: self.sticky.contacts.first,
        }
    }

    /// Restores `checkpoint` into this run, freshly built from the same scene.
    pub fn resume(&mut self, checkpoint: &RunCheckpoint) -> Result<(), SceneError> {
        if checkpoint.held.len() != self.sticky.contacts.held.len() {
            return Err(SceneError::Invalid(format!(
                "the checkpoint holds {} nodes, the scene {}",
                checkpoint.held.len(),
                self.sticky.contacts.held.len()
            )));
        }
        self.sim.restore(&checkpoint.snapshot)?;
        self.sticky.contacts.held.clone_from(&checkpoint.held);
        self.sticky.contacts.first = checkpoint.first_hold;
        Ok(())
    }
}

/// Writes `checkpoint` of the run with `fingerprint` to `dir/checkpoint.bin` (atomically).
pub fn write(dir: &Path, checkpoint: &RunCheckpoint, fingerprint: u64) -> Result<(), SceneError> {
    let c = checkpoint;
    let s = &c.snapshot;
    let mut p = Vec::with_capacity(64 + 17 * s.q.len() + 8 * s.anchors.len() + c.held.len());
    let u = |p: &mut Vec<u8>, v: usize| p.extend_from_slice(&(v as u64).to_le_bytes());
    let f = |p: &mut Vec<u8>, v: f64| p.extend_from_slice(&v.to_le_bytes());
    p.extend_from_slice(&fingerprint.to_le_bytes());
    u(&mut p, c.steps);
    u(&mut p, c.frames);
    let (tag, values) = match c.framing {
        None => (0, [0.0; 3]),
        Some(Framing::Auto { margin }) => (1, [margin, 0.0, 0.0]),
        Some(Framing::Fixed {
            center,
            pixels_per_metre,
        }) => (2, [center[0], center[1], pixels_per_metre]),
    };
    p.push(tag);
    values.iter().for_each(|&v| f(&mut p, v));
    f(&mut p, s.time);
    u(&mut p, s.q.len());
    s.q.iter().chain(&s.v).for_each(|&v| f(&mut p, v));
    p.extend(s.fixed.iter().map(|&b| u8::from(b)));
    u(&mut p, s.anchors.len());
    s.anchors.iter().for_each(|&v| f(&mut p, v));
    u(&mut p, c.held.len());
    p.extend(c.held.iter().map(|&b| u8::from(b)));
    p.push(u8::from(c.first_hold.is_some()));
    f(&mut p, c.first_hold.unwrap_or(0.0));

    let mut bytes = MAGIC.to_vec();
    bytes.extend_from_slice(&(p.len() as u64).to_le_bytes());
    bytes.extend_from_slice(&p);
    bytes.extend_from_slice(&solver::checksum::fnv1a(&p).to_le_bytes());
    let path = dir.join(CHECKPOINT_FILE);
    let tmp = dir.join(format!(".{CHECKPOINT_FILE}.{}.tmp", std::process::id()));
    std::fs::write(&tmp, &bytes)
        .and_then(|()| std::fs::rename(&tmp, &path))
        .map_err(|source| SceneError::Io { path, source })
}

/// Reads `dir/checkpoint.bin` of the run with `fingerprint`: `None` when there is none,
/// an error naming the file and the problem when it is not a whole checkpoint of this run.
pub fn read(dir: &Path, fingerprint: u64) -> Result<Option<RunCheckpoint>, SceneError> {
    let path = dir.join(CHECKPOINT_FILE);
    let bytes = match std::fs::read(&path) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(source) => return Err(SceneError::Io { path, source }),
    };
    decode(&bytes, fingerprint)
        .map(Some)
        .map_err(|problem| SceneError::Checkpoint { path, problem })
}

/// The checkpoint in `bytes`, or what is wrong with them.
fn decode(bytes: &[u8], fingerprint: u64) -> Result<RunCheckpoint, String> {
    let body = bytes
        .strip_prefix(MAGIC.as_slice())
        .ok_or("not a sim-persistent checkpoint (bad magic)")?;
    let mut r = Reader { bytes: body };
    let length = r.u64()? as usize;
    if r.bytes.len() != length.saturating_add(8) {
        return Err(format!(
            "truncated or padded: the header promises {length} payload bytes and a checksum, \
             the file holds {}",
            r.bytes.len()
        ));
    }
    let (payload, sum) = r.bytes.split_at(length);
    let sum = u64::from_le_bytes(sum.try_into().expect("8 bytes"));
    if solver::checksum::fnv1a(payload) != sum {
        return Err("corrupted: the checksum does not match the payload".into());
    }
    let mut r = Reader { bytes: payload };
    if r.u64()? != fingerprint {
        return Err(
            "was written by a run of another scene or checkpoint interval; remove it or run \
             the original scene"
                .into(),
        );
    }
    let steps = r.size()?;
    let frames = r.size()?;
    let tag = r.byte()?;
    let values = [r.f64()?, r.f64()?, r.f64()?];
    let framing = match tag {
        0 => None,
        1 => Some(Framing::Auto { margin: values[0] }),
        2 => Some(Framing::Fixed {
            center: [values[0], values[1]],
            pixels_per_metre: values[2],
        }),
        t => return Err(format!("unknown framing tag {t}")),
    };
    let time = r.f64()?;
    let n = r.size()?;
    let q = r.f64s(n)?;
    let v = r.f64s(n)?;
    let fixed = r.flags(n)?;
    let m = r.size()?;
    let anchors = r.f64s(m)?;
    let nodes = r.size()?;
    let held = r.flags(nodes)?;
    let has_first = r.byte()? != 0;
    let first = r.f64()?;
    if !r.bytes.is_empty() {
        return Err(format!("{} bytes after the last field", r.bytes.len()));
    }
    Ok(RunCheckpoint {
        steps,
        frames,
        framing,
        snapshot: Snapshot {
            time,
            q,
            v,
            fixed,
            anchors,
        },
        held,
        first_hold: has_first.then_some(first),
    })
}

/// Little-endian fields from the front of a byte slice.
struct Reader<'a> {
    bytes: &'a [u8],
}

impl Reader<'_> {
    fn take(&mut self, n: usize) -> Result<&[u8], String> {
        if self.bytes.len() < n {
            return Err("truncated payload".into());
        }
        let (head, rest) = self.bytes.split_at(n);
        self.bytes = rest;
        Ok(head)
    }
    fn u64(&mut self) -> Result<u64, String> {
        Ok(u64::from_le_bytes(self.take(8)?.try_into().expect("8")))
    }
    /// A count, bounded by what the rest of the payload could hold.
    fn size(&mut self) -> Result<usize, String> {
        let v = self.u64()?;
        usize::try_from(v)
            .ok()
            .filter(|&v| v <= self.bytes.len())
            .ok_or_else(|| format!("count {v} exceeds the payload"))
    }
    fn f64(&mut self) -> Result<f64, String> {
        Ok(f64::from_le_bytes(self.take(8)?.try_into().expect("8")))
    }
    fn byte(&mut self) -> Result<u8, String> {
        Ok(self.take(1)?[0])
    }
    fn f64s(&mut self, n: usize) -> Result<Vec<f64>, String> {
        let bytes = self.take(n.checked_mul(8).ok_or("count overflows")?)?;
        Ok(bytes
            .chunks_exact(8)
            .map(|c| f64::from_le_bytes(c.try_into().expect("8")))
            .collect())
    }
    fn flags(&mut self, n: usize) -> Result<Vec<bool>, String> {
        Ok(self.take(n)?.iter().map(|&b| b != 0).collect())
    }
}

/// The fingerprint of a run: its scene file's text and the checkpoint interval (frames).
pub fn fingerprint(scene_text: &str, checkpoint_frames: usize) -> u64 {
    solver::checksum::fnv1a(format!("{scene_text}\u{0}{checkpoint_frames}").as_bytes())
}

/// Where [`write()`] puts the checkpoint of a run writing into `dir`.
pub fn path(dir: &Path) -> PathBuf {
    dir.join(CHECKPOINT_FILE)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> RunCheckpoint {
        RunCheckpoint {
            steps: 40,
            frames: 5,
            framing: Some(Framing::Fixed {
                center: [0.01, -0.02],
                pixels_per_metre: 1e4,
            }),
            snapshot: Snapshot {
                time: 0.04,
                q: vec![1.0, 2.0, 3.0, 0.5],
                v: vec![0.1, 0.0, -0.1, 0.0],
                fixed: vec![true, false, false, true],
                anchors: vec![0.25],
            },
            held: vec![false, true],
            first_hold: Some(0.03),
        }
    }

    #[test]
    fn round_trips_and_refuses_damaged_files() {
        let dir = std::env::temp_dir().join(format!("ckpt-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        assert_eq!(read(&dir, 7).unwrap(), None);
        write(&dir, &sample(), 7).unwrap();
        assert_eq!(read(&dir, 7).unwrap(), Some(sample()));
        let e = read(&dir, 8).unwrap_err().to_string();
        assert!(
            e.contains("checkpoint.bin") && e.contains("another scene"),
            "{e}"
        );
        let bytes = std::fs::read(path(&dir)).unwrap();
        let damaged = |b: Vec<u8>| {
            std::fs::write(path(&dir), b).unwrap();
            read(&dir, 7).unwrap_err().to_string()
        };
        let e = damaged(bytes[..bytes.len() - 11].to_vec());
        assert!(e.contains("truncated"), "{e}");
        let mut flipped = bytes.clone();
        flipped[40] ^= 1;
        assert!(damaged(flipped).contains("checksum"));
        assert!(damaged(b"YWDBCK01".to_vec()).contains("bad magic"));
        assert!(damaged(vec![]).contains("bad magic"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
