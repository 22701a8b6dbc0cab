//! The JSON-lines sample format of `fusiond replay` and `fusion-sim` (feature `json`).
//!
//! ```text
//! {"imu": {"t_ns": 1000000, "sensor": 0, "seq": 0, "accel": [ax, ay, az], "gyro": [gx, gy, gz]}}
//! {"position": {"t_ns": 1100000, "sensor": 1, "seq": 0, "pos": [x, y, z], "cov": [9 numbers, row-major]}}
//! ```
//!
//! Unknown fields, wrong array lengths and numbers out of range are errors.

use serde::{Deserialize, Serialize};

use crate::{ImuSample, PositionSample, Sample};

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields, rename_all = "lowercase")]
enum Line {
    Imu(ImuLine),
    Position(PositionLine),
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ImuLine {
    t_ns: u64,
    sensor: u32,
    seq: u64,
    accel: [f64; 3],
    gyro: [f64; 3],
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct PositionLine {
    t_ns: u64,
    sensor: u32,
    seq: u64,
    pos: [f64; 3],
    cov: [f64; 9],
}

/// Parses one line; the error text says what is wrong and where in the line.
pub fn parse_sample(line: &str) -> Result<Sample, serde_json::Error> {
    Ok(match serde_json::from_str::<Line>(line)? {
        Line::Imu(s) => Sample::Imu(ImuSample {
            t_ns: s.t_ns,
            sent_ns: 0,
            seq: s.seq,
            sensor: s.sensor,
            _reserved: 0,
            accel_mps2: s.accel,
            gyro_radps: s.gyro,
        }),
        Line::Position(s) => Sample::Position(PositionSample {
            t_ns: s.t_ns,
            sent_ns: 0,
            seq: s.seq,
            sensor: s.sensor,
            _reserved: 0,
            pos_m: s.pos,
            cov_m2: s.cov,
        }),
    })
}

/// Formats a sample as one line (no newline); numbers round-trip exactly.
pub fn format_sample(sample: &Sample) -> String {
    let line = match *sample {
        Sample::Imu(s) => {
            Line::Imu(ImuLine { t_ns: s.t_ns, sensor: s.sensor, seq: s.seq, accel: s.accel_mps2, gyro: s.gyro_radps })
        }
        Sample::Position(s) => {
            Line::Position(PositionLine { t_ns: s.t_ns, sensor: s.sensor, seq: s.seq, pos: s.pos_m, cov: s.cov_m2 })
        }
    };
    // Serialising plain numbers and arrays cannot fail; non-finite floats become null.
    serde_json::to_string(&line).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_round_trip_exactly() {
        let imu = Sample::Imu(ImuSample {
            t_ns: 7,
            sent_ns: 0,
            seq: 3,
            sensor: 2,
            _reserved: 0,
            accel_mps2: [0.1, 1.0 / 3.0, -2e-300],
            gyro_radps: [1e300, 0.0, -0.5],
        });
        assert_eq!(parse_sample(&format_sample(&imu)).unwrap(), imu);
        let pos = Sample::Position(PositionSample {
            t_ns: 9,
            cov_m2: [1.0; 9],
            pos_m: [std::f64::consts::PI; 3],
            ..Default::default()
        });
        assert_eq!(parse_sample(&format_sample(&pos)).unwrap(), pos);
    }

    #[test]
    fn random_doubles_round_trip_bit_for_bit() {
        // A simple LCG over the bit patterns of finite doubles of every magnitude.
        let mut state = 0x2545_f491_4f6c_dd1du64;
        for _ in 0..20_000 {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            let v = f64::from_bits(state >> 1);
            if !v.is_finite() {
                continue;
            }
            let s = Sample::Imu(ImuSample { accel_mps2: [v, -v, v * 1e-3], ..Default::default() });
            let back = parse_sample(&format_sample(&s)).unwrap();
            let Sample::Imu(b) = back else { panic!() };
            assert_eq!(b.accel_mps2.map(f64::to_bits), [v, -v, v * 1e-3].map(f64::to_bits), "{v:e}");
        }
    }

    #[test]
    fn the_documented_example_parses() {
        let a = r#"{"imu": {"t_ns": 1000000, "sensor": 0, "seq": 0, "accel": [1, 2, 3], "gyro": [0.1, 0.2, 0.3]}}"#;
        assert!(matches!(parse_sample(a).unwrap(), Sample::Imu(s) if s.accel_mps2 == [1.0, 2.0, 3.0]));
        let b =
            r#"{"position": {"t_ns": 1100000, "sensor": 1, "seq": 0, "pos": [1, 2, 3], "cov": [1,0,0,0,1,0,0,0,1]}}"#;
        assert!(matches!(parse_sample(b).unwrap(), Sample::Position(s) if s.sensor == 1));
    }
}
