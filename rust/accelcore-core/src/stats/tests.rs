//! Known values, symmetries and the conventions of every edge case.
//!
//! The reference values were computed with 40–50 significant digits (mpmath's
//! `gammainc` and `betainc`, regularised) and are quoted to 20 digits; the critical
//! values of the printed tables are quoted to the digits the tables give.

// The 20 digits are kept as computed; the compiler rounds them to the nearest double.
#![allow(clippy::excessive_precision)]

use super::*;

/// Relative accuracy the special functions promise where the result is a normal double.
const RTOL: f64 = 2e-13;

fn assert_rel(got: f64, want: f64, rtol: f64, what: &str) {
    let err = ((got - want) / want).abs();
    assert!(
        err <= rtol,
        "{what}: got {got:e}, want {want:e}, rel err {err:e}"
    );
}

#[test]
fn chi2_sf_known_values() {
    let cases = [
        (3.841_458_820_694_124, 1.0, 0.050_000_000_000_000_057_435),
        (1e-3, 1.0, 0.974_772_879_369_960_388_28),
        (0.5, 1.0, 0.479_500_122_186_953_462_32),
        (10.0, 1.0, 0.001_565_402_258_002_549_677_5),
        (100.0, 1.0, 1.523_970_604_832_105_213_2e-23),
        (1400.0, 1.0, 2.101_014_516_264_217_495e-306),
        (18.307_038_053_275_146, 10.0, 0.050_000_000_000_000_006_706),
        (5.0, 3.0, 0.171_797_144_296_733_135_06),
        (60.0, 3.0, 5.878_230_727_906_912_341e-13),
        (200.0, 30.0, 4.952_733_529_003_190_601_9e-27),
        (700.0, 600.0, 0.002_895_772_531_822_271_801_1),
        (3.5, 2.5, 0.244_430_250_681_281_526_64),
        (101_000.0, 1e5, 0.012_868_840_377_233_669_864),
        (99_000.0, 1e5, 0.987_521_684_361_917_201_23),
        (1e6, 1e6, 0.499_811_936_803_394_499_52),
    ];
    for (x, k, want) in cases {
        assert_rel(chi2_sf(x, k), want, RTOL, &format!("chi2_sf({x}, {k})"));
    }
}

#[test]
fn chi2_sf_closed_forms() {
    // dof 2: e^{-x/2}; dof 4: e^{-x/2} (1 + x/2), in the far tail too.
    for x in [1e-6, 0.3, 2.0, 17.0, 150.0, 1200.0] {
        assert_rel(chi2_sf(x, 2.0), (-0.5 * x).exp(), RTOL, "dof 2");
        assert_rel(
            chi2_sf(x, 4.0),
            (-0.5 * x).exp() * (1.0 + 0.5 * x),
            RTOL,
            "dof 4",
        );
    }
}

#[test]
fn chi2_sf_table_critical_values() {
    // Upper 5 % and 1 % points of printed chi-square tables (5 significant digits).
    for (x, k, p) in [
        (3.8415, 1.0, 0.05),
        (5.9915, 2.0, 0.05),
        (18.307, 10.0, 0.05),
        (6.6349, 1.0, 0.01),
        (37.566, 20.0, 0.01),
    ] {
        assert_rel(chi2_sf(x, k), p, 5e-4, &format!("table chi2({x}, {k})"));
    }
}

#[test]
fn chi2_sf_edge_cases() {
    assert_eq!(chi2_sf(0.0, 3.0), 1.0);
    assert_eq!(chi2_sf(-2.0, 3.0), 1.0);
    assert_eq!(chi2_sf(f64::INFINITY, 3.0), 0.0);
    // No degrees of freedom: nothing was tested.
    assert_eq!(chi2_sf(5.0, 0.0), 1.0);
    assert_eq!(chi2_sf(5.0, -1.0), 1.0);
    assert!(chi2_sf(f64::NAN, 3.0).is_nan());
    assert!(chi2_sf(1.0, f64::NAN).is_nan());
    assert!(chi2_sf(1.0, f64::INFINITY).is_nan());
    // Far beyond the smallest double: 0, not NaN.
    assert_eq!(chi2_sf(1e6, 3.0), 0.0);
    assert_eq!(chi2_sf(2e4, 1e4), 0.0);
}

#[test]
fn t_sf_known_values() {
    let cases = [
        (2.0, 10.0, 0.036_694_017_385_370_182_809),
        (1.0, 1.0, 0.25),
        (1e10, 1.0, 3.183_098_861_837_906_715_4e-11),
        (1e200, 1.0, 3.183_098_861_837_906_811_7e-201),
        (-2.0, 10.0, 0.963_305_982_614_629_817_19),
        (0.1, 5.0, 0.462_115_070_577_330_185_14),
        (5.0, 3.0, 0.007_696_219_036_651_150_493_3),
        (40.0, 30.0, 6.863_022_597_203_201_393_6e-28),
        (3.0, 1e6, 0.001_349_931_270_710_898_529_4),
        (10.0, 1e6, 7.639_305_384_089_124_776_7e-24),
        (1e-8, 3.0, 0.499_999_996_324_474_030_52),
        (2.5, 2.5, 0.052_284_981_539_077_693_627),
        (30.0, 100.0, 4.190_166_279_344_146_084_7e-52),
        (6.0, 1e8, 9.865_910_171_576_435_271_4e-10),
    ];
    for (t, dof, want) in cases {
        assert_rel(t_sf(t, dof), want, RTOL, &format!("t_sf({t}, {dof})"));
    }
}

#[test]
fn t_sf_closed_forms() {
    // dof 1 (Cauchy): 1/2 - atan(t)/π; dof 2: (1 - t / sqrt(2 + t²)) / 2.
    for t in [0.01f64, 0.7, 3.0, 55.0, 1e4] {
        let cauchy = (1.0 / t).atan() / std::f64::consts::PI;
        assert_rel(t_sf(t, 1.0), cauchy, RTOL, "dof 1");
        let two = 0.5 * (1.0 - t / (2.0 + t * t).sqrt());
        // The closed form itself cancels for large t: compare where it does not.
        if t < 10.0 {
            assert_rel(t_sf(t, 2.0), two, RTOL, "dof 2");
        }
    }
}

#[test]
fn t_sf_table_critical_values() {
    // One-sided 5 % and 0.5 % points of printed t tables (4 significant digits).
    for (t, dof, p) in [
        (6.314, 1.0, 0.05),
        (1.812, 10.0, 0.05),
        (1.697, 30.0, 0.05),
        (3.169, 10.0, 0.005),
        (2.750, 30.0, 0.005),
    ] {
        assert_rel(t_sf(t, dof), p, 2e-3, &format!("table t({t}, {dof})"));
    }
}

#[test]
fn t_sf_is_symmetric() {
    for dof in [1.0, 2.5, 7.0, 40.0, 1e4] {
        for t in [1e-9, 0.3, 1.0, 2.2, 9.0] {
            let (up, down) = (t_sf(t, dof), t_sf(-t, dof));
            assert!(
                (up + down - 1.0).abs() <= 2.0 * f64::EPSILON,
                "dof {dof}, t {t}"
            );
        }
    }
}

#[test]
fn t_sf_edge_cases() {
    assert_eq!(t_sf(0.0, 4.0), 0.5);
    assert_eq!(t_sf(-0.0, 4.0), 0.5);
    assert_eq!(t_sf(f64::INFINITY, 4.0), 0.0);
    assert_eq!(t_sf(f64::NEG_INFINITY, 4.0), 1.0);
    assert!(t_sf(f64::NAN, 4.0).is_nan());
    assert!(t_sf(1.0, 0.0).is_nan());
    assert!(t_sf(1.0, -3.0).is_nan());
    assert!(t_sf(1.0, f64::INFINITY).is_nan());
    assert!(t_sf(1.0, f64::NAN).is_nan());
    assert_eq!(t_sf(1e300, 3.0), 0.0);
    assert_eq!(t_sf(-1e300, 3.0), 1.0);
}

#[test]
fn f_sf_known_values() {
    let cases = [
        (
            3.325_834_530_413_011_2,
            5.0,
            10.0,
            0.050_000_000_000_000_031_003,
        ),
        (1.0, 1.0, 1.0, 0.5),
        (0.01, 4.0, 7.0, 0.999_748_170_703_271_589_93),
        (100.0, 4.0, 7.0, 2.962_282_351_038_381_471_2e-6),
        (1.1, 1000.0, 1000.0, 0.065_991_926_286_882_412_447),
        (1.5, 1000.0, 1000.0, 8.424_503_698_936_114_062_5e-11),
        (0.8, 2000.0, 500.0, 0.999_399_830_228_122_129_42),
        (50.0, 2.0, 2.0, 0.019_607_843_137_254_901_961),
        (1e6, 3.0, 100.0, 1.117_846_246_563_814_501_6e-223),
        (1.05, 20_000.0, 20_000.0, 0.000_280_530_721_248_137_736_36),
    ];
    for (f, dfn, dfd, want) in cases {
        assert_rel(
            f_sf(f, dfn, dfd),
            want,
            RTOL,
            &format!("f_sf({f}, {dfn}, {dfd})"),
        );
    }
}

#[test]
fn f_sf_table_critical_values_and_relations() {
    // Upper 5 % and 1 % points of printed F tables (4 significant digits: the last
    // digit moves p by up to 0.3 %).
    for (f, dfn, dfd, p) in [
        (3.326, 5.0, 10.0, 0.05),
        (4.938, 3.0, 20.0, 0.01),
        (161.4, 1.0, 1.0, 0.05),
        (2.690, 4.0, 30.0, 0.05),
    ] {
        assert_rel(
            f_sf(f, dfn, dfd),
            p,
            3e-3,
            &format!("table F({f}, {dfn}, {dfd})"),
        );
    }
    // F(1, ν) is t² with ν dof: P(F > t²) = 2 P(T > t).
    for (t, dof) in [(0.4, 3.0), (2.0, 10.0), (7.0, 25.0)] {
        assert_rel(
            f_sf(t * t, 1.0, dof),
            2.0 * t_sf(t, dof),
            RTOL,
            "F(1, ν) = t²",
        );
    }
    // dfn = 2: P(F > f) = (1 + 2 f / dfd)^(-dfd / 2).
    for (f, dfd) in [(0.5f64, 4.0f64), (3.0, 9.0), (40.0, 60.0)] {
        let want = (-0.5 * dfd * (2.0 * f / dfd).ln_1p()).exp();
        assert_rel(f_sf(f, 2.0, dfd), want, RTOL, "F(2, dfd)");
    }
    // 1 / F swaps the degrees of freedom: P(F(a, b) > f) = 1 - P(F(b, a) > 1 / f).
    for (f, a, b) in [(0.7, 3.0, 8.0), (2.5, 12.0, 40.0), (1.0, 300.0, 90.0)] {
        let sum = f_sf(f, a, b) + f_sf(1.0 / f, b, a);
        assert!((sum - 1.0).abs() < 1e-14, "F({a}, {b}) at {f}: {sum}");
    }
}

#[test]
fn f_sf_edge_cases() {
    assert_eq!(f_sf(0.0, 3.0, 4.0), 1.0);
    assert_eq!(f_sf(-1.0, 3.0, 4.0), 1.0);
    assert_eq!(f_sf(f64::INFINITY, 3.0, 4.0), 0.0);
    for (dfn, dfd) in [
        (0.0, 4.0),
        (3.0, 0.0),
        (-1.0, 4.0),
        (f64::INFINITY, 4.0),
        (3.0, f64::NAN),
    ] {
        assert!(f_sf(2.0, dfn, dfd).is_nan(), "dof ({dfn}, {dfd})");
    }
    assert!(f_sf(f64::NAN, 3.0, 4.0).is_nan());
}

#[test]
fn special_functions_agree_with_closed_forms() {
    // Γ(n) = (n - 1)!, Γ(1/2) = sqrt(π), ln Γ by Stirling above 10.
    let mut fact = 1.0f64;
    for n in 1..=170 {
        let got = ln_gamma(f64::from(n));
        assert!(
            (got - fact.ln()).abs() <= 4e-15 * fact.ln().abs().max(1.0),
            "n {n}"
        );
        fact *= f64::from(n);
    }
    assert!((ln_gamma(1e-300) - 1e300f64.ln()).abs() < 1e-12);
    assert!(ln_gamma(0.0).is_nan() && ln_gamma(-1.0).is_nan());
    // P + Q = 1 and Q(1, x) = e^{-x}.
    for (a, x) in [(0.5, 0.2), (3.0, 2.0), (40.0, 45.0), (1e4, 9900.0)] {
        assert!((gamma_p(a, x) + gamma_q(a, x) - 1.0).abs() <= 2.0 * f64::EPSILON);
    }
    assert_rel(gamma_q(1.0, 7.5), (-7.5f64).exp(), RTOL, "Q(1, x)");
    // I_x(1, b) = 1 - (1 - x)^b.
    for (b, x) in [(0.5f64, 0.3f64), (4.0, 0.01), (50.0, 0.2)] {
        let want = -(b * (-x).ln_1p()).exp_m1();
        assert_rel(beta_inc(1.0, b, x), want, RTOL, "I_x(1, b)");
    }
    assert!(beta_inc(2.0, 3.0, 1.5).is_nan() && beta_inc(0.0, 3.0, 0.5).is_nan());
    assert_eq!(
        (beta_inc(2.0, 3.0, 0.0), beta_inc(2.0, 3.0, 1.0)),
        (0.0, 1.0)
    );
}

#[test]
fn paired_test_values_and_conventions() {
    // mean 2, sd 1, n 3: t = 2 sqrt(3), p = t_sf(t, 2).
    let test = paired_test(&[1.0, 2.0, 3.0]);
    assert_eq!(test.n, 3);
    assert!((test.t - 2.0 * 3f64.sqrt()).abs() < 1e-14);
    assert_eq!(test.p, t_sf(test.t, 2.0));
    // Scale does not change t, even where squares would overflow or underflow.
    for scale in [1e-300, 1e-170, 1e170, 1e300] {
        let scaled: Vec<f64> = [1.0, 2.0, 3.0].iter().map(|d| d * scale).collect();
        assert!(
            (paired_test(&scaled).t - test.t).abs() < 1e-14,
            "scale {scale}"
        );
    }
    // Fewer than two: nothing tested.
    for short in [&[][..], &[3.0][..]] {
        let s = paired_test(short);
        assert!(s.t.is_nan() && s.p == 1.0 && s.n == short.len());
    }
    // Non-finite: a failed comparison.
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        let s = paired_test(&[1.0, bad, 2.0]);
        assert!(s.t.is_nan() && s.p.is_nan() && s.n == 3);
    }
    // Zero variance.
    let up = paired_test(&[0.5, 0.5, 0.5]);
    assert_eq!((up.t, up.p), (f64::INFINITY, 0.0));
    for flat in [[0.0, -0.0, 0.0], [-2.0, -2.0, -2.0]] {
        let s = paired_test(&flat);
        assert_eq!((s.t, s.p), (0.0, 1.0));
    }
    // A negative mean: p above one half.
    assert!(paired_test(&[-1.0, -2.0, 0.5]).p > 0.5);
}

#[test]
fn bonferroni_and_holm() {
    let p = [0.01, 0.04, 0.03, 0.5, f64::NAN];
    let b = bonferroni(&p, None).unwrap();
    let want_b = [0.05, 0.2, 0.15, 1.0];
    for (got, want) in b.iter().zip(want_b) {
        assert!((got - want).abs() < 1e-15);
    }
    assert!(b[4].is_nan());
    // Sorted 0.01, 0.03, 0.04, 0.5 (NaN last) over m = 5: 0.05, 0.12, 0.12 (the running
    // max over 0.04 * 3), 1.0.
    let h = holm(&p, None).unwrap();
    for (got, want) in h.iter().zip([0.05, 0.12, 0.12, 1.0]) {
        assert!((got - want).abs() < 1e-15, "{h:?}");
    }
    assert!(h[4].is_nan());
    // Over more tests than p-values given.
    assert_eq!(bonferroni(&[1e-4], Some(300)).unwrap(), vec![1e-4 * 300.0]);
    assert_eq!(holm(&[0.2, 1e-4], Some(10)).unwrap(), vec![1.0, 1e-3]);
    // Ties get equal values; empty input gives empty output.
    let tied = holm(&[0.02, 0.02, 0.001], None).unwrap();
    assert_eq!(tied[0], tied[1]);
    assert!(holm(&[], None).unwrap().is_empty() && bonferroni(&[], Some(3)).unwrap().is_empty());
    // Bad input.
    for bad in [[-0.1], [1.5]] {
        assert!(matches!(
            holm(&bad, None),
            Err(Error::InvalidParameter { name: "p", .. })
        ));
        assert!(matches!(
            bonferroni(&bad, None),
            Err(Error::InvalidParameter { name: "p", .. })
        ));
    }
    assert!(matches!(
        holm(&[0.1, 0.2], Some(1)),
        Err(Error::InvalidParameter {
            name: "n_tests",
            ..
        })
    ));
}

#[test]
fn acceptance_rule() {
    let rule = AcceptanceRule::new(0.1, 0.01).unwrap();
    assert_eq!((rule.min_improvement(), rule.alpha()), (0.1, 0.01));
    let current = [4.0, 5.0, 4.5, 5.5, 4.8];
    let better = [1.0, 1.2, 0.9, 1.1, 1.0];
    let v = rule.judge(&current, &better).unwrap();
    let cut = 1.0 - (better.iter().sum::<f64>() / current.iter().sum::<f64>()).sqrt();
    assert!(v.accepted && v.cut == cut && v.n == 5);
    let diff: Vec<f64> = current.iter().zip(better).map(|(c, k)| c - k).collect();
    let test = paired_test(&diff);
    assert_eq!((v.t, v.p_sum), (test.t, test.p));
    let logs: Vec<f64> = current
        .iter()
        .zip(better)
        .map(|(c, k)| c.ln() - k.ln())
        .collect();
    assert_eq!(v.p_log, paired_test(&logs).p);
    assert_eq!(v.p_sign, sign_test(&diff));
    assert_eq!(v.p, (3.0 * v.p_sum.min(v.p_log).min(v.p_sign)).min(1.0));
    // A cut on most blocks while one block dominates the total: the log ratio sees it.
    let broad = rule
        .judge(
            &[20.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0],
            &[14.0, 0.4, 0.35, 0.4, 0.45, 0.4, 0.35, 0.4],
        )
        .unwrap();
    assert!(broad.cut > 0.2 && broad.p_sum > 0.01 && broad.p_log < 1e-4 && broad.accepted);
    // A big cut that is not significant (one block carries it) is refused.
    let lucky = rule
        .judge(&[1.0, 1.0, 1.0, 9.0], &[1.1, 0.9, 1.05, 0.5])
        .unwrap();
    assert!(lucky.cut > 0.4 && lucky.p >= 0.01 && !lucky.accepted);
    // A significant change below the least improvement is refused.
    let small = rule
        .judge(&[1.0; 6], &[0.95, 0.96, 0.95, 0.94, 0.95, 0.96])
        .unwrap();
    assert!(small.p < 0.01 && small.cut < 0.1 && !small.accepted);
    // No error before: cut 0. NaN: refused. Fewer than two blocks: p = 1.
    assert_eq!(rule.judge(&[0.0, 0.0], &[0.0, 0.0]).unwrap().cut, 0.0);
    // NaN before: cut 0 (as for no error); NaN after: cut NaN; both refused.
    let nan = rule.judge(&[1.0, f64::NAN, 1.0], &[0.1, 0.1, 0.1]).unwrap();
    assert!(!nan.accepted && nan.cut == 0.0 && nan.p.is_nan());
    let nan = rule.judge(&[1.0, 1.0, 1.0], &[0.1, f64::NAN, 0.1]).unwrap();
    assert!(!nan.accepted && nan.cut.is_nan() && nan.t.is_nan());
    let one = rule.judge(&[5.0], &[1.0]).unwrap();
    assert!(!one.accepted && one.p == 1.0);
    assert!(matches!(
        rule.judge(&[1.0, 2.0], &[1.0]),
        Err(Error::Shape {
            expected: 2,
            got: 1,
            ..
        })
    ));
    for (mi, alpha) in [
        (-0.1, 0.01),
        (1.0, 0.01),
        (f64::NAN, 0.01),
        (0.1, 0.0),
        (0.1, 1.0),
    ] {
        assert!(AcceptanceRule::new(mi, alpha).is_err(), "({mi}, {alpha})");
    }
}

mod properties {
    use proptest::prelude::*;

    use super::super::*;

    /// Degrees of freedom from 0.5 to 1e5, spread over the decades.
    fn dof() -> impl Strategy<Value = f64> {
        (-0.3f64..5.0).prop_map(|e| 10f64.powf(e))
    }

    proptest! {
        #[test]
        fn t_tails_add_up_to_one(t in -1e3f64..1e3, dof in dof()) {
            let sum = t_sf(t, dof) + t_sf(-t, dof);
            prop_assert!((sum - 1.0).abs() <= 2.0 * f64::EPSILON, "sum {sum}");
        }

        #[test]
        fn f_with_one_numerator_dof_is_t_squared(t in 0.01f64..30.0, dof in dof()) {
            let (f, two_t) = (f_sf(t * t, 1.0, dof), 2.0 * t_sf(t, dof));
            // t² rounds once (relative ε); the tail's log-derivative in t is below dof + 1.
            let tol = 1e-13 + 4.0 * f64::EPSILON * (dof + 1.0);
            prop_assert!(((f - two_t) / two_t).abs() <= tol || two_t < 1e-300, "{f} vs {two_t}");
        }

        #[test]
        fn survival_falls_with_the_statistic(x in 0.0f64..2e5, step in 1e-6f64..1.0, dof in dof()) {
            // Monotone up to the 2e-13 relative accuracy (the series and the continued
            // fraction meet at x = dof/2 + 1).
            let (lo, hi) = (chi2_sf(x, dof), chi2_sf(x * (1.0 + step) + step, dof));
            prop_assert!(hi <= lo * (1.0 + 2e-13), "chi2 {lo} then {hi}");
            let (lo, hi) = (f_sf(x, 3.0, dof), f_sf(x * (1.0 + step) + step, 3.0, dof));
            prop_assert!(hi <= lo * (1.0 + 2e-13), "F {lo} then {hi}");
        }

        #[test]
        fn holm_lies_between_p_and_bonferroni(
            p in prop::collection::vec(0.0f64..=1.0, 0..40),
            extra in 0usize..20,
        ) {
            let m = Some(p.len() + extra);
            let (h, b) = (holm(&p, m).unwrap(), bonferroni(&p, m).unwrap());
            for i in 0..p.len() {
                prop_assert!(p[i] <= h[i] && h[i] <= b[i] && h[i] <= 1.0);
                for j in 0..p.len() {
                    if p[i] <= p[j] {
                        prop_assert!(h[i] <= h[j], "order kept");
                    }
                }
            }
        }

        #[test]
        fn paired_t_is_odd_and_scale_free(
            d in prop::collection::vec(-1e3f64..1e3, 2..60),
            k in -900i32..900,
        ) {
            prop_assume!(d.iter().any(|&v| v != d[0]));
            let base = paired_test(&d);
            let neg: Vec<f64> = d.iter().map(|v| -v).collect();
            let flipped = paired_test(&neg);
            prop_assert_eq!(flipped.t, -base.t);
            prop_assert!((flipped.p + base.p - 1.0).abs() <= 2.0 * f64::EPSILON);
            // A power of two scales exactly: the same bits.
            let scaled: Vec<f64> = d.iter().map(|v| v * 2f64.powi(k)).collect();
            prop_assert_eq!(paired_test(&scaled).t.to_bits(), base.t.to_bits());
        }

        #[test]
        fn a_candidate_equal_to_the_current_model_is_refused(
            sse in prop::collection::vec(0.0f64..1e6, 0..50),
            min_improvement in 0.0f64..0.9,
        ) {
            let v = AcceptanceRule::new(min_improvement, 0.5).unwrap().judge(&sse, &sse).unwrap();
            prop_assert!(!v.accepted && v.cut == 0.0 && (v.p == 1.0 || v.n < 2));
        }
    }
}

#[test]
fn sign_test_is_the_binomial_tail() {
    // Every one of n positive: 2^-n; zeros are no evidence; NaN in, NaN out.
    for n in 1..=40 {
        assert_eq!(sign_test(&vec![1.0; n]), 0.5f64.powi(n as i32), "{n}");
    }
    assert_eq!(sign_test(&[1.0, -1.0]), 0.75);
    assert_eq!(sign_test(&[2.0, 0.0, 3.0, 0.0]), 0.25);
    assert_eq!(sign_test(&[0.0, 0.0]), 1.0);
    assert_eq!(sign_test(&[]), 1.0);
    assert!(sign_test(&[1.0, f64::NAN]).is_nan());
    // 8 of 10: (C(10,8) + C(10,9) + C(10,10)) / 1024 = 56 / 1024.
    let d = [1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, -1.0, -1.0];
    assert!((sign_test(&d) - 56.0 / 1024.0).abs() < 1e-16);
    // Past 1000 differences, in log space: the same tail as the direct sum, to 1e-12.
    let many: Vec<f64> = (0..1200)
        .map(|i| if i % 2 == 0 || i % 7 == 0 { 1.0 } else { -1.0 })
        .collect();
    let k = many.iter().filter(|d| **d > 0.0).count();
    let direct: f64 = (k..=1200)
        .map(|j| {
            (ln_gamma(1201.0)
                - ln_gamma(j as f64 + 1.0)
                - ln_gamma((1200 - j) as f64 + 1.0)
                - 1200.0 * std::f64::consts::LN_2)
                .exp()
        })
        .sum();
    assert!(
        (sign_test(&many) - direct).abs() <= 1e-12 * direct,
        "{} {direct}",
        sign_test(&many)
    );
}

#[test]
fn a_cut_on_every_block_of_a_few_passes_where_its_size_varies() {
    // A heating sweep's curvature: nine held-out blocks, the two coldest cut 100-fold,
    // every other a little (PX4-style log of the interop round). Both t-tests give p
    // about 0.04; the sign test 2^-9, so p = 3 * 2^-9 < 0.01.
    let rule = AcceptanceRule::new(0.1, 0.01).unwrap();
    let before = [342.2, 84.31, 15.41, 5.36, 4.5, 5.32, 2.82, 4.13, 2.86];
    let after = [2.59, 2.81, 2.8, 2.47, 2.84, 2.74, 2.8, 2.68, 2.46];
    let v = rule.judge(&before, &after).unwrap();
    assert!(v.p_sum > 0.01 && v.p_log > 0.01, "{v:?}");
    assert_eq!(v.p_sign, 0.5f64.powi(9));
    assert!(
        v.accepted && (v.p - 3.0 * 0.5f64.powi(9)).abs() < 1e-18,
        "{v:?}"
    );
    // One block of the nine made worse: the sign test's 10/512, no longer enough.
    let mut worse = after;
    worse[6] = 2.9;
    assert!(!rule.judge(&before, &worse).unwrap().accepted);
}
