//! The JSON-lines sample format of `fusiond replay` and `fusion-sim` (feature `json`).
//!
//! ```text
//! {"imu": {"t_ns": 1000000, "sensor": 0, "seq": 0, "accel": [ax, ay, az], "gyro": [gx, gy, gz]}}
//! {"position": {"t_ns": 1100000, "sensor": 1, "seq": 0, "pos": [x, y, z], "cov": [9 numbers, row-major]}}
//! {"velocity": {"t_ns": 1100000, "sensor": 2, "seq": 0, "vel": [vx, vy, vz], "cov": [9 numbers, row-major]}}
//! ```
//!
//! Each kind's fields are defined beside its wire type (`sample/<kind>.rs`).
//!
//! Unknown fields, wrong array lengths and numbers out of range are errors.

use crate::Sample;

/// Parses one line; the error text says what is wrong and where in the line.
pub fn parse_sample(line: &str) -> Result<Sample, serde_json::Error> {
    serde_json::from_str(line)
}

/// Formats a sample as one line (no newline); numbers round-trip exactly.
pub fn format_sample(sample: &Sample) -> String {
    // Serialising plain numbers and arrays cannot fail; non-finite floats become null.
    serde_json::to_string(sample).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{ImuSample, PositionSample, VelocitySample};

    #[test]
    fn lines_round_trip_exactly() {
        let imu = Sample::Imu(ImuSample::new(7, 2, 3, [0.1, 1.0 / 3.0, -2e-300], [1e300, 0.0, -0.5]));
        assert_eq!(parse_sample(&format_sample(&imu)).unwrap(), imu);
        let pos = Sample::Position(PositionSample::new(9, 0, 0, [std::f64::consts::PI; 3], [1.0; 9]));
        assert_eq!(parse_sample(&format_sample(&pos)).unwrap(), pos);
        let vel = Sample::Velocity(VelocitySample::new(11, 4, 8, [1.5, -0.25, 1e-9], [0.01; 9]));
        let line = format_sample(&vel);
        assert!(line.starts_with(r#"{"velocity":{"t_ns":11,"sensor":4,"seq":8,"vel":[1.5,"#), "{line}");
        assert_eq!(parse_sample(&line).unwrap(), vel);
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
        assert!(matches!(parse_sample(b).unwrap(), Sample::Position(s) if s.header.sensor == 1));
    }
}
