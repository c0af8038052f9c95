//! Temperature binning (CONTRACT PLACEHOLDER: bodies to be written).
use crate::error::Result;
use ndarray::ArrayView2;

/// Configuration of a [`TemperatureBinner`].
#[derive(Debug, Clone, PartialEq)]
pub struct BinnerConfig {
    /// Lower edge of the window, °C (inclusive). Default 0.
    pub lo_c: f64,
    /// Upper edge of the window, °C (exclusive). Default 60.
    pub hi_c: f64,
    /// Bin width, °C. Default 0.5.
    pub width_c: f64,
    /// Number of data channels. Default 3.
    pub n_channels: usize,
}

impl Default for BinnerConfig {
    fn default() -> Self {
        Self { lo_c: 0.0, hi_c: 60.0, width_c: 0.5, n_channels: 3 }
    }
}

/// Per-bin statistics. Arrays of length n_bins (row-major n_bins x n_channels for 2-D ones).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct BinnedStats {
    /// Number of channels.
    pub n_channels: usize,
    /// Bin edges, n_bins + 1 values: lo + i*width, the last one is hi.
    pub edges_c: Vec<f64>,
    /// Samples per bin.
    pub count: Vec<u64>,
    /// Mean temperature per bin (NaN when empty).
    pub temperature_c: Vec<f64>,
    /// Mean time per bin (NaN when empty).
    pub time_s: Vec<f64>,
    /// Mean per bin and channel (NaN when empty).
    pub mean: Vec<f64>,
    /// Sample variance (ddof = 1) per bin and channel (NaN when count < 2).
    pub variance: Vec<f64>,
    /// Samples with temperature below the window.
    pub n_below: u64,
    /// Samples with temperature at or above the upper edge.
    pub n_above: u64,
    /// Samples skipped because a value was NaN or infinite.
    pub n_nonfinite: u64,
}

/// Fixed-width temperature binner with Welford accumulators.
#[derive(Debug, Clone)]
pub struct TemperatureBinner {
    config: BinnerConfig,
}

impl TemperatureBinner {
    /// Validate the configuration.
    pub fn new(config: BinnerConfig) -> Result<Self> {
        let _ = config;
        todo!()
    }
    /// The configuration.
    pub fn config(&self) -> &BinnerConfig {
        &self.config
    }
    /// Number of bins.
    pub fn n_bins(&self) -> usize {
        todo!()
    }
    /// Push a chunk; `channels` is (n, n_channels).
    pub fn push(
        &mut self,
        time_s: &[f64],
        temperature_c: &[f64],
        channels: ArrayView2<'_, f64>,
    ) -> Result<()> {
        let _ = (time_s, temperature_c, channels);
        todo!()
    }
    /// Merge another binner of identical configuration.
    pub fn merge(&mut self, other: &TemperatureBinner) -> Result<()> {
        let _ = other;
        todo!()
    }
    /// Statistics; error if no sample fell in the window.
    pub fn finish(&self) -> Result<BinnedStats> {
        todo!()
    }
}
