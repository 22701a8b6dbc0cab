//! Reads the latest fused state with the typed accessors of `fusion-client` only.
//! Prints `key value` lines (floats in Rust's round-trip form).

use std::time::Duration;

use fusion_client::{Client, Health};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let namespace = std::env::args().nth(1).unwrap_or_else(|| "fusion".to_string());
    let client = Client::connect(&namespace)?;
    let mut state = client.state_subscriber()?;
    let s = match state.latest()? {
        Some(s) => *s,
        None => *state.wait_next(Duration::from_secs(5))?.ok_or("no snapshot within 5 s")?,
    };
    let model = s.model().ok_or("unknown model")?;
    println!("seq {}", s.seq);
    println!("model {model}");
    println!("position {:?}", s.position().ok_or("no position")?);
    println!("position_std {:?}", s.position_std().ok_or("no position σ")?);
    println!("velocity {:?}", s.velocity().ok_or("no velocity")?);
    println!("velocity_std {:?}", s.velocity_std().ok_or("no velocity σ")?);
    if let (Some(q), Some(rpy)) = (s.attitude(), s.roll_pitch_yaw()) {
        println!("attitude {q:?}");
        println!("roll_pitch_yaw_deg {:?}", rpy.map(f64::to_degrees));
        println!("gyro_bias {:?}", s.gyro_bias().ok_or("no gyro bias")?);
    }
    let health = match s.health() {
        Health::Ok => "ok".to_string(),
        Health::Initialising => "initialising".to_string(),
        Health::Degraded => {
            let reasons: Vec<String> = s.health_reasons().map(|r| r.to_string()).collect();
            format!("degraded ({})", reasons.join(", "))
        }
        Health::Unknown(code) => format!("unknown code {code}"),
    };
    println!("health {health}");
    Ok(())
}
