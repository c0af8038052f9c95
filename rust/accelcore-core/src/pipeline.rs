//! Fused streaming pipeline: decimate → bin → fit, in bounded memory.
//!
//! A [`FusedPipeline`] streams raw `(time_s, temperature_c, channels…)` rows
//! through a [`Decimator`]; every completed block (taken with
//! [`Decimator::drain_completed`]) goes at once into a [`TemperatureBinner`]
//! and into line fits `channel = a + b · (T − t_ref_c)` of every channel on the
//! block means, weighted by the block's sample count. The channels share the
//! design, so one [`LeastSquares::with_responses`] factor serves them all; its
//! results are bit-identical to one [`LeastSquares`] per channel, so this computes
//! what the composition computes:
//!
//! ```text
//! blocks = Decimator(cfg).push(all rows).finish()
//! TemperatureBinner(binner).push(blocks.time_s, blocks.temperature_c, blocks.channels)
//! for j in channels:
//!     LeastSquares(2).push([1, T - t_ref_c], blocks.channels[:, j], weights = blocks.count)
//! ```
//!
//! but never holds the blocks: the state is the decimator's open block, at
//! most two held-back blocks (see *Merging*), the bins and the `R` factors.
//! Memory does not grow with the length of the log.
//!
//! # Semantics
//!
//! - Decimation, NaN policy (skip) and time order are those of [`Decimator`];
//!   binning (`[lo, hi)`, out-of-window counters) is that of
//!   [`TemperatureBinner`], applied to block means (each block is one sample).
//! - `min_count` is applied to whole blocks just before they reach the binner
//!   and the fits; dropped blocks are counted in
//!   [`PipelineResult::n_blocks_dropped`]. (Internally the decimator keeps
//!   every block, so that a block cut in two by a piece boundary is not lost.)
//! - Every kept block enters every fit, inside the binner's window or not.
//! - Chunking: `push` cuts its input into sub-chunks of [`SUB_CHUNK_ROWS`]
//!   rows; the result does not depend on how the stream is cut into `push`
//!   calls (bit for bit).
//!
//! # Merging
//!
//! Pieces of one log processed separately combine with
//! [`FusedPipeline::merge`]. They must share the block grid: pass
//! `t0_s` explicitly (otherwise each piece anchors its grid at its own first
//! sample and the merge is rejected). A piece boundary may fall inside a
//! block, so neither the first block of a piece nor its last (open) block can
//! be binned or fitted before the neighbouring pieces are known. Each piece
//! therefore holds back its first block (`head`) and its open block, and a
//! merge combines the last block of the earlier piece with the first block of
//! the later one when they share an index. The merged result equals one pass
//! up to rounding (Chan et al. for the bins, an orthogonal merge for `R`,
//! and, for a block split by the cut, `mean·count` sums recombined).
//! The pieces' finite times must not overlap (either order is fine).
use crate::binning::{BinnedStats, BinnerConfig, TemperatureBinner, RUN_CHANNELS};
use crate::decimate::{DecimatedBlocks, Decimator, DecimatorConfig};
use crate::error::{Error, Result};
use crate::regression::{LeastSquares, LstsqSolution};
use ndarray::{ArrayView2, Axis, Slice};

/// Rows handed to the decimator at a time; its completed blocks are binned and
/// fitted before the next sub-chunk, so the working set stays in cache.
pub const SUB_CHUNK_ROWS: usize = 8192;

/// Configuration of a [`FusedPipeline`].
#[derive(Debug, Clone, PartialEq)]
pub struct PipelineConfig {
    /// Decimation (its `n_channels` must equal the binner's).
    pub decimator: DecimatorConfig,
    /// Temperature bins of the block means.
    pub binner: BinnerConfig,
    /// Reference temperature of the line fits, °C (finite). Default 25.
    pub t_ref_c: f64,
}

impl Default for PipelineConfig {
    fn default() -> Self {
        Self {
            decimator: DecimatorConfig::default(),
            binner: BinnerConfig::default(),
            t_ref_c: 25.0,
        }
    }
}

/// Result of [`FusedPipeline::finish`].
#[derive(Debug, Clone, PartialEq)]
pub struct PipelineResult {
    /// Per-bin statistics of the kept block means.
    pub binned: BinnedStats,
    /// One fit per channel; coefficients `[offset at t_ref_c, slope per °C]`.
    pub fits: Vec<LstsqSolution>,
    /// Rows pushed (valid or not).
    pub n_samples: u64,
    /// Rows skipped by the decimator because a value was NaN or infinite.
    pub n_skipped_nonfinite: u64,
    /// Blocks binned and fitted (at least `min_count` valid samples).
    pub n_blocks: u64,
    /// Blocks left out because they had fewer than `min_count` valid samples.
    pub n_blocks_dropped: u64,
}

/// One block mean (held back until its neighbours are known).
#[derive(Debug, Clone, PartialEq)]
struct Block {
    index: i64,
    count: u64,
    time_s: f64,
    temperature_c: f64,
    channels: Vec<f64>,
}

impl Block {
    /// Combine with a later part of the same block (sums recovered as mean · count).
    fn absorb(&mut self, later: &Block) {
        let (na, nb) = (self.count as f64, later.count as f64);
        let n = self.count.saturating_add(later.count);
        let f = n as f64;
        let mix = |a: f64, b: f64| (a * na + b * nb) / f;
        self.time_s = mix(self.time_s, later.time_s);
        self.temperature_c = mix(self.temperature_c, later.temperature_c);
        for (a, &b) in self.channels.iter_mut().zip(&later.channels) {
            *a = mix(*a, b);
        }
        self.count = n;
    }
}

/// Put `next` after the blocks in `seq`, combining it with the last one if they share an index.
fn append_block(seq: &mut Vec<Block>, next: Block) {
    match seq.last_mut() {
        Some(last) if last.index == next.index => last.absorb(&next),
        _ => seq.push(next),
    }
}

/// Decimate → bin → fit in one streaming pass (see the [module docs](self)).
#[derive(Debug, Clone)]
pub struct FusedPipeline {
    config: PipelineConfig,
    /// Internal decimator with `min_count = 1`; always drained after a sub-chunk.
    decimator: Decimator,
    /// First block of this piece, once a later block exists.
    head: Option<Block>,
    /// A block (from a merge) at or before the decimator's first block.
    pending: Option<Block>,
    binner: TemperatureBinner,
    /// Line fits of every channel against `[1, T - t_ref]`, one shared factor (None: no channel).
    fit: Option<LeastSquares>,
    /// Rows and skipped rows of decimators merged away.
    extra_samples: u64,
    extra_skipped: u64,
    /// First and last finite time pushed (merge order and overlap check).
    time_range: Option<(f64, f64)>,
    n_blocks: u64,
    n_blocks_dropped: u64,
    /// Scratch, reused: the blocks drained after a sub-chunk.
    drained: DecimatedBlocks,
}

impl FusedPipeline {
    /// Validate the configuration and create an empty pipeline.
    pub fn new(config: PipelineConfig) -> Result<Self> {
        let nc = config.decimator.n_channels;
        if config.binner.n_channels != nc {
            return Err(Error::InvalidParameter {
                name: "n_channels",
                reason: format!(
                    "decimator has {nc} channels but binner has {}",
                    config.binner.n_channels
                ),
            });
        }
        if !config.t_ref_c.is_finite() {
            return Err(Error::InvalidParameter {
                name: "t_ref_c",
                reason: format!("must be finite, got {}", config.t_ref_c),
            });
        }
        let decimator = Decimator::new(DecimatorConfig {
            min_count: 1,
            ..config.decimator.clone()
        })?;
        // The user's min_count is validated by the decimator's own rules.
        Decimator::new(config.decimator.clone())?;
        let binner = TemperatureBinner::new(config.binner.clone())?;
        let names = Some(vec!["offset".to_string(), "slope_per_c".to_string()]);
        // One factor for every channel: they share the design [1, T - t_ref].
        let fit = if nc > 0 {
            Some(LeastSquares::with_responses(2, nc, names)?)
        } else {
            None
        };
        Ok(Self {
            config,
            decimator,
            head: None,
            pending: None,
            binner,
            fit,
            extra_samples: 0,
            extra_skipped: 0,
            time_range: None,
            n_blocks: 0,
            n_blocks_dropped: 0,
            drained: DecimatedBlocks::default(),
        })
    }

    /// The configuration (with `decimator.t0_s` filled in once known).
    pub fn config(&self) -> PipelineConfig {
        let mut c = self.config.clone();
        c.decimator.t0_s = self.decimator.config().t0_s;
        c
    }

    /// Rows pushed so far (valid or not).
    pub fn n_samples(&self) -> u64 {
        self.decimator
            .n_samples()
            .saturating_add(self.extra_samples)
    }

    /// Rows skipped because a value was NaN or infinite.
    pub fn n_skipped_nonfinite(&self) -> u64 {
        self.decimator
            .n_skipped_nonfinite()
            .saturating_add(self.extra_skipped)
    }

    /// Push a chunk: same arguments, shape rules and errors as [`Decimator::push`].
    ///
    /// On error, the sub-chunks before the offending row have been consumed
    /// and the rest of the chunk has not (the time-order check of the
    /// decimator runs per sub-chunk).
    pub fn push(
        &mut self,
        time_s: &[f64],
        temperature_c: &[f64],
        channels: ArrayView2<'_, f64>,
    ) -> Result<()> {
        crate::decimate::check_shapes(
            time_s,
            temperature_c,
            &channels,
            self.config.decimator.n_channels,
        )?;
        let mut start = 0;
        while start < time_s.len() {
            let end = (start + SUB_CHUNK_ROWS).min(time_s.len());
            let rows = channels.slice_axis(Axis(0), Slice::from(start..end));
            self.decimator
                .push(&time_s[start..end], &temperature_c[start..end], rows)?;
            self.note_times(&time_s[start..end]);
            let mut blocks = std::mem::take(&mut self.drained);
            self.decimator.drain_completed_into(&mut blocks);
            self.take_blocks(&blocks)?;
            self.drained = blocks;
            start = end;
        }
        Ok(())
    }

    /// Merge another piece of the same log (see the [module docs](self#merging)).
    ///
    /// Configurations must be equal, and so must `t0_s` once both pieces know
    /// it; the pieces' finite times must not overlap. Failures are
    /// [`Error::Incompatible`] and leave `self` unchanged.
    pub fn merge(&mut self, other: &FusedPipeline) -> Result<()> {
        let (a, b) = (&self.config, &other.config);
        let same = a.t_ref_c.to_bits() == b.t_ref_c.to_bits()
            && a.binner == b.binner
            && DecimatorConfig {
                t0_s: None,
                ..a.decimator.clone()
            } == DecimatorConfig {
                t0_s: None,
                ..b.decimator.clone()
            };
        if !same {
            return Err(Error::Incompatible {
                reason: format!("pipeline configurations differ: {a:?} vs {b:?}"),
            });
        }
        let (ta, tb) = (self.decimator.config().t0_s, other.decimator.config().t0_s);
        if let (Some(x), Some(y)) = (ta, tb) {
            if x.to_bits() != y.to_bits() {
                return Err(Error::Incompatible {
                    reason: format!(
                        "block grids differ: t0 = {x} s vs {y} s; pass t0_s explicitly \
                         when splitting a log into pieces"
                    ),
                });
            }
        }
        let self_first = match (self.time_range, other.time_range) {
            (Some((lo_a, hi_a)), Some((lo_b, hi_b))) => {
                if hi_a < lo_b {
                    true
                } else if hi_b < lo_a {
                    false
                } else {
                    return Err(Error::Incompatible {
                        reason: format!(
                            "time ranges overlap: [{lo_a}, {hi_a}] s and [{lo_b}, {hi_b}] s"
                        ),
                    });
                }
            }
            // A piece without finite times has no blocks and no grid: the
            // other one's decimator carries on.
            (Some(_), None) => false,
            (None, _) => true,
        };
        let (early, late) = if self_first {
            (&*self, other)
        } else {
            (other, &*self)
        };
        let mut binner = early.binner.clone();
        binner.merge(&late.binner)?;
        let mut fit = early.fit.clone();
        if let (Some(f), Some(g)) = (fit.as_mut(), late.fit.as_ref()) {
            f.merge(g)?;
        }
        // Held-back blocks in time order; the late piece's open block stays in its decimator.
        let mut seq = Vec::with_capacity(5);
        for b in [&early.head, &early.pending].into_iter().flatten() {
            append_block(&mut seq, b.clone());
        }
        for b in open_blocks(&early.decimator) {
            append_block(&mut seq, b);
        }
        for b in [&late.head, &late.pending].into_iter().flatten() {
            append_block(&mut seq, b.clone());
        }
        let decimator = late.decimator.clone();
        let mut merged = FusedPipeline {
            config: self.config.clone(),
            decimator,
            head: None,
            pending: None,
            binner,
            fit,
            extra_samples: early.n_samples().saturating_add(late.extra_samples),
            extra_skipped: early
                .n_skipped_nonfinite()
                .saturating_add(late.extra_skipped),
            time_range: match (early.time_range, late.time_range) {
                (Some((lo, _)), Some((_, hi))) => Some((lo, hi)),
                (x, y) => x.or(y),
            },
            n_blocks: early.n_blocks.saturating_add(late.n_blocks),
            n_blocks_dropped: early.n_blocks_dropped.saturating_add(late.n_blocks_dropped),
            drained: DecimatedBlocks::default(),
        };
        let open_index = open_blocks(&merged.decimator).first().map(|b| b.index);
        let mut rest = seq.into_iter();
        let n_held = rest.len();
        if let Some(first) = rest.next() {
            if n_held == 1 && open_index == Some(first.index) {
                merged.pending = Some(first);
            } else {
                merged.head = Some(first);
                let mut middle: Vec<Block> = rest.collect();
                merged.pending = middle.pop();
                for b in &middle {
                    merged.emit(b)?;
                }
            }
        }
        *self = merged;
        Ok(())
    }

    /// Binned statistics and line fits of everything pushed so far.
    ///
    /// Does not change the pipeline. Errors: those of
    /// [`TemperatureBinner::finish`] (no block in the window) and of
    /// [`LeastSquares::finish`] (e.g. fewer than two blocks, or a single
    /// temperature: [`Error::RankDeficient`]).
    pub fn finish(&self) -> Result<PipelineResult> {
        let mut done = self.clone();
        let mut seq = Vec::with_capacity(3);
        for b in [&self.head, &self.pending].into_iter().flatten() {
            append_block(&mut seq, b.clone());
        }
        for b in open_blocks(&self.decimator) {
            append_block(&mut seq, b);
        }
        for b in &seq {
            done.emit(b)?;
        }
        let binned = done.binner.finish()?;
        let fits = match &done.fit {
            Some(fit) => (0..fit.n_responses())
                .map(|j| fit.finish_response(j))
                .collect::<Result<Vec<_>>>()?,
            None => Vec::new(),
        };
        Ok(PipelineResult {
            binned,
            fits,
            n_samples: self.n_samples(),
            n_skipped_nonfinite: self.n_skipped_nonfinite(),
            n_blocks: done.n_blocks,
            n_blocks_dropped: done.n_blocks_dropped,
        })
    }

    fn note_times(&mut self, time_s: &[f64]) {
        let first = time_s.iter().copied().find(|t| t.is_finite());
        let last = time_s.iter().rev().copied().find(|t| t.is_finite());
        if let (Some(lo), Some(hi)) = (first, last) {
            self.time_range = Some(match self.time_range {
                Some((l, _)) => (l, hi),
                None => (lo, hi),
            });
        }
    }

    /// Completed blocks from the decimator: the first one of the piece is held
    /// back, a pending block is combined or emitted first, the rest are
    /// binned and fitted in one batch.
    fn take_blocks(&mut self, blocks: &DecimatedBlocks) -> Result<()> {
        if blocks.is_empty() {
            return Ok(());
        }
        let nc = blocks.n_channels;
        let mut start = 0;
        if let Some(mut p) = self.pending.take() {
            if p.index == blocks.block_index[0] {
                p.absorb(&block_at(blocks, 0));
                start = 1;
            }
            self.emit(&p)?;
        }
        if self.head.is_none() && start < blocks.len() {
            self.head = Some(block_at(blocks, start));
            start += 1;
        }
        if start < blocks.len() {
            self.feed(
                &blocks.count[start..],
                &blocks.time_s[start..],
                &blocks.temperature_c[start..],
                &blocks.channels[start * nc..],
            )?;
        }
        Ok(())
    }

    /// A single held-back block leaves hold: it becomes the head if there is none.
    fn emit(&mut self, b: &Block) -> Result<()> {
        if self.head.is_none() {
            self.head = Some(b.clone());
            return Ok(());
        }
        self.feed(&[b.count], &[b.time_s], &[b.temperature_c], &b.channels)
    }

    /// Bin and fit a batch of finished blocks (`channels` row-major).
    fn feed(
        &mut self,
        count: &[u64],
        time_s: &[f64],
        temperature_c: &[f64],
        channels: &[f64],
    ) -> Result<()> {
        let nc = self.config.decimator.n_channels;
        let n = count.len();
        let min = self.config.decimator.min_count as u64;
        if count.iter().any(|&c| c < min) {
            // Rare: filter into owned copies.
            let keep: Vec<usize> = (0..n).filter(|&i| count[i] >= min).collect();
            self.n_blocks_dropped += (n - keep.len()) as u64;
            let c: Vec<u64> = keep.iter().map(|&i| count[i]).collect();
            let t: Vec<f64> = keep.iter().map(|&i| time_s[i]).collect();
            let temp: Vec<f64> = keep.iter().map(|&i| temperature_c[i]).collect();
            let ch: Vec<f64> = keep
                .iter()
                .flat_map(|&i| channels[i * nc..(i + 1) * nc].iter().copied())
                .collect();
            self.feed_kept(&c, &t, &temp, &ch)
        } else {
            self.feed_kept(count, time_s, temperature_c, channels)
        }
    }

    fn feed_kept(
        &mut self,
        count: &[u64],
        time_s: &[f64],
        temperature_c: &[f64],
        channels: &[f64],
    ) -> Result<()> {
        let nc = self.config.decimator.n_channels;
        let n = count.len();
        if n == 0 {
            return Ok(());
        }
        let view = ArrayView2::from_shape((n, nc), channels).map_err(|_| Error::Shape {
            what: "block channels",
            expected: n * nc,
            got: channels.len(),
        })?;
        if let Some(fit) = self.fit.as_mut() {
            // Block means are finite unless a sum overflowed, and `T - t_ref`
            // may overflow: screen both (branch-free) before touching the
            // binner, so that a rejected batch changes nothing.
            let t_ref = self.config.t_ref_c;
            let finite = temperature_c
                .iter()
                .fold(true, |ok, &t| ok & (t - t_ref).is_finite())
                & channels.iter().fold(true, |ok, v| ok & v.is_finite());
            if !finite {
                return Err(self.fit_error(count, temperature_c, view));
            }
            fit.push_line_unchecked(temperature_c, t_ref, count, channels);
            // Temperatures and channels are finite: if the times are too, the
            // binner need not test every value again.
            if nc <= RUN_CHANNELS && time_s.iter().fold(true, |ok, t| ok & t.is_finite()) {
                self.binner.push_finite(time_s, temperature_c, channels);
                self.n_blocks += n as u64;
                return Ok(());
            }
        }
        self.binner.push(time_s, temperature_c, view)?;
        self.n_blocks += n as u64;
        Ok(())
    }
}

impl FusedPipeline {
    /// The error for a batch with a non-finite `T - t_ref` or block mean:
    /// the design's first bad row, otherwise the fit's own report of the
    /// responses (as [`LeastSquares::push_multi`] gives it).
    #[cold]
    fn fit_error(
        &mut self,
        count: &[u64],
        temperature_c: &[f64],
        channels: ArrayView2<'_, f64>,
    ) -> Error {
        let t_ref = self.config.t_ref_c;
        if let Some(i) = temperature_c.iter().position(|&t| !(t - t_ref).is_finite()) {
            return Error::NonFinite {
                what: "design (temperature_c - t_ref_c)",
                row: self.n_blocks + i as u64,
                column: 1,
            };
        }
        let design: Vec<f64> = temperature_c
            .iter()
            .flat_map(|&t| [1.0, t - t_ref])
            .collect();
        #[allow(clippy::cast_precision_loss)]
        let weights: Vec<f64> = count.iter().map(|&c| c as f64).collect();
        let pushed = match (
            ArrayView2::from_shape((count.len(), 2), &design[..]),
            self.fit.as_mut(),
        ) {
            (Ok(design), Some(fit)) => fit.push_multi(design, channels, Some(&weights)),
            _ => Ok(()),
        };
        pushed.err().unwrap_or(Error::NonFinite {
            what: "block means",
            row: self.n_blocks,
            column: 0,
        })
    }
}

fn block_at(blocks: &DecimatedBlocks, i: usize) -> Block {
    let nc = blocks.n_channels;
    Block {
        index: blocks.block_index[i],
        count: blocks.count[i],
        time_s: blocks.time_s[i],
        temperature_c: blocks.temperature_c[i],
        channels: blocks.channels[i * nc..(i + 1) * nc].to_vec(),
    }
}

/// The decimator's un-drained blocks (its open block), in order.
fn open_blocks(d: &Decimator) -> Vec<Block> {
    match d.finish() {
        Ok(blocks) => (0..blocks.len()).map(|i| block_at(&blocks, i)).collect(),
        Err(_) => Vec::new(),
    }
}
