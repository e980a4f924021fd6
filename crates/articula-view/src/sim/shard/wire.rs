//! The shards' messages as bytes (little-endian), for a driver in another process: each
//! starts with a four-byte tag naming its kind and version, and every read is checked — a
//! message cut short or of another kind is a [`ViewError::Shard`], never a panic.
//!
//! - [`DepthMessage`]: the step, the buffer's size, then the runs of finite cells (start and
//!   length as `u32`, then their depths): empty cells cost nothing.
//! - [`Candidates`]: the shard's range, step, budget and tolerance, the roots' masses (with
//!   a tolerance), then per pop its metric, body (`u64`), node and cost (`u32`), and with a
//!   tolerance the mass it adds: 24 bytes a pop without a tolerance.
//! - [`ShardStep`]: the step's figures, then the bodies' errors.

use super::{Candidate, Candidates, DepthMessage, ShardRange, ShardStep};
use crate::error::ViewError;
use crate::sim::SceneStep;

const DEPTH: &[u8; 4] = b"ADP1";
const CANDIDATES: &[u8; 4] = b"ACD1";
const STEP: &[u8; 4] = b"AST1";

/// A message being written.
#[derive(Default)]
struct Writer(Vec<u8>);

impl Writer {
    fn tag(tag: &[u8; 4]) -> Writer {
        Writer(tag.to_vec())
    }
    fn u32(&mut self, x: usize) {
        let x = u32::try_from(x).expect("a count below 2^32 (checked by the caller)");
        self.0.extend_from_slice(&x.to_le_bytes());
    }
    fn u64(&mut self, x: u64) {
        self.0.extend_from_slice(&x.to_le_bytes());
    }
    fn usize(&mut self, x: usize) {
        self.u64(x as u64);
    }
    fn f64(&mut self, x: f64) {
        self.u64(x.to_bits());
    }
    /// `None` as `u64::MAX`.
    fn opt(&mut self, x: Option<u64>) {
        self.u64(x.unwrap_or(u64::MAX));
    }
}

/// A message being read.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
    what: &'static str,
}

impl<'a> Reader<'a> {
    fn new(bytes: &'a [u8], tag: &[u8; 4], what: &'static str) -> Result<Reader<'a>, ViewError> {
        if bytes.get(..4) != Some(&tag[..]) {
            return Err(ViewError::Shard(format!(
                "not a {what} message ({} bytes starting {:?})",
                bytes.len(),
                &bytes[..bytes.len().min(4)]
            )));
        }
        Ok(Reader { bytes, at: 4, what })
    }
    fn take(&mut self, n: usize) -> Result<&'a [u8], ViewError> {
        let out = self
            .bytes
            .get(self.at..self.at.saturating_add(n))
            .ok_or_else(|| {
                ViewError::Shard(format!(
                    "{} message cut short: {} bytes, needs more than {}",
                    self.what,
                    self.bytes.len(),
                    self.at
                ))
            })?;
        self.at += n;
        Ok(out)
    }
    fn u32(&mut self) -> Result<usize, ViewError> {
        let b = self.take(4)?;
        Ok(u32::from_le_bytes(b.try_into().expect("4 bytes")) as usize)
    }
    fn u64(&mut self) -> Result<u64, ViewError> {
        let b = self.take(8)?;
        Ok(u64::from_le_bytes(b.try_into().expect("8 bytes")))
    }
    fn usize(&mut self) -> Result<usize, ViewError> {
        let x = self.u64()?;
        usize::try_from(x).map_err(|_| ViewError::Shard(format!("{}: {x} out of range", self.what)))
    }
    fn f64(&mut self) -> Result<f64, ViewError> {
        Ok(f64::from_bits(self.u64()?))
    }
    fn opt(&mut self) -> Result<Option<u64>, ViewError> {
        Ok(Some(self.u64()?).filter(|x| *x != u64::MAX))
    }
    /// A count of items of `size` bytes each, checked against the bytes left (no huge
    /// allocation from a corrupt count).
    fn count(&mut self, size: usize) -> Result<usize, ViewError> {
        let n = self.usize()?;
        if n.saturating_mul(size) > self.bytes.len() - self.at {
            return Err(ViewError::Shard(format!(
                "{} message: {n} items do not fit in its {} bytes",
                self.what,
                self.bytes.len()
            )));
        }
        Ok(n)
    }
    fn end(self) -> Result<(), ViewError> {
        if self.at != self.bytes.len() {
            return Err(ViewError::Shard(format!(
                "{} message: {} bytes after its end",
                self.what,
                self.bytes.len() - self.at
            )));
        }
        Ok(())
    }
}

impl DepthMessage {
    /// The message as bytes: runs of finite cells.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut w = Writer::tag(DEPTH);
        w.u64(self.step);
        w.usize(self.width);
        w.usize(self.height);
        w.usize(self.depth.len());
        let mut runs: Vec<(usize, usize)> = Vec::new();
        for (i, d) in self.depth.iter().enumerate() {
            if d.is_finite() {
                match runs.last_mut() {
                    Some((s, n)) if *s + *n == i => *n += 1,
                    _ => runs.push((i, 1)),
                }
            }
        }
        w.usize(runs.len());
        for &(s, n) in &runs {
            w.u32(s);
            w.u32(n);
            self.depth[s..s + n].iter().for_each(|d| w.f64(*d));
        }
        w.0
    }

    /// The message from [`DepthMessage::to_bytes`].
    pub fn from_bytes(bytes: &[u8]) -> Result<DepthMessage, ViewError> {
        let mut r = Reader::new(bytes, DEPTH, "depth buffer")?;
        let step = r.u64()?;
        let (width, height) = (r.usize()?, r.usize()?);
        let cells = r.usize()?;
        if cells != width.saturating_mul(height) || cells > super::MAX_CELLS {
            return Err(ViewError::Shard(format!(
                "depth buffer message: {cells} cells for {width}×{height}"
            )));
        }
        let mut depth = vec![f64::INFINITY; cells];
        for _ in 0..r.count(8)? {
            let (s, n) = (r.u32()?, r.u32()?);
            let run = depth.get_mut(s..s.saturating_add(n)).ok_or_else(|| {
                ViewError::Shard(format!(
                    "depth buffer message: run {s}+{n} beyond {cells} cells"
                ))
            })?;
            for d in run {
                *d = r.f64()?;
            }
        }
        r.end()?;
        Ok(DepthMessage {
            step,
            width,
            height,
            depth,
        })
    }
}

fn put_range(w: &mut Writer, r: &ShardRange) {
    for x in [r.index, r.count, r.first, r.bodies, r.total] {
        w.usize(x);
    }
}

fn get_range(r: &mut Reader) -> Result<ShardRange, ViewError> {
    Ok(ShardRange {
        index: r.usize()?,
        count: r.usize()?,
        first: r.usize()?,
        bodies: r.usize()?,
        total: r.usize()?,
    })
}

impl Candidates {
    /// The message as bytes.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut w = Writer::tag(CANDIDATES);
        put_range(&mut w, &self.range);
        w.u64(self.step);
        w.opt(self.budget.map(|b| b as u64));
        w.opt(self.tolerance.map(f64::to_bits));
        w.usize(self.roots.len());
        for &(b, m) in &self.roots {
            w.usize(b);
            w.f64(m);
        }
        w.usize(self.pops.len());
        for c in &self.pops {
            w.f64(c.metric);
            w.usize(c.body);
            w.u32(c.node);
            w.u32(c.cost);
            if self.tolerance.is_some() {
                w.f64(c.added);
            }
        }
        w.0
    }

    /// The message from [`Candidates::to_bytes`].
    pub fn from_bytes(bytes: &[u8]) -> Result<Candidates, ViewError> {
        let mut r = Reader::new(bytes, CANDIDATES, "candidates")?;
        let range = get_range(&mut r)?;
        let step = r.u64()?;
        let budget = r.opt()?.map(|b| b as usize);
        let tolerance = r.opt()?.map(f64::from_bits);
        let roots = (0..r.count(16)?)
            .map(|_| Ok((r.usize()?, r.f64()?)))
            .collect::<Result<_, ViewError>>()?;
        let size = if tolerance.is_some() { 32 } else { 24 };
        let pops = (0..r.count(size)?)
            .map(|_| {
                Ok(Candidate {
                    metric: r.f64()?,
                    body: r.usize()?,
                    node: r.u32()?,
                    cost: r.u32()?,
                    added: if tolerance.is_some() { r.f64()? } else { 0.0 },
                })
            })
            .collect::<Result<_, ViewError>>()?;
        r.end()?;
        Ok(Candidates {
            range,
            step,
            budget,
            tolerance,
            roots,
            pops,
        })
    }
}

impl ShardStep {
    /// The message as bytes.
    pub fn to_bytes(&self) -> Vec<u8> {
        let SceneStep {
            reselected,
            active_total,
            classes,
            link_classes,
            total_error,
            contacts,
            max_penetration,
            contact_solves,
            contact_capped,
            contact_rows,
            contact_sweeps,
        } = self.step;
        let mut w = Writer::tag(STEP);
        w.usize(usize::from(reselected));
        w.usize(active_total);
        classes
            .iter()
            .chain(&link_classes)
            .for_each(|c| w.usize(*c));
        w.f64(total_error);
        w.usize(contacts);
        w.f64(max_penetration);
        for x in [contact_solves, contact_capped, contact_rows, contact_sweeps] {
            w.usize(x);
        }
        w.usize(self.errors.len());
        for &(b, e) in &self.errors {
            w.usize(b);
            w.f64(e);
        }
        w.0
    }

    /// The message from [`ShardStep::to_bytes`].
    pub fn from_bytes(bytes: &[u8]) -> Result<ShardStep, ViewError> {
        let mut r = Reader::new(bytes, STEP, "shard step")?;
        let reselected = r.usize()? != 0;
        let active_total = r.usize()?;
        let mut c = [0usize; 6];
        for x in &mut c {
            *x = r.usize()?;
        }
        let step = SceneStep {
            reselected,
            active_total,
            classes: [c[0], c[1], c[2]],
            link_classes: [c[3], c[4], c[5]],
            total_error: r.f64()?,
            contacts: r.usize()?,
            max_penetration: r.f64()?,
            contact_solves: r.usize()?,
            contact_capped: r.usize()?,
            contact_rows: r.usize()?,
            contact_sweeps: r.usize()?,
        };
        let errors = (0..r.count(16)?)
            .map(|_| Ok((r.usize()?, r.f64()?)))
            .collect::<Result<_, ViewError>>()?;
        r.end()?;
        Ok(ShardStep { step, errors })
    }
}
