//! Features of a time series that calibration models use as basis values.

use crate::error::{Error, Result};

/// First-order lag of `temperature_c` with time constant `tau_s`, sample by sample:
/// `y[i] = y[i-1] + (1 - exp(-(t[i] - t[i-1]) / tau)) (x[i] - y[i-1])`, `y[0] = initial`
/// (or `x[0]` when `initial` is None). This is the exact response of a first-order
/// system to an input that holds its value between samples, so it is right for any
/// sample spacing, including gaps. `tau_s == 0` returns the input.
///
/// The lagged temperature is what the die sees when it trails the logged probe
/// (thermal lag); `(x - y) / tau` is a causal, smoothed dT/dt.
pub fn first_order_lag(
    time_s: &[f64],
    temperature_c: &[f64],
    tau_s: f64,
    initial: Option<f64>,
) -> Result<Vec<f64>> {
    direction_lag(time_s, temperature_c, tau_s, tau_s, initial)
}

/// First-order lag whose time constant depends on the direction of the heat flow:
/// `tau_heat_s` while the input is above the output (the die heating), `tau_cool_s`
/// otherwise; each step as in [`first_order_lag`], which this is when the two are
/// equal (the same floats). A die coupled to the air differently while the chamber
/// heats (a heater blowing on the board) and while it cools (through the far wall)
/// trails the logged probe by a time constant of each.
pub fn direction_lag(
    time_s: &[f64],
    temperature_c: &[f64],
    tau_heat_s: f64,
    tau_cool_s: f64,
    initial: Option<f64>,
) -> Result<Vec<f64>> {
    if time_s.len() != temperature_c.len() {
        return Err(Error::Shape {
            what: "temperature_c",
            expected: time_s.len(),
            got: temperature_c.len(),
        });
    }
    for (name, tau) in [("tau_s", tau_heat_s), ("tau_cool_s", tau_cool_s)] {
        if !(tau.is_finite() && tau >= 0.0) {
            return Err(Error::InvalidParameter {
                name,
                reason: format!("must be finite and >= 0, got {tau}"),
            });
        }
    }
    let mut out = Vec::with_capacity(time_s.len());
    let Some(&first) = temperature_c.first() else {
        return Ok(out);
    };
    let mut y = initial.unwrap_or(first);
    let mut previous_t = time_s[0];
    // Logs are sampled on a regular grid: the steps' factors are computed again only
    // when the interval changes (the same values as computing them every time).
    let mut last_dt = f64::NAN;
    let (mut alpha_heat, mut alpha_cool) = (0.0, 0.0);
    for (i, (&t, &x)) in time_s.iter().zip(temperature_c).enumerate() {
        if !(t.is_finite() && x.is_finite()) {
            return Err(Error::NonFinite {
                what: "time or temperature",
                row: i as u64,
                column: 0,
            });
        }
        let heating = x > y;
        let tau = if heating { tau_heat_s } else { tau_cool_s };
        if tau == 0.0 {
            y = x;
        } else if i > 0 {
            let dt = t - previous_t;
            if dt < 0.0 {
                return Err(Error::TimeNotIncreasing {
                    index: i as u64,
                    previous_s: previous_t,
                    time_s: t,
                });
            }
            if dt.to_bits() != last_dt.to_bits() {
                last_dt = dt;
                alpha_heat = -(-dt / tau_heat_s).exp_m1();
                alpha_cool = -(-dt / tau_cool_s).exp_m1();
            }
            y += (if heating { alpha_heat } else { alpha_cool }) * (x - y);
        }
        previous_t = t;
        out.push(y);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ramp_settles_to_rate_times_tau_behind() {
        let time: Vec<f64> = (0..20_000).map(|i| f64::from(i) * 0.5).collect();
        let temp: Vec<f64> = time.iter().map(|t| 0.01 * t).collect();
        let lagged = first_order_lag(&time, &temp, 60.0, None).unwrap();
        let last = lagged.len() - 1;
        // Exact ZOH response of a ramp: lag = rate * tau * (1 - dt/(...)) within 1e-3 relative.
        let lag = temp[last] - lagged[last];
        assert!((lag - 0.6).abs() < 0.6 * 5e-3, "{lag}");
    }

    #[test]
    fn zero_tau_is_identity_and_errors_are_typed() {
        let y = first_order_lag(&[0.0, 1.0], &[1.0, 2.0], 0.0, None).unwrap();
        assert_eq!(y, vec![1.0, 2.0]);
        assert!(first_order_lag(&[0.0], &[1.0, 2.0], 1.0, None).is_err());
        assert!(first_order_lag(&[0.0, 1.0], &[1.0, 2.0], -1.0, None).is_err());
        assert!(matches!(
            first_order_lag(&[0.0, f64::NAN], &[1.0, 2.0], 1.0, None),
            Err(Error::NonFinite { row: 1, .. })
        ));
        assert!(first_order_lag(&[], &[], 1.0, None).unwrap().is_empty());
    }

    #[test]
    fn direction_lag_takes_each_time_constant_on_its_leg() {
        // Up a ramp then down it: on the way up the output trails by rate * tau_heat,
        // on the way down it leads by rate * tau_cool (settled, within 1 %).
        let time: Vec<f64> = (0..40_000).map(|i| f64::from(i) * 0.5).collect();
        let temp: Vec<f64> = time
            .iter()
            .map(|&t| {
                if t < 10_000.0 {
                    0.01 * t
                } else {
                    100.0 - 0.01 * (t - 10_000.0)
                }
            })
            .collect();
        let y = direction_lag(&time, &temp, 50.0, 250.0, None).unwrap();
        let up = temp[19_999] - y[19_999];
        let down = y[39_999] - temp[39_999];
        assert!((up - 0.5).abs() < 0.005, "{up}");
        assert!((down - 2.5).abs() < 0.025, "{down}");
        // Equal time constants: the same floats as the plain lag.
        let same = direction_lag(&time, &temp, 60.0, 60.0, Some(1.0)).unwrap();
        assert_eq!(
            same,
            first_order_lag(&time, &temp, 60.0, Some(1.0)).unwrap()
        );
        assert!(matches!(
            direction_lag(&time, &temp, 50.0, -1.0, None),
            Err(Error::InvalidParameter {
                name: "tau_cool_s",
                ..
            })
        ));
    }
}
