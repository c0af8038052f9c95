//! Streaming decimator (CONTRACT PLACEHOLDER: bodies to be written).
use crate::error::Result;
use ndarray::ArrayView2;

/// Configuration of a [`Decimator`].
#[derive(Debug, Clone, PartialEq)]
pub struct DecimatorConfig {
    /// Samples per output block at the nominal rate (>= 1). Default 10.
    pub factor: usize,
    /// Nominal input sample rate in Hz (finite, > 0). Default 20.
    pub rate_hz: f64,
    /// Number of data channels besides time and temperature. Default 3.
    pub n_channels: usize,
    /// Blocks with fewer valid samples are dropped (>= 1). Default 1.
    pub min_count: usize,
    /// Origin of the block grid in seconds; `None` = time of the first sample with finite time.
    pub t0_s: Option<f64>,
}

impl Default for DecimatorConfig {
    fn default() -> Self {
        Self { factor: 10, rate_hz: 20.0, n_channels: 3, min_count: 1, t0_s: None }
    }
}

/// Output of a decimator: one row per kept block, in increasing block order.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct DecimatedBlocks {
    /// Number of channels per row of `channels`.
    pub n_channels: usize,
    /// Block index k: the block covers [t0 + k*factor/rate, t0 + (k+1)*factor/rate).
    pub block_index: Vec<i64>,
    /// Number of valid samples averaged in each block.
    pub count: Vec<u64>,
    /// Mean time of the block's valid samples, s.
    pub time_s: Vec<f64>,
    /// Mean temperature of the block's valid samples, °C.
    pub temperature_c: Vec<f64>,
    /// Mean of each channel, row-major (n_blocks x n_channels).
    pub channels: Vec<f64>,
}

/// Time-aligned block-mean decimator.
#[derive(Debug, Clone)]
pub struct Decimator {
    config: DecimatorConfig,
}

impl Decimator {
    /// Validate the configuration and create an empty decimator.
    pub fn new(config: DecimatorConfig) -> Result<Self> {
        let _ = config;
        todo!()
    }
    /// The configuration (with `t0_s` filled in once known).
    pub fn config(&self) -> &DecimatorConfig {
        &self.config
    }
    /// Push a chunk. `channels` is (n, n_channels).
    pub fn push(
        &mut self,
        time_s: &[f64],
        temperature_c: &[f64],
        channels: ArrayView2<'_, f64>,
    ) -> Result<()> {
        let _ = (time_s, temperature_c, channels);
        todo!()
    }
    /// Merge another decimator of the same configuration (pieces of one stream).
    pub fn merge(&mut self, other: &Decimator) -> Result<()> {
        let _ = other;
        todo!()
    }
    /// Remove and return all blocks that can no longer receive samples (all but the open one).
    pub fn drain_completed(&mut self) -> DecimatedBlocks {
        todo!()
    }
    /// All blocks so far with at least `min_count` samples. Error if none.
    pub fn finish(&self) -> Result<DecimatedBlocks> {
        todo!()
    }
    /// Rows pushed so far (valid or not).
    pub fn n_samples(&self) -> u64 {
        todo!()
    }
    /// Rows skipped because time, temperature or a channel was NaN or infinite.
    pub fn n_skipped_nonfinite(&self) -> u64 {
        todo!()
    }
}
