//! A GNSS receiver's view of its fix's quality, mapped to the noise the fix is
//! fused with (`[sensor.quality]` of a sensor with kind `geodetic`).
//!
//! A receiver reports, with each fix, its fix type (no fix, 2-D, 3-D, DGNSS,
//! RTK float, RTK fixed), the satellites used, its dilutions of precision and its
//! own accuracy estimate (the sample's covariance `R_r`). Those estimates are
//! often optimistic, and most in the fix types a receiver is least sure of: an
//! RTK receiver that loses its fixed ambiguities still says a few centimetres for
//! a while. The fix is fused with
//!
//! ```text
//! R = s R_r,  then  R_EE += d_h, R_NN += d_h,  R_UU += d_v
//! d_h = max(0, σ_h,min² − (R_EE + R_NN)/2),   σ_h,min = max(floor_h[fix], HDOP · UERE)
//! d_v = max(0, σ_v,min² − R_UU),               σ_v,min = max(floor_v[fix], VDOP · UERE)
//! ```
//!
//! (`s` is `covariance_scale`; the floors lift the horizontal and vertical
//! variances to what the fix type is worth: adding to the diagonal keeps `R`
//! positive definite and its correlations; `UERE` is the user-equivalent range
//! error, so `HDOP · UERE` is the textbook horizontal σ, Kaplan & Hegarty,
//! *Understanding GPS/GNSS* (3rd ed. 2017), §11.2). A change of fix type
//! changes `R` with the very fix it comes with: the gate and the update see the
//! worse fix as worse, so a jump from RTK fixed to float or to a single-point fix
//! moves the estimate by what that fix is worth, not by its distance.
//!
//! Fix types in `refuse` (by default `none`) and fixes with fewer satellites than
//! `min_satellites` (when the receiver reports them) are refused and counted as
//! refused. Without a `[sensor.quality]` table a fix is fused with its reported
//! covariance, and only `none` is refused.

use std::collections::BTreeMap;

use fusion_shared::{GeodeticSample, fix};
use serde::Deserialize;

use crate::setting::{ConfigError, invalid};

/// `[sensor.quality]` as written.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct QualityConfig {
    /// Fix types refused, by name (`unknown`, `none`, `2d`, `3d`, `dgnss`,
    /// `rtk_float`, `rtk_fixed`); default `["none"]`.
    #[serde(default = "QualityConfig::default_refuse")]
    pub refuse: Vec<String>,
    /// Factor on the reported covariance (default 1).
    #[serde(default = "QualityConfig::default_scale")]
    pub covariance_scale: f64,
    /// Least horizontal σ per fix type name, m (default none).
    #[serde(default)]
    pub horizontal_floor_m: BTreeMap<String, f64>,
    /// Least vertical σ per fix type name, m (default none).
    #[serde(default)]
    pub vertical_floor_m: BTreeMap<String, f64>,
    /// User-equivalent range error, m: with it, `HDOP · uere_m` and `VDOP ·
    /// uere_m` are floors too (default 0: not used).
    #[serde(default)]
    pub uere_m: f64,
    /// Fewest satellites a fix may use, when the receiver reports them (default 0).
    #[serde(default)]
    pub min_satellites: u32,
}

impl QualityConfig {
    fn default_refuse() -> Vec<String> {
        vec!["none".to_string()]
    }
    fn default_scale() -> f64 {
        1.0
    }
}

/// The largest σ floor or UERE accepted, m.
pub const MAX_FLOOR_M: f64 = 1000.0;

/// The mapping of a receiver's quality to noise, checked (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GnssQuality {
    /// Bit `c` set: fix type code `c` is refused.
    refused: u32,
    scale: f64,
    /// Horizontal and vertical variance floors by fix type code, m².
    floor_h: [f64; fix::COUNT],
    floor_v: [f64; fix::COUNT],
    /// UERE², m².
    uere2: f64,
    min_satellites: i32,
}

impl Default for GnssQuality {
    /// No mapping: the reported covariance; fix type `none` refused.
    fn default() -> Self {
        Self {
            refused: 1 << fix::NONE,
            scale: 1.0,
            floor_h: [0.0; fix::COUNT],
            floor_v: [0.0; fix::COUNT],
            uere2: 0.0,
            min_satellites: 0,
        }
    }
}

/// Why a fix is not fused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Refused {
    /// Its fix type is in `refuse`.
    FixType,
    /// It used fewer satellites than `min_satellites`.
    Satellites,
}

impl GnssQuality {
    /// The mapping of a `[sensor.quality]` table; `key` names a field for errors.
    pub fn from_config(c: &QualityConfig, key: impl Fn(&str) -> String) -> Result<Self, ConfigError> {
        let code = |field: &str, name: &str| {
            fix::from_name(name).ok_or_else(|| {
                invalid(key(field), format!("unknown fix type {name:?}; known: {}", fix::NAMES.join(", ")))
            })
        };
        let mut q = Self { refused: 0, ..Self::default() };
        for name in &c.refuse {
            q.refused |= 1 << code("refuse", name)?;
        }
        if !(c.covariance_scale.is_finite() && c.covariance_scale > 0.0 && c.covariance_scale <= MAX_FLOOR_M) {
            return Err(invalid(
                key("covariance_scale"),
                format!("must be a finite number in (0, {MAX_FLOOR_M}], got {}", c.covariance_scale),
            ));
        }
        q.scale = c.covariance_scale;
        for (field, table, floors) in [
            ("horizontal_floor_m", &c.horizontal_floor_m, &mut q.floor_h),
            ("vertical_floor_m", &c.vertical_floor_m, &mut q.floor_v),
        ] {
            for (name, sd) in table {
                let i = code(field, name)? as usize;
                if !(sd.is_finite() && *sd >= 0.0 && *sd <= MAX_FLOOR_M) {
                    return Err(invalid(
                        key(field),
                        format!("{name}: must be a finite number of metres in [0, {MAX_FLOOR_M}], got {sd}"),
                    ));
                }
                floors[i] = sd * sd;
            }
        }
        if !(c.uere_m.is_finite() && c.uere_m >= 0.0 && c.uere_m <= MAX_FLOOR_M) {
            return Err(invalid(
                key("uere_m"),
                format!("must be a finite number of metres in [0, {MAX_FLOOR_M}], got {}", c.uere_m),
            ));
        }
        q.uere2 = c.uere_m * c.uere_m;
        if c.min_satellites > fix::MAX_SATELLITES as u32 {
            return Err(invalid(key("min_satellites"), format!("at most {}", fix::MAX_SATELLITES)));
        }
        q.min_satellites = c.min_satellites as i32;
        Ok(q)
    }

    /// Whether fix type `code` is refused.
    pub fn refuses(&self, code: u32) -> bool {
        code < 32 && self.refused & (1 << code) != 0
    }

    /// The covariance `fix` is fused with (row-major ENU, m²), or why it is
    /// refused. `fix` is valid (checked by its kind's validation).
    pub fn noise(&self, f: &GeodeticSample) -> Result<[f64; 9], Refused> {
        if self.refuses(f.fix_type) {
            return Err(Refused::FixType);
        }
        if f.satellites > 0 && f.satellites < self.min_satellites {
            return Err(Refused::Satellites);
        }
        let code = (f.fix_type as usize).min(fix::COUNT - 1);
        let mut r = f.cov_enu_m2;
        if self.scale != 1.0 {
            r.iter_mut().for_each(|v| *v *= self.scale);
        }
        let min_h = self.floor_h[code].max(f.hdop * f.hdop * self.uere2);
        let min_v = self.floor_v[code].max(f.vdop * f.vdop * self.uere2);
        let d_h = min_h - 0.5 * (r[0] + r[4]);
        if d_h > 0.0 {
            r[0] += d_h;
            r[4] += d_h;
        }
        let d_v = min_v - r[8];
        if d_v > 0.0 {
            r[8] += d_v;
        }
        Ok(r)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn config(text: &str) -> Result<GnssQuality, ConfigError> {
        let c: QualityConfig = toml::from_str(text).map_err(|e| invalid("quality", e.to_string()))?;
        GnssQuality::from_config(&c, |f| format!("quality.{f}"))
    }

    const COV: [f64; 9] = [0.01, 0.002, 0.0, 0.002, 0.01, 0.0, 0.0, 0.0, 0.04];

    fn fix(code: u32, sats: i32, hdop: f64, vdop: f64) -> GeodeticSample {
        GeodeticSample::new(0, 3, 0, 48.1, 11.5, 500.0, COV).with_quality(code, sats, hdop, vdop)
    }

    #[test]
    fn without_a_table_the_reported_covariance_is_used_bit_for_bit_and_no_fix_is_refused() {
        let q = GnssQuality::default();
        assert_eq!(q.noise(&fix(fix::UNKNOWN, 0, 0.0, 0.0)), Ok(COV));
        assert_eq!(q.noise(&fix(fix::RTK_FIXED, 20, 0.6, 0.9)), Ok(COV));
        assert_eq!(q.noise(&fix(fix::NONE, 0, 0.0, 0.0)), Err(Refused::FixType));
    }

    #[test]
    fn floors_per_fix_type_lift_the_variances_and_keep_the_correlation() {
        let q = config(
            "refuse = [\"none\", \"2d\"]\ncovariance_scale = 2.0\n\
             horizontal_floor_m = { rtk_fixed = 0.02, rtk_float = 0.3, \"3d\" = 2.0 }\n\
             vertical_floor_m = { \"3d\" = 3.0 }\n",
        )
        .unwrap();
        // RTK fixed: the scaled report (0.02 m², σ 0.14 m) is above its floor.
        let r = q.noise(&fix(fix::RTK_FIXED, 20, 0.0, 0.0)).unwrap();
        assert_eq!(r, COV.map(|v| v * 2.0));
        // RTK float: lifted to σ_h 0.3 m on both axes, correlation kept.
        let r = q.noise(&fix(fix::RTK_FLOAT, 20, 0.0, 0.0)).unwrap();
        assert!((0.5 * (r[0] + r[4]) - 0.09).abs() < 1e-15, "{r:?}");
        assert_eq!((r[1], r[3], r[8]), (0.004, 0.004, 0.08));
        // 3-D: 2 m and 3 m.
        let r = q.noise(&fix(fix::THREE_D, 20, 0.0, 0.0)).unwrap();
        assert!((r[0] - 4.0).abs() < 1e-12 && (r[8] - 9.0).abs() < 1e-12, "{r:?}");
        assert_eq!(q.noise(&fix(fix::TWO_D, 20, 0.0, 0.0)), Err(Refused::FixType));
        assert_eq!(q.noise(&fix(fix::NONE, 20, 0.0, 0.0)), Err(Refused::FixType));
        // Not reported: no floor of its own.
        assert_eq!(q.noise(&fix(fix::UNKNOWN, 0, 0.0, 0.0)).unwrap(), COV.map(|v| v * 2.0));
    }

    #[test]
    fn dilution_times_uere_is_a_floor_and_few_satellites_are_refused() {
        let q = config("uere_m = 1.5\nmin_satellites = 6\n").unwrap();
        let r = q.noise(&fix(fix::THREE_D, 9, 1.2, 2.0)).unwrap();
        assert!((0.5 * (r[0] + r[4]) - (1.2f64 * 1.5).powi(2)).abs() < 1e-12, "{r:?}");
        assert!((r[8] - 9.0).abs() < 1e-12, "{r:?}");
        assert_eq!(q.noise(&fix(fix::THREE_D, 4, 1.2, 2.0)), Err(Refused::Satellites));
        assert!(q.noise(&fix(fix::THREE_D, 0, 1.2, 2.0)).is_ok(), "satellites not reported");
    }

    #[test]
    fn absurd_tables_are_refused_with_the_key() {
        let err = |t: &str| config(t).unwrap_err().to_string();
        assert!(err("refuse = [\"rtk\"]\n").contains("quality.refuse"));
        assert!(err("covariance_scale = 0\n").contains("quality.covariance_scale"));
        assert!(err("covariance_scale = nan\n").contains("quality.covariance_scale"));
        assert!(err("horizontal_floor_m = { \"3d\" = -1 }\n").contains("quality.horizontal_floor_m"));
        assert!(err("vertical_floor_m = { float = 1 }\n").contains("quality.vertical_floor_m"));
        assert!(err("uere_m = inf\n").contains("quality.uere_m"));
        assert!(err("min_satellites = 1000\n").contains("quality.min_satellites"));
        assert!(err("hdop_scale = 1\n").contains("hdop_scale"), "unknown keys are errors");
    }
}
